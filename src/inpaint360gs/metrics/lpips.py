"""LPIPS v0.1 (Zhang et al. 2018) with the published AlexNet/VGG16 weights, in plain torch.

The paper reports LPIPS (Sec. 4 "Metrics", Tab. 1); its evaluation code uses the VGG network. This
module follows LPIPS v0.1 step by step: inputs in [0, 1] are mapped to [-1, 1] and through LPIPS's
ScalingLayer (shift ``[-.030, -.088, -.188]``, scale ``[.458, .448, .450]``); the backbone's five
ReLU outputs (alex: after each of the 5 convolutions; vgg: relu1_2, relu2_2, relu3_3, relu4_3,
relu5_3) are L2-normalised over channels (eps 1e-10), their squared difference goes through the
1x1 linear heads (no bias), each layer's map is averaged over space and the layers are summed.
``lpips_map`` instead upsamples each layer's map bilinearly to the input size and sums them (LPIPS
``spatial=True``), which the ROI convention averages over mask pixels (see ``masked.py``).

Weights come from :mod:`inpaint360gs.metrics.weights` (no download, no torchvision). Networks are
built once per (net, device, dtype), frozen and in eval mode; the functions stay differentiable
with respect to the images (the 3D inpainting loss uses LPIPS). When only one image of a pair
requires a gradient (a render against fixed ground truth), the other goes through the network
without autograd, so the backward pass covers one image.

VGG16 costs about 23 times AlexNet's multiply-adds per image, which is why the 3D inpainting loss
uses AlexNet on CPU. bfloat16 inputs run a bfloat16 copy of the network, faster on CPUs with
AVX512-BF16 and close to, not equal to, float32: an option for the loss, not for reported metrics.
Timings and the bfloat16 deviation: results/README.md, "Metrics" (``benchmarks/bench_metrics.py``).
"""

from __future__ import annotations

import functools
from typing import Literal

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from inpaint360gs.core.errors import InputError
from inpaint360gs.metrics.weights import flatten_arrays, load_numpy_pickle, lpips_weights_path

Net = Literal["vgg", "alex"]
# the smallest image side each network takes: AlexNet's 11/4 convolution and two 3/2 max-pools, VGG16's four 2/2 max-pools
MIN_SIDE: dict[str, int] = {"alex": 31, "vgg": 16}

# (out_channels, kernel, stride, padding) per convolution; "M" = max pool (kernel, stride)
_ALEX = [
    (64, 11, 4, 2), "tap", ("M", 3, 2),
    (192, 5, 1, 2), "tap", ("M", 3, 2),
    (384, 3, 1, 1), "tap",
    (256, 3, 1, 1), "tap",
    (256, 3, 1, 1), "tap",
]  # fmt: skip
_VGG16 = [
    (64, 3, 1, 1), (64, 3, 1, 1), "tap", ("M", 2, 2),
    (128, 3, 1, 1), (128, 3, 1, 1), "tap", ("M", 2, 2),
    (256, 3, 1, 1), (256, 3, 1, 1), (256, 3, 1, 1), "tap", ("M", 2, 2),
    (512, 3, 1, 1), (512, 3, 1, 1), (512, 3, 1, 1), "tap", ("M", 2, 2),
    (512, 3, 1, 1), (512, 3, 1, 1), (512, 3, 1, 1), "tap",
]  # fmt: skip
# every convolution is followed by a ReLU; "tap" marks where LPIPS taps that ReLU's output (slice end)
_LAYOUT = {"alex": (_ALEX, "AlexNet_0"), "vgg": (_VGG16, "VGG16_0")}
_SHIFT = (-0.030, -0.088, -0.188)
_SCALE = (0.458, 0.448, 0.450)


