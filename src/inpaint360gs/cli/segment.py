"""``inpaint360gs segment SCENE MODEL.ply OUT``: raw 2D masks of every training view (paper Sec. 3.2;
thin shell over :func:`inpaint360gs.segment.stage.segment_stage`).

Writes ``OUT/<stem>.png`` (16-bit ids, 0 = no segment, ids per view) and ``OUT/segment.json``.
``--segmenter geometric`` (default, no weights) renders clusters of the model's Gaussians;
``oracle`` damages the ground-truth masks of a synthetic scene (reads gt/, labelled as such);
``sam`` runs SAM / HQ-SAM / MobileSAM ONNX files given by ``--sam-encoder`` / ``--sam-decoder``.
The model is read by the segmenters that use it (geometric) and recorded by the others.
"""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import (
    add_backend_argument,
    add_scene_arguments,
    add_threads_argument,
    check_apart,
    existing_dir,
    existing_file,
    fraction,
    nonneg_int,
    output_dir,
    positive_float,
    positive_int,
    set_threads,
)
from inpaint360gs.segment.base import DEFAULT_SEGMENTER, segmenter_names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs segment``'s arguments to ``parser``."""
    from inpaint360gs.segment.cluster3d import ClusterConfig
    from inpaint360gs.segment.oracle import OracleConfig
    from inpaint360gs.segment.sam import ENV_DECODER, ENV_ENCODER, SamConfig

    c, o, s = ClusterConfig(), OracleConfig(), SamConfig()
    parser.add_argument("scene", type=existing_dir, help="scene folder (images/, sparse/0, ...)")
    parser.add_argument("model", type=existing_file, help="trained 3DGS (point_cloud.ply of the train stage)")
    parser.add_argument("out", type=output_dir, help="output folder: <stem>.png per training view, segment.json (created atomically)")
    parser.add_argument("--segmenter", default=DEFAULT_SEGMENTER, choices=segmenter_names(), help=f"how to get the masks (default {DEFAULT_SEGMENTER})")
    parser.add_argument("--seed", type=nonneg_int, default=0, help="seed (geometric: ground-plane RANSAC; oracle: damage)")
    add_scene_arguments(parser)
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    parser.add_argument("--allow-unregistered", action="store_true", help="warn about, instead of rejecting, images not in sparse/0")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_threads_argument(parser)
    add_backend_argument(parser)
    g = parser.add_argument_group("geometric segmenter (lengths are fractions of the orbit radius R)")
    g.add_argument("--tau", type=positive_float, default=c.tau, help=f"objects stand higher than this above the ground plane (default {c.tau:g})")
    g.add_argument("--eps", type=positive_float, default=c.eps, help=f"DBSCAN neighbourhood of the Gaussian centres (default {c.eps:g})")
    g = parser.add_argument_group("oracle segmenter (synthetic scenes: reads gt/instance)")
    g.add_argument("--split-prob", type=fraction, default=o.split_prob, help=f"probability an object is cut in two (default {o.split_prob:g})")
    g.add_argument("--merge-prob", type=fraction, default=o.merge_prob, help=f"probability two touching objects merge in a view (default {o.merge_prob:g})")
    g.add_argument("--edge-px", type=nonneg_int, default=o.edge_px, help=f"edges erode or dilate by up to this many pixels (default {o.edge_px})")
    g = parser.add_argument_group("sam segmenter (ONNX files you supply; pip install 'inpaint360gs[sam]')")
    g.add_argument("--sam-encoder", type=existing_file, default=None, help=f"image encoder .onnx (default ${ENV_ENCODER})")
    g.add_argument("--sam-decoder", type=existing_file, default=None, help=f"prompt decoder .onnx, the segment-anything export (default ${ENV_DECODER})")
    g.add_argument("--sam-points-per-side", type=positive_int, default=s.points_per_side, help=f"prompt grid (default {s.points_per_side})")
    g.add_argument("--sam-pred-iou-thresh", type=fraction, default=s.pred_iou_thresh, help=f"(default {s.pred_iou_thresh:g})")
    g.add_argument("--sam-stability-thresh", type=fraction, default=s.stability_score_thresh, help=f"(default {s.stability_score_thresh:g})")
    g.add_argument("--sam-min-region-area", type=nonneg_int, default=s.min_mask_region_area, help="remove holes and islands below this many pixels (default 0)")
    g.add_argument("--sam-image-size", type=positive_int, default=s.image_size, help=f"encoder input side when the file leaves it dynamic (default {s.image_size})")


def make_segmenter(args: argparse.Namespace):
    """The segmenter named by ``args.segmenter``, configured from the parsed ``args``."""
    from dataclasses import replace

    from inpaint360gs.segment.base import get_segmenter

    if args.segmenter == "geometric":
        from inpaint360gs.segment.geometric import GeometricConfig

        d = GeometricConfig()
        cfg = replace(d, seed=args.seed, backend=args.backend, cluster=replace(d.cluster, tau=args.tau, eps=args.eps))
        return get_segmenter("geometric", config=cfg)
    if args.segmenter == "oracle":
        from inpaint360gs.segment.oracle import OracleConfig

        return get_segmenter("oracle", config=OracleConfig(seed=args.seed, split_prob=args.split_prob, merge_prob=args.merge_prob, edge_px=args.edge_px))
    from inpaint360gs.segment.sam import SamConfig

    cfg = SamConfig(
        encoder=None if args.sam_encoder is None else str(args.sam_encoder),
        decoder=None if args.sam_decoder is None else str(args.sam_decoder),
        points_per_side=args.sam_points_per_side, pred_iou_thresh=args.sam_pred_iou_thresh,
        stability_score_thresh=args.sam_stability_thresh, min_mask_region_area=args.sam_min_region_area, image_size=args.sam_image_size,
    )  # fmt: skip
    cfg.paths()  # missing files: one line before any work
    return get_segmenter("sam", config=cfg)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs segment`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.segment.stage import segment_stage

    set_threads(args.threads)
    check_apart({"OUT": args.out}, {"SCENE": args.scene, "MODEL": args.model})  # --overwrite replaces OUT as a whole
    segmenter = make_segmenter(args)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False, unregistered="warn" if args.allow_unregistered else "error")
    info = segment_stage(scene, args.model, args.out, segmenter, overwrite=args.overwrite, progress=not args.no_progress)
    counts = [v["segments"] for v in info["views"].values()]
    label = " (from ground truth)" if info["reads_ground_truth"] else ""
    print(
        f"{scene.name}: {info['segmenter']}{label} segmented {len(counts)} training views, {min(counts)}–{max(counts)} segments per view, "
        f"{info['timings']['ms_per_view']:.0f} ms per view; wrote {args.out}"
    )
    return 0
