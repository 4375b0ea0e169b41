"""``inpaint360gs evaluate RENDERS SCENE OUT.json``: every metric of the paper (Sec. 4 "Metrics",
Tab. 1, supp. Eq. 1) for a folder of renders of a scene's test_ views — full image, ``masked_*``
(the paper's evaluation code) and ``roi_*`` (strict) conventions, LPIPS VGG and AlexNet, FID with
the Inception weights when configured, the offline substitutes fd_vgg16 / kid_vgg16, the unseen
masks' coverage (unseen_share), with ``--removal REMOVED_DIR`` AMCR (supp. Eq. 1: that removal's
masks over the training views) and its removed silhouette at the test cameras, and with ``--model PLY`` the fill's geometry against the true surface (roi_depth_off)
(thin shell over :func:`inpaint360gs.evaluate.stage.evaluate_stage`, :mod:`inpaint360gs.evaluate.removal`
and :mod:`inpaint360gs.report.geometry`). A scene without test_ views (no
object-free photos) is scored as "no ground truth": exit 0, every metric null with that reason."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs evaluate``'s arguments to ``parser``."""
    from inpaint360gs.cli.common import add_backend_argument, add_scene_arguments, add_threads_argument, existing_dir, existing_file, output_file
    from inpaint360gs.metrics.weights import INCEPTION_ENV

    parser.add_argument("renders", type=existing_dir, help="one PNG per test_ view, named like the test image (test_0003.png)")
    parser.add_argument("scene", type=existing_dir, help="scene folder (its test_ images and unseen_mask/)")
    parser.add_argument("out", type=output_file, help="metrics JSON to write")
    parser.add_argument("--nets", default="vgg,alex", help="LPIPS networks, comma-separated (default vgg,alex; lpips = vgg as the paper's code)")
    parser.add_argument("--inception-weights", type=existing_file, default=None, help=f"pt_inception-2015-12-05 weights for FID (default ${INCEPTION_ENV}; without them fid is null with the reason)")
    add_scene_arguments(parser, llffhold=False, resize_note="the renders have the test views' size at it, as given to `render --resize`")
    parser.add_argument("--removal", type=existing_dir, default=None, metavar="REMOVED_DIR",
                        help="the run's removal (output of inpaint360gs remove): AMCR (supp. Eq. 1) of its masks over the training views and its silhouette at the test cameras; without it both are null")
    parser.add_argument("--model", type=existing_file, default=None, metavar="PLY",
                        help="the run's final model: roi_depth_off, its surface inside the unseen masks against gt/depth (synthetic scenes); without it null")
    add_backend_argument(parser)
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs evaluate`` with parsed ``args``; returns the exit status."""
    import json

    from inpaint360gs.cli.common import check_apart, set_threads
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.io.atomic import write_text
    from inpaint360gs.evaluate.stage import evaluate_stage

    set_threads(args.threads)
    nets = tuple(n.strip() for n in args.nets.split(",") if n.strip())
    bad = [n for n in nets if n not in ("vgg", "alex")]
    if bad or not nets:
        raise InputError(f"unknown LPIPS network(s) {bad or nets} (vgg, alex)", "--nets")
    check_apart({"OUT": args.out}, {"RENDERS": args.renders, "SCENE": args.scene, "--inception-weights": args.inception_weights,
                                    "--removal": args.removal, "--model": args.model}, replaced=False)
    removal_masks = depth_off = training_amcr = None
    if args.removal is not None or args.model is not None:
        from inpaint360gs.io.scene import load_scene

        scene = load_scene(args.scene, resize=args.resize)
        if args.removal is not None:
            from inpaint360gs.evaluate.removal import masks_in_test_views, training_amcr as amcr_of

            removal_masks = masks_in_test_views(args.removal, scene, args.backend)
            training_amcr = amcr_of(args.removal, scene)
        if args.model is not None:
            from inpaint360gs.report.geometry import depth_off as fill_depth_off

            depth_off = fill_depth_off(args.model, scene, args.backend)
    res = evaluate_stage(args.renders, args.scene, nets=nets, inception_weights=args.inception_weights, resize=args.resize,
                           removal_masks=removal_masks, training_amcr=training_amcr, depth_off=depth_off)
    write_text(args.out, json.dumps(res, indent=1, allow_nan=False) + "\n")
    if not res.get("ground_truth", True):
        print(f"{res.get('scene', args.scene)}: {res['reason']}; every metric is null -> {args.out}")
        return 0
    m = res["mean"]

    def f(k):
        v = m.get(k)
        return "null" if v is None else f"{v:.4f}"

    amcr = res["scene_metrics"].get("amcr")
    extra = "" if amcr is None else f", AMCR {amcr:.2f}%"
    print(f"{res.get('scene', args.scene)}: {res['num_views']} views; PSNR {f('psnr')}, masked PSNR {f('masked_psnr')}, ROI PSNR {f('roi_psnr')}, LPIPS {f('lpips')}{extra} -> {args.out}")
    return 0