class LPIPSNet(nn.Module):
    """Backbone slices and linear heads of LPIPS v0.1; ``forward`` returns per-layer distance maps."""

    def __init__(self, net: Net, params: dict[str, np.ndarray]):
        super().__init__()
        layout, root = _LAYOUT[net]
        self.net = net
        self.slices = nn.ModuleList()
        layers: list[nn.Module] = []
        in_ch, conv_i = 3, 0
        for item in layout:
            if item == "tap":  # close the current slice
                self.slices.append(nn.Sequential(*layers))
                layers = []
            elif item[0] == "M":
                layers.append(nn.MaxPool2d(kernel_size=item[1], stride=item[2]))
            else:
                out_ch, k, stride, pad = item
                conv = nn.Conv2d(in_ch, out_ch, k, stride=stride, padding=pad)
                _set(conv.weight, params, f"{root}/Conv_{conv_i}/kernel", kernel=True)
                _set(conv.bias, params, f"{root}/Conv_{conv_i}/bias")
                layers += [conv, nn.ReLU(inplace=True)]
                in_ch, conv_i = out_ch, conv_i + 1
        self.lins = nn.ModuleList()
        for i, sl in enumerate(self.slices):
            ch = [m for m in sl if isinstance(m, nn.Conv2d)][-1].out_channels
            lin = nn.Conv2d(ch, 1, 1, bias=False)
            _set(lin.weight, params, f"NetLinLayer_{i}/Conv_0/kernel", kernel=True)
            self.lins.append(lin)
        self.register_buffer("shift", torch.tensor(_SHIFT).view(1, 3, 1, 1))
        self.register_buffer("scale", torch.tensor(_SCALE).view(1, 3, 1, 1))
        self.requires_grad_(False)
        self.to(memory_format=torch.channels_last)
        self.eval()

    def features(self, x: torch.Tensor) -> list[torch.Tensor]:
        """The 5 tapped ReLU outputs of images ``x`` (N, 3, H, W) in [0, 1]."""
        # channels-last is oneDNN's fast convolution layout on CPU
        x = ((2.0 * x - 1.0 - self.shift) / self.scale).contiguous(memory_format=torch.channels_last)
        feats = []
        for sl in self.slices:
            x = sl(x)
            feats.append(x)
        return feats

    def layer_maps(self, fa: list[torch.Tensor], fb: list[torch.Tensor]) -> list[torch.Tensor]:
        """Per-layer (N, 1, h_l, w_l) maps: heads applied to squared differences of normalised features."""
        return [lin((_normalize(a) - _normalize(b)) ** 2) for lin, a, b in zip(self.lins, fa, fb)]

    def pair_features(self, a: torch.Tensor, b: torch.Tensor) -> tuple[list[torch.Tensor], list[torch.Tensor]]:
        """Features of both image batches: one pass over their concatenation when no gradient is
        needed; otherwise separate passes, so that the backward pass runs only through the
        image(s) that require a gradient (a loss against a fixed ground truth)."""
        if torch.is_grad_enabled() and (a.requires_grad or b.requires_grad):
            return [self._features_maybe_no_grad(x) for x in (a, b)]  # type: ignore[return-value]
        feats = self.features(torch.cat([a, b]))
        n = len(a)
        return [f[:n] for f in feats], [f[n:] for f in feats]

    def _features_maybe_no_grad(self, x: torch.Tensor) -> list[torch.Tensor]:
        if x.requires_grad:
            return self.features(x)
        with torch.no_grad():
            return self.features(x)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> list[torch.Tensor]:
        """Per-layer (N, 1, h_l, w_l) distance maps between image batches ``a`` and ``b``."""
        return self.layer_maps(*self.pair_features(a, b))


def _normalize(f: torch.Tensor, eps: float = 1e-10) -> torch.Tensor:
    # LPIPS normalize_tensor; vector_norm has a zero (not NaN) gradient where all channels are 0
    return f / (torch.linalg.vector_norm(f, dim=1, keepdim=True) + eps)


def _set(param: torch.Tensor, params: dict[str, np.ndarray], key: str, *, kernel: bool = False) -> None:
    if key not in params:
        raise ValueError(f"entry {key} missing")
    arr = params[key].transpose(3, 2, 0, 1) if kernel else params[key]  # flax HWIO -> torch OIHW
    if tuple(arr.shape) != tuple(param.shape):
        raise ValueError(f"entry {key} has shape {tuple(arr.shape)}, expected {tuple(param.shape)}")
    with torch.no_grad():
        param.copy_(torch.from_numpy(np.ascontiguousarray(arr, dtype=np.float32)))


