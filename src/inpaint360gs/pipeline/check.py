"""A run checks its own result (docs/architecture.md, "A run checks itself").

After ``remove`` and after ``inpaint``, :class:`~.run.Runner` scores what it made with the scores a
capture without ground truth allows (:mod:`inpaint360gs.evaluate.capture`) and writes
``OUT/check.json`` and ``OUT/check.png``:

- ``selection``: the selection is an object under the click (:mod:`inpaint360gs.remove.check`);
- ``outside_removed``: outside the removed Gaussians' footprint grown by 15 px, the removed model
  renders the photos as well as the 3DGS did (PSNR drop at most :attr:`CheckLimits.outside_drop_db`,
  training and held-out views): the removal took nothing around the object;
- ``over_removal``: the removal's masks cover at most :attr:`CheckLimits.over_removal` times the
  pixels of the selection standing above the support (``removal.json``'s ``over_removal``): the
  removal took no large piece of the support or of a neighbour with the object;
- ``standing_removed`` / ``standing_inpainted``: nothing stands in the object's footprint column
  after removal / after inpainting (:attr:`CheckLimits.standing`; other objects reaching into the
  column are left out);
- ``outside_inpainted``: the inpainting changed nothing outside the grown footprint;
- ``beside_inpainted``: nothing of the object is left just outside its footprint after the
  inpainting (:attr:`CheckLimits.beside`: the band's pixels in the object's colours and in none of
  the colours around it, over the footprint's area); after ``remove`` the same score is reported,
  not judged (a rim of the object's base left there is what the inpainting's seams go over);
- ``in_fill_inpainted``: nothing of the object is drawn into the fill (:attr:`CheckLimits.in_fill`:
  the footprint's pixels in the object's colours and in none of the colours around it, over its
  area; reported, not judged, when the limit is None);
- ``fill_texture`` / ``fill_luminance``: the fill is about as detailed and as bright as a ring
  around it at the training cameras (ratios within :attr:`CheckLimits.laplacian` and
  :attr:`CheckLimits.luminance`; skipped where the ring itself has no texture to compare with).

The picture: the selection drawn over the clicked photo and three other training views, then rows
3DGS / removed / inpainted at those views.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inpaint360gs.core.layout import RunLayout
from inpaint360gs.evaluate.limits import CheckLimits
from inpaint360gs.io.atomic import write_text

if TYPE_CHECKING:  # torch-free at import, as the run config is
    from inpaint360gs.io.scene import Scene

__all__ = ["CHECKED_STAGES", "CHECK_JSON", "CHECK_PICTURE", "Check", "CheckLimits", "CheckReport", "check_run", "load_check", "write_report"]

CHECKED_STAGES = ("remove", "inpaint")  # the stages after which a run checks its result
CHECK_JSON = "check.json"
CHECK_PICTURE = "check.png"


@dataclass
class Check:
    """One check: its ``name``, ``value`` against ``limit``, whether it ``passed`` and why."""

    name: str
    passed: bool
    value: float | str | None
    limit: str
    reason: str

    def line(self) -> str:
        return f"{self.name}: {self.reason}"


@dataclass
class CheckReport:
    """Every check made so far of a run (``stage``: the last stage checked)."""

    stage: str
    checks: list[Check] = field(default_factory=list)
    accepted: bool = False  # the user accepted a failed result (``--accept``)
    signature: str = ""  # the checked stage's signature (run.json): a report is reused only for the same outputs
    limits: dict = field(default_factory=dict)  # the CheckLimits it was made with

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failed(self) -> list[Check]:
        return [c for c in self.checks if not c.passed]

    def to_json(self) -> dict:
        return {"stage": self.stage, "passed": self.passed, "accepted": self.accepted, "picture": CHECK_PICTURE,
                "failed": [c.name for c in self.failed], "checks": [asdict(c) for c in self.checks],
                "signature": self.signature, "limits": self.limits}  # fmt: skip

    @classmethod
    def from_json(cls, d: dict) -> "CheckReport":
        return cls(d["stage"], [Check(**c) for c in d["checks"]], bool(d.get("accepted", False)), d.get("signature", ""), d.get("limits", {}))


def _limits_json(lim: CheckLimits) -> dict:
    return json.loads(json.dumps(asdict(lim)))  # tuples as lists, as they read back


def load_check(layout: RunLayout, stage: str, signature: str, limits: CheckLimits) -> CheckReport | None:
    """The report in ``layout``'s ``check.json`` when it checked ``stage`` with outputs of ``signature``
    and these ``limits`` (and its picture is there); else None (check again)."""
    path = layout.root / CHECK_JSON
    if not path.is_file() or not (layout.root / CHECK_PICTURE).is_file():
        return None
    try:
        report = CheckReport.from_json(json.loads(path.read_text()))
    except (ValueError, KeyError, TypeError):
        return None  # unreadable: check again and replace it
    if report.stage != stage or report.signature != signature or report.limits != _limits_json(limits):
        return None
    return report


def _views_for_picture(scene: Scene, clicked: list[str], n: int = 4) -> list[str]:
    """The clicked views, then training views spread round the orbit, ``n`` in all."""
    train = [v.name for v in scene.train_views]
    names = list(dict.fromkeys(clicked))[:n]
    for i in np.linspace(0, len(train) - 1, 2 * n).round().astype(int):
        if len(names) >= n:
            break
        if train[i] not in names:
            names.append(train[i])
    return names


def selection_overlay(photo: np.ndarray, mask: np.ndarray, clicks: list[tuple[int, int]]) -> np.ndarray:
    """``photo`` (H, W, 3 in [0, 1]) with ``mask`` tinted red and outlined, a cross at each click."""
    import cv2

    img = photo.astype(np.float32).copy()
    m = mask.astype(bool)
    img[m] = 0.5 * img[m] + 0.5 * np.array([1.0, 0.15, 0.1], np.float32)
    edge = m & ~cv2.erode(m.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    img[edge] = (1.0, 0.0, 0.0)
    s = max(3, int(0.02 * max(img.shape[:2])))
    for x, y in clicks:
        cv2.line(img, (x - s, y), (x + s, y), (0.0, 1.0, 1.0), 1)
        cv2.line(img, (x, y - s), (x, y + s), (0.0, 1.0, 1.0), 1)
    return img


def _resize(img: np.ndarray, width: int) -> np.ndarray:
    import cv2

    h, w = img.shape[:2]
    if w <= width:
        return img
    return cv2.resize(img, (width, max(1, round(h * width / w))), interpolation=cv2.INTER_AREA)


def _fails_on(value: float | None, ok: bool, name: str, limit: str, what: str) -> Check:
    return Check(name, ok, value, limit, f"{what} ({'ok' if ok else 'FAILED'}, limit {limit})")


def score_checks(scores: dict, lim: CheckLimits, stage: str) -> list[Check]:
    """The checks of the no-ground-truth ``scores`` (:func:`inpaint360gs.evaluate.capture.score_capture`)
    that apply after ``stage`` (``remove`` or ``inpaint``)."""
    out = []
    psnr = scores["psnr_outside"]
    later = "removed" if stage == "remove" else "inpainted"
    before = "3dgs" if stage == "remove" else "removed"
    drops = {split: row[before] - row[later] for split, row in psnr.items() if row.get(later) is not None and row.get(before) is not None}
    drops = {k: d for k, d in drops.items() if np.isfinite(d)}  # NaN: no pixel of that split lies outside the grown footprint
    if not drops:
        out.append(Check(f"outside_{later}", True, None, f"<= {lim.outside_drop_db} dB", "not scored: no pixel lies outside the grown footprint"))
    else:
        worst = max(drops, key=lambda k: drops[k])
        d = drops[worst]
        out.append(_fails_on(round(d, 3), bool(d <= lim.outside_drop_db), f"outside_{later}", f"<= {lim.outside_drop_db} dB",
                             f"PSNR outside the grown footprint drops {d:+.2f} dB from {before} to {later} ({worst} views)"))  # fmt: skip
    st = scores["standing"].get(later)
    if st is not None:
        s = st["share"]
        nb = scores.get("standing_neighbours") or 0
        beside = "; other objects reaching into it left out" if nb else ""
        out.append(_fails_on(round(s, 4), bool(s <= lim.standing), f"standing_{later}", f"<= {100 * lim.standing:g} %",
                             f"{100 * s:.1f} % of what stood in the footprint column (the object) stands there after {stage} ({st['count']} Gaussians{beside})"))  # fmt: skip
    elif "standing_note" in scores:
        out.append(Check(f"standing_{later}", True, None, "", f"not scored: {scores['standing_note']}"))
    bs = scores.get("beside", {}).get(later)
    if bs is not None and lim.beside is not None:
        limit = f"<= {100 * lim.beside:g} %" if stage == "inpaint" else "reported"
        if bs["share"] is None:
            out.append(Check(f"beside_{later}", True, None, limit, "not scored: no training view has a footprint with a band and a ring around it"))
        else:
            b = bs["share"]
            what = f"{100 * b:.2f} % of the footprint's area just outside it shows the object's colours after {stage} (worst view {100 * bs['worst_view']:.2f} %)"
            if stage == "inpaint":
                out.append(_fails_on(round(b, 4), bool(b <= lim.beside), "beside_inpainted", limit, what))
            else:  # a rim of the object's base left at the footprint's edge: the inpainting's seams go over it; judged on its result
                out.append(Check("beside_removed", True, round(b, 4), limit, f"{what} (reported; judged after inpaint)"))
    fill = scores.get("in_fill", {}).get("inpainted") if stage == "inpaint" else None
    if fill is not None:
        limit = "reported" if lim.in_fill is None else f"<= {100 * lim.in_fill:g} %"
        if fill["share"] is None:
            out.append(Check("in_fill_inpainted", True, None, limit, "not scored: no training view has a footprint with a ring around it"))
        else:
            b = fill["share"]
            what = f"{100 * b:.2f} % of the footprint shows the object's colours after inpaint (worst view {100 * fill['worst_view']:.2f} %)"
            if lim.in_fill is None:
                out.append(Check("in_fill_inpainted", True, round(b, 4), limit, f"{what} (reported)"))
            else:
                out.append(_fails_on(round(b, 4), bool(b <= lim.in_fill), "in_fill_inpainted", limit, what))
    tex = scores["texture"].get("inpainted") if stage == "inpaint" else None
    if tex is not None and tex["laplacian"] is not None:
        lap, lum = tex["laplacian"], tex["luminance"]
        lo, hi = lim.laplacian
        if tex.get("ring_laplacian", 1.0) < lim.min_ring_texture:
            out.append(Check("fill_texture", True, lap, f"{lo}-{hi}", f"not scored: the ring around the hole has no texture (mean |Laplacian| {tex['ring_laplacian']:.4f})"))
        else:
            out.append(_fails_on(round(lap, 3), bool(lo <= lap <= hi), "fill_texture", f"{lo}-{hi}", f"the fill's |Laplacian| is {lap:.2f}x the ring's"))
        out.append(_fails_on(round(lum, 3), bool(abs(lum - 1.0) <= lim.luminance), "fill_luminance", f"1 +- {lim.luminance}", f"the fill's luminance is {lum:.2f}x the ring's"))
    return out


def check_run(scene: Scene, layout: RunLayout, model: Path, stage: str, *, limits: CheckLimits | None = None,
              signature: str = "", accept: bool = False) -> CheckReport:  # fmt: skip
    """Score the run in ``layout`` after ``stage`` (``remove`` or ``inpaint``), write ``check.png``
    then ``check.json`` into its folder (each atomically; the report marked accepted when it fails
    and ``accept``), and return the report (the module docstring)."""
    import torch

    from inpaint360gs.evaluate.capture import CaptureRun, score_capture
    from inpaint360gs.io.images import write_image
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.remove.check import SelectionCheck
    from inpaint360gs.remove.select import Click

    lim = limits or CheckLimits()
    removal = json.loads((layout.removed / "removal.json").read_text())
    report = CheckReport(stage, signature=signature, limits=_limits_json(lim))
    sel = removal.get("selection_check")
    if sel is not None:
        sc = SelectionCheck(**sel)
        report.checks.append(Check("selection", sc.passed, sc.verdict, "object", sc.reason))
    over = (removal.get("over_removal") or {}).get("ratio")
    if lim.over_removal is not None and over is not None:
        report.checks.append(_fails_on(round(over, 3), bool(over <= lim.over_removal), "over_removal", f"<= {lim.over_removal:g}",
                                       f"the removal's masks cover {over:.2f}x the pixels of the selection standing above the support"))  # fmt: skip
    run = CaptureRun(model, layout.distill, layout.removed, layout.inpainted if stage == "inpaint" else None)
    scores, renders = score_capture(scene, run)
    # after the inpainting the removal's own checks still hold: a removal that took the mat outside
    # the footprint leaves it damaged whatever the fill does
    for checked in CHECKED_STAGES[: CHECKED_STAGES.index(stage) + 1]:
        report.checks += score_checks(scores, lim, checked)
    # the picture: selection over the photos, then the models
    clicks = [Click.parse(c) for c in removal.get("clicks", [])]
    names = _views_for_picture(scene, [scene.view(c.view).name for c in clicks])
    distilled = read_ply(layout.distill / "point_cloud.ply")
    index = torch.from_numpy(np.load(layout.removed / "removed_index.npy").astype(np.int64))
    selected = torch.zeros(len(distilled), dtype=torch.bool)
    selected[index] = True
    from inpaint360gs.remove.objects import fill_masks

    masks = fill_masks(distilled, selected, [scene.view(n) for n in names])
    top = []
    for n in names:
        v = scene.view(n)
        pix = [c.pixel(v) for c in clicks if scene.view(c.view).name == n]
        top.append(selection_overlay(scene.load_image(v).numpy(), masks[n], pix))
    rows = [top] + [[renders[k][n] for n in names] for k in ("3dgs", "removed", "inpainted") if k in renders]
    picture = np.concatenate([np.concatenate([_resize(np.clip(im, 0, 1), lim.picture_width) for im in row], axis=1) for row in rows], axis=0)
    write_image(layout.root / CHECK_PICTURE, picture)
    report.accepted = accept and not report.passed
    write_report(layout, report)
    return report


def write_report(layout: RunLayout, report: CheckReport) -> None:
    """``report`` as ``check.json`` in ``layout``'s folder (atomically)."""
    write_text(layout.root / CHECK_JSON, json.dumps(report.to_json(), indent=1) + "\n")
