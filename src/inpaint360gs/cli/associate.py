"""``inpaint360gs associate SCENE MODEL.ply SEGMENTS OUT``: Key Object Management association of the
segment stage's per-view masks into view-consistent object masks (paper Sec. 3.2; thin shell over
:func:`inpaint360gs.associate.stage.associate_stage`)."""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import add_scene_arguments, check_apart, existing_dir, existing_file, fraction, nonneg_int, output_dir, positive_int


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs associate``'s arguments to ``parser``."""
    from inpaint360gs.associate.config import AssociationConfig

    d = AssociationConfig()
    parser.add_argument("scene", type=existing_dir, help="scene folder")
    parser.add_argument("model", type=existing_file, help="the scene's trained 3DGS (point_cloud.ply)")
    parser.add_argument("segments", type=existing_dir, help="output folder of `inpaint360gs segment`")
    parser.add_argument("out", type=output_dir, help="output folder: object_mask/<stem>.png, objects.json")
    parser.add_argument("--method", default=d.method, choices=["kom", "tracker"], help="kom: Key Object Management (default); tracker: ablation a), 2D IoU between consecutive views")
    parser.add_argument("--variant", default=d.variant, choices=["paper", "code"], help="paper: GS-IoU 0.2 on plain IoU (default); code: the authors' public code (0.1 on |A∩B|/(|B|+|A∩B|), nearest 30%%)")
    parser.add_argument("--sigma", type=fraction, default=None, help="GS-IoU threshold (default: the variant's)")
    parser.add_argument("--keep-near", type=fraction, default=None, help="keep this nearest fraction of each patch's near cluster (default: the variant's)")
    parser.add_argument("--compare", default=d.compare, choices=["visible", "all"],
                        help="visible: each database set through the Gaussians the current view labels (default); all: the whole set (Eq. 2 read literally; objects split once their set outgrows 1/sigma views' worth)")
    parser.add_argument("--part-share", type=fraction, default=d.part_share,
                        help=f"a segment below the GS-IoU threshold with at least this share of its Gaussians in one object's set is a part of it (default {d.part_share}; 0 = off, Alg. 1 alone)")
    parser.add_argument("--merge-share", type=fraction, default=d.merge_share,
                        help=f"a segment holding at least this share of each of two objects' sets is a merge and is divided between them (default {d.merge_share}; 0 = off)")
    parser.add_argument("--no-consolidate", dest="consolidate", action="store_false",
                        help="keep objects apart that more views segmented as one than as two (default: join them after the pass)")
    parser.add_argument("--patch", type=positive_int, default=d.patch, help=f"patch size in pixels (default {d.patch})")
    parser.add_argument("--min-segment-pixels", type=nonneg_int, default=d.min_segment_pixels)
    add_scene_arguments(parser)
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs associate`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.associate import AssociationConfig, associate_stage

    check_apart({"OUT": args.out}, {"SCENE": args.scene, "MODEL": args.model, "SEGMENTS": args.segments})  # --overwrite replaces OUT as a whole
    cfg = AssociationConfig(
        method=args.method, variant=args.variant, sigma=args.sigma, keep_near=args.keep_near,
        patch=args.patch, min_segment_pixels=args.min_segment_pixels, compare=args.compare,
        part_share=args.part_share, merge_share=args.merge_share, consolidate=args.consolidate,
    ).resolved()  # fmt: skip
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False)
    res = associate_stage(scene, args.model, args.segments, args.out, cfg, overwrite=args.overwrite, meta={"scene": str(scene.root), "model": str(args.model)})
    print(f"{scene.name}: {len(res.objects)} object(s) over {len(res.masks)} training views ({cfg.method}) -> {args.out}")
    return 0
