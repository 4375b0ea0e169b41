"""``inpaint360gs score-removal SCENE REMOVED OUT.json``: what a removal took, over the scene's
training views — AMCR (paper supp. Eq. 1, the removal's own masks) and, on a synthetic scene, the
ground-truth residual, collateral and footprint share with the limits a run must stay within
(docs/architecture.md, "Ground-truth removal scores"; thin shell over
:func:`inpaint360gs.evaluate.removal.score_removal_stage`). Without ``gt/`` only AMCR is computed,
the rest is null with the reason (exit 0)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs score-removal``'s arguments to ``parser``."""
    from inpaint360gs.cli.common import add_backend_argument, add_threads_argument, existing_dir, output_file

    parser.add_argument("scene", type=existing_dir, help="scene folder (a synthetic scene's gt/ gives the ground-truth scores)")
    parser.add_argument("removed", type=existing_dir, help="the removal (output folder of inpaint360gs remove) of this scene")
    parser.add_argument("out", type=output_file, help="scores JSON to write")
    add_backend_argument(parser)
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs score-removal`` with parsed ``args``; returns the exit status."""
    import json

    from inpaint360gs.cli.common import check_apart, set_threads
    from inpaint360gs.evaluate.removal import score_removal_stage
    from inpaint360gs.io.atomic import write_text

    set_threads(args.threads)
    check_apart({"OUT": args.out}, {"SCENE": args.scene, "REMOVED": args.removed}, replaced=False)
    res = score_removal_stage(args.scene, args.removed, backend=args.backend)
    write_text(args.out, json.dumps(res, indent=1, allow_nan=False) + "\n")
    s = res["scores"]

    def f(k, unit=" %"):
        return "null" if s[k] is None else f"{s[k]:.2f}{unit}"

    above = "; above: " + ", ".join(f"{a['limit']} {a['value']:.2f} > {a['max']:g}" for a in res["above_limits"]) if res["above_limits"] else ""
    print(f"{args.scene}: AMCR {f('amcr')} ({f('amcr_ratio', 'x')} the true footprint {f('gt_footprint_share')}), "
          f"residual {f('residual')}, collateral {f('collateral')}{above} -> {args.out}")
    return 0
