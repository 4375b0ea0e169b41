"""The optimisation loop every training stage shares: 3DGS (paper Sec. 3.1), object-ID distillation
(Sec. 3.3, Eq. 3-4) and 3D inpainting (Sec. 3.5, Eq. 6).

What changes between them is injected:

* which Gaussian tensors train (each with a learning rate or a schedule ``step -> lr``) and which
  stay frozen, optionally which rows (Gaussians) may move at all;
* extra modules trained alongside (e.g. the identity classifier of Sec. 3.3);
* where views come from (:class:`SceneViews`: a scene's images; :class:`TargetList`: cameras with
  their own targets, e.g. inpainted virtual views with depth and masks);
* how a view is rendered (``render_fn``) and the loss (``loss_fn`` on the render output and the
  view's targets);
* the densification :class:`~inpaint360gs.gs.strategy.Strategy` (the base class: none).

One step: pick the next view (random order without replacement, reshuffled each epoch, 3DGS
``viewpoint_stack``), render, loss, backward, Adam steps, strategy, finite check. Everything random
draws from one seeded generator, and :meth:`OptimizationLoop.state_dict` holds all the state a
resumed run needs to continue bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import TrainingDivergedError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.gs.optim import Optimizers, Params, adam, as_gaussians, make_optimizers, make_params
from inpaint360gs.gs.strategy import DensifyStats, Strategy
from inpaint360gs.io.images import to_float
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.render.api import RenderOutput


@dataclass
class Target:
    """One supervision view: its camera and whatever the loss compares against (``"image"`` (H, W, 3)
    in [0, 1], and e.g. ``"depth"`` (H, W), ``"mask"`` (H, W) bool, ``"labels"`` (H, W) long)."""

    name: str
    camera: Camera
    data: dict[str, torch.Tensor] = field(default_factory=dict)


class ViewSource:
    """Where the views of an optimisation come from: ``len(source)`` views, ``source[i]`` a :class:`Target`."""

    def __len__(self) -> int:
        raise NotImplementedError

    def __getitem__(self, i: int) -> Target:
        raise NotImplementedError


class SceneViews(ViewSource):
    """A scene's views (default: its training views) with their images as ``"image"``.

    Pixels stay in their stored integer type until used (one byte per channel in memory). ``extra``
    maps a target name to a function ``view -> tensor`` for more per-view targets (e.g. object labels).
    """

    def __init__(self, scene: Scene, views: Sequence[View] | None = None, extra: Mapping[str, Callable[[View], torch.Tensor]] | None = None,
                 device: torch.device | str = "cpu"):  # fmt: skip
        self.views = list(scene.train_views if views is None else views)
        self.images = [torch.from_numpy(scene.load_image_raw(v)).to(device) for v in self.views]
        self.extra = {k: [fn(v) for v in self.views] for k, fn in (extra or {}).items()}

    def __len__(self) -> int:
        return len(self.views)

    def __getitem__(self, i: int) -> Target:
        v = self.views[i]
        data = {"image": to_float(self.images[i])}
        data.update({k: vals[i] for k, vals in self.extra.items()})
        return Target(v.name, v.camera, data)


class TargetList(ViewSource):
    """Explicit targets, e.g. virtual cameras with inpainted images, depths and masks."""

    def __init__(self, targets: Sequence[Target]):
        self.targets = list(targets)

    def __len__(self) -> int:
        return len(self.targets)

    def __getitem__(self, i: int) -> Target:
        return self.targets[i]


# render_fn(gaussians, target, step, generator) -> RenderOutput
RenderFn = Callable[[Gaussians, Target, int, torch.Generator], RenderOutput]
# loss_fn(render output, target, step) -> (scalar loss, {name: float} for logs)
LossFn = Callable[[RenderOutput, Target, int], tuple[torch.Tensor, dict[str, float]]]
LearningRate = float | Callable[[int], float]


@dataclass
class StepResult:
    step: int  # 0-based index of the step just taken
    target: Target
    out: RenderOutput
    loss: float
    logs: dict[str, float]
    stats: DensifyStats


class OptimizationLoop:
    """Optimise some tensors of ``gaussians`` (and ``modules``) on ``views``; call :meth:`step`.

    ``train`` maps Gaussian tensor names (``means``, ``log_scales``, ``quats``, ``opacity_logits``,
    ``sh0``, ``shN``, ``features``) to a learning rate or a schedule; every other tensor is frozen.
    ``modules`` maps names to ``(module, lr)`` trained with their own Adam. ``trainable_rows`` (N,)
    bool restricts which Gaussians move: the gradients of the others are zeroed before every Adam
    step, so their moments stay zero and they stay exactly where they are (a fixed set of Gaussians:
    not combined with a densifying strategy).
    """

    def __init__(
        self,
        gaussians: Gaussians,
        *,
        train: Mapping[str, LearningRate],
        views: ViewSource,
        render_fn: RenderFn,
        loss_fn: LossFn,
        strategy: Strategy | None = None,
        modules: Mapping[str, tuple[torch.nn.Module, float]] | None = None,
        trainable_rows: torch.Tensor | None = None,
        seed: int = 0,
        adam_eps: float = 1e-15,
        on_step: Callable[[int, Params], None] | None = None,
    ):
        if len(views) == 0:
            raise ValueError("an optimisation needs at least one view")
        if trainable_rows is not None and strategy is not None and type(strategy) is not Strategy:
            raise ValueError("trainable_rows needs a fixed set of Gaussians (no densifying strategy)")
        torch.manual_seed(seed)
        self.generator = torch.Generator().manual_seed(seed)
        self.views = views
        self.render_fn = render_fn
        self.loss_fn = loss_fn
        self.strategy = strategy or Strategy()
        self.on_step = on_step  # called after each step's updates, before the finite check (inspection, tests)
        self.schedules = dict(train)
        self.params: Params = make_params(gaussians, self.schedules)
        self.adam_eps = adam_eps
        self.optimizers: Optimizers = make_optimizers(self.params, {k: self._lr(k, 0) for k in self.schedules}, adam_eps)
        self.modules = {k: m for k, (m, _) in (modules or {}).items()}
        self.module_optimizers = {k: adam(list(m.parameters()), lr, adam_eps) for k, (m, lr) in (modules or {}).items()}
        self.device = gaussians.means.device  # where the parameters live (CUDA for the gsplat backend)
        self.strategy_state = self.strategy.initialize_state(len(gaussians), self.device)
        self.trainable_rows = None if trainable_rows is None else trainable_rows.clone().bool()
        self.step_index = 0
        self.order = torch.zeros(0, dtype=torch.long)
        self.order_pos = 0

    # --- state ----------------------------------------------------------------------------------
    def _lr(self, name: str, step: int) -> float:
        lr = self.schedules[name]
        return float(lr(step)) if callable(lr) else float(lr)

    def gaussians(self) -> Gaussians:
        """The current model (its tensors are the live parameters)."""
        return as_gaussians(self.params)

    def detached(self) -> Gaussians:
        """The current Gaussians, detached and cloned."""
        return self.gaussians().map(lambda t: t.detach().clone())

    def state_dict(self) -> dict:
        """Everything :meth:`load_state_dict` needs to resume: step, parameters, optimiser and module states."""
        return {
            "step": self.step_index,
            "params": {k: p.detach().clone() for k, p in self.params.items()},
            "optimizers": {k: o.state_dict() for k, o in self.optimizers.items()},
            "modules": {k: m.state_dict() for k, m in self.modules.items()},
            "module_optimizers": {k: o.state_dict() for k, o in self.module_optimizers.items()},
            "strategy": {k: v.clone() for k, v in self.strategy_state.items()},
            "trainable_rows": self.trainable_rows,
            "generator": self.generator.get_state(),
            "torch_rng": torch.get_rng_state(),
            "order": self.order.clone(),
            "order_pos": self.order_pos,
        }

    def load_state_dict(self, data: dict) -> None:
        """Resume from a :meth:`state_dict`."""
        self.step_index = int(data["step"])
        self.params = {k: torch.nn.Parameter(t.to(self.device).clone(), requires_grad=k in self.schedules) for k, t in data["params"].items()}
        self.optimizers = make_optimizers(self.params, {k: self._lr(k, self.step_index) for k in self.schedules}, self.adam_eps)
        for k, o in self.optimizers.items():
            o.load_state_dict(data["optimizers"][k])
        for k, m in self.modules.items():
            m.load_state_dict(data["modules"][k])
            self.module_optimizers[k].load_state_dict(data["module_optimizers"][k])
        self.strategy_state = {k: v.to(self.device).clone() for k, v in data["strategy"].items()}
        self.trainable_rows = data["trainable_rows"]
        self.generator = torch.Generator()
        self.generator.set_state(data["generator"])
        torch.set_rng_state(data["torch_rng"])
        self.order = data["order"].clone()
        self.order_pos = int(data["order_pos"])

    # --- one step -------------------------------------------------------------------------------
    def _next_view(self) -> int:
        """Random order without replacement, reshuffled each epoch (3DGS ``viewpoint_stack``)."""
        if self.order_pos >= len(self.order):
            self.order = torch.randperm(len(self.views), generator=self.generator)
            self.order_pos = 0
        i = int(self.order[self.order_pos])
        self.order_pos += 1
        return i

    def _check_finite(self, step: int) -> None:
        for k, p in self.params.items():
            if k not in self.schedules:
                continue
            t = p.detach()
            # A NaN or inf anywhere makes the sum non-finite; the sum is one pass without a mask tensor
            # (~20x cheaper than isfinite().all() per step). Finite values whose sum overflows fall
            # through to the exact count, which finds nothing.
            if torch.isfinite(t.sum()):
                continue
            bad = int((~torch.isfinite(t)).sum())
            if bad:
                raise TrainingDivergedError(f"step {step}: parameter '{k}' has {bad} non-finite value(s)")

    def step(self) -> StepResult:
        """One optimisation step; raises :class:`TrainingDivergedError` on a non-finite loss or parameter."""
        step = self.step_index
        for k, o in self.optimizers.items():
            if callable(self.schedules[k]):
                for group in o.param_groups:
                    group["lr"] = self._lr(k, step)
        target = self.views[self._next_view()]
        out = self.render_fn(self.gaussians(), target, step, self.generator)
        loss, logs = self.loss_fn(out, target, step)
        if not torch.isfinite(loss):
            raise TrainingDivergedError(f"step {step}: loss is {loss.item()} (rendering view {target.name})")
        loss.backward()
        if self.trainable_rows is not None:
            frozen = ~self.trainable_rows
            for p in self.params.values():
                if p.grad is not None:
                    p.grad[frozen] = 0
        for o in (*self.optimizers.values(), *self.module_optimizers.values()):
            o.step()
            o.zero_grad(set_to_none=True)
        stats = self.strategy.step_post_backward(self.params, self.optimizers, self.strategy_state, step, out, target.camera, generator=self.generator)
        if self.on_step is not None:
            self.on_step(step, self.params)
        self._check_finite(step)
        self.step_index += 1
        return StepResult(step, target, out, float(loss.item()), logs, stats)


