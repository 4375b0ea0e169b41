"""``inpaint360gs <stage> ...``: one subcommand per pipeline stage.

Each stage is a module of this package that defines ``add_arguments(parser)`` and ``run(args) -> int``
and is a thin shell over a library function; modules are imported only when their stage runs, so
``--help`` stays fast. The shared layer (:mod:`.common`) turns every failure into one line and a
documented exit code.
"""

from __future__ import annotations

import sys

from inpaint360gs.cli.common import run_stages

# stage name -> (module, one-line help)
STAGES: dict[str, tuple[str, str]] = {
    "train": ("inpaint360gs.cli.train", "train 3D Gaussian Splatting on a scene folder"),
    "segment": ("inpaint360gs.cli.segment", "raw 2D masks of every training view (geometric, oracle or SAM segmenter)"),
    "render": ("inpaint360gs.cli.render", "render a trained model at a scene's cameras"),
    "associate": ("inpaint360gs.cli.associate", "link per-view 2D segments into view-consistent object masks (Key Object Management)"),
    "remove": ("inpaint360gs.cli.remove", "select objects by click or id and remove them from the distilled field"),
    "inpaint": ("inpaint360gs.cli.inpaint", "virtual views, unseen masks, conditional RGB-D 2D inpainting and 3D inpainting"),
    "run": ("inpaint360gs.cli.run", "the whole method on one scene folder (train -> segment -> associate -> distill -> remove -> inpaint)"),
    "evaluate": ("inpaint360gs.cli.evaluate", "score renders of a scene's test_ views: full, masked and ROI metrics, LPIPS, FID or its substitutes"),
    "distill": ("inpaint360gs.cli.distill", "distill associated object masks into identity features of a trained model (Sec. 3.3)"),
    "score-removal": ("inpaint360gs.cli.score_removal", "score a removal: AMCR over the training views and, on a synthetic scene, residual and collateral against gt/"),
    "capture-scores": ("inpaint360gs.cli.capture_scores", "score a removal on a capture without ground truth: outside the hole, the footprint, the fill's texture"),
    "view": ("inpaint360gs.cli.view", "the browser viewer: click a photo to select the object, run the removal, compare before and after"),
    "table": ("inpaint360gs.cli.table", "tables: 3DGS reconstruction, one run's record, the paper's Tabs. 1-3 from records (CSV/Markdown/LaTeX)"),
}


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``inpaint360gs``: dispatch ``argv`` to a stage's subcommand; returns the exit status."""
    return run_stages("inpaint360gs", STAGES, argv, __doc__.splitlines()[0])


__all__ = ["STAGES", "main", "run_stages"]

if __name__ == "__main__":
    sys.exit(main())