@functools.lru_cache(maxsize=2)
def _load_params(net: Net) -> tuple[dict[str, np.ndarray], str]:
    path = lpips_weights_path(net)
    try:
        return flatten_arrays(load_numpy_pickle(path)), str(path)
    except ValueError as e:
        raise InputError(f"unexpected LPIPS weights content ({e})", path) from None


@functools.lru_cache(maxsize=8)
def _cached_net(net: Net, device: str, dtype: torch.dtype) -> LPIPSNet:
    params, path = _load_params(net)
    # ordinary tensors even when first asked for inside inference_mode (evaluation), so that the
    # cached network also serves autograd later in the process (the inpainting loss)
    with torch.inference_mode(False):
        try:
            model = LPIPSNet(net, params)
        except ValueError as e:
            raise InputError(f"unexpected LPIPS weights content ({e})", path) from None
        return model.to(device=device, dtype=dtype)


def get_lpips_net(net: Net = "vgg", device: str | torch.device = "cpu", dtype: torch.dtype = torch.float32) -> LPIPSNet:
    """The frozen LPIPS network for ``net`` on ``device``/``dtype`` (built once, then cached)."""
    if net not in _LAYOUT:
        raise ValueError(f"unknown LPIPS network {net!r} (expected 'vgg' or 'alex')")
    return _cached_net(net, str(torch.device(device)), dtype)


def _batch(a: torch.Tensor, b: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, bool]:
    if a.shape != b.shape:
        raise ValueError(f"image shapes differ: {tuple(a.shape)} vs {tuple(b.shape)}")
    single = a.ndim == 3
    if single:
        a, b = a[None], b[None]
    if a.ndim != 4 or a.shape[1] != 3:
        raise ValueError(f"expected (3, H, W) or (N, 3, H, W) images, got shape {tuple(a.shape)}")
    if not a.is_floating_point():
        raise ValueError(f"expected float images in [0, 1], got {a.dtype}")
    return a, b.to(a.dtype), single


def reduce_maps(maps: list[torch.Tensor]) -> torch.Tensor:
    """LPIPS value per image: spatial mean of each layer's map, summed over layers -> (N,).

    Reduced in at least float32 (a bfloat16 network's maps are upcast first)."""
    return sum(m.to(torch.promote_types(m.dtype, torch.float32)).mean(dim=(1, 2, 3)) for m in maps)


def upsample_maps(maps: list[torch.Tensor], size: tuple[int, int]) -> torch.Tensor:
    """LPIPS ``spatial=True``: layer maps upsampled bilinearly to ``size`` and summed -> (N, 1, H, W)."""
    return sum(F.interpolate(m, size=size, mode="bilinear", align_corners=False) for m in maps)


def lpips(a: torch.Tensor, b: torch.Tensor, net: Net = "vgg") -> torch.Tensor:
    """LPIPS distance of images in [0, 1], (3, H, W) -> scalar or (N, 3, H, W) -> (N,); differentiable."""
    a, b, single = _batch(a, b)
    out = reduce_maps(get_lpips_net(net, a.device, a.dtype)(a, b))
    return out[0] if single else out


def lpips_alex(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """:func:`lpips` with the AlexNet network."""
    return lpips(a, b, net="alex")


def lpips_map(a: torch.Tensor, b: torch.Tensor, net: Net = "vgg") -> torch.Tensor:
    """Spatial LPIPS map (N, 1, H, W) of images in [0, 1] (a (3, H, W) pair gives N = 1)."""
    a, b, _ = _batch(a, b)
    return upsample_maps(get_lpips_net(net, a.device, a.dtype)(a, b), tuple(a.shape[-2:]))


def lpips_weights_info(net: Net) -> str:
    """Path of the checkpoint file the ``net`` network is built from."""
    return _load_params(net)[1]
