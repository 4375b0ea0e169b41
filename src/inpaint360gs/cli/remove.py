"""``inpaint360gs remove SCENE DISTILL OUT --click VIEW:X,Y | --id N``: select objects by a click on
a view (resolved through the rendered id map) or by id, and remove them from the distilled field
(paper Sec. 3.4; thin shell over :func:`inpaint360gs.remove.stage.remove_stage`)."""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import add_backend_argument, add_scene_arguments, add_threads_argument, check_apart, existing_dir, fraction, output_dir, positive_int, set_threads


def add_click_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the repeatable ``--click VIEW:X,Y`` and ``--id N`` object selectors to ``parser``."""
    parser.add_argument("--click", action="append", default=[], metavar="VIEW:X,Y", help="a pixel (column X, row Y, in the image as it lies in images/) inside the object in a training view; repeat for several objects (default: the clicks scene.json names)")
    parser.add_argument("--id", action="append", type=positive_int, default=[], help="an object id read off the rendered id map; repeatable")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs remove``'s arguments to ``parser``."""
    from inpaint360gs.remove.config import RemovalConfig

    d = RemovalConfig()
    parser.add_argument("scene", type=existing_dir, help="scene folder")
    parser.add_argument("distill", type=existing_dir, help="output folder of `inpaint360gs distill` (point_cloud.ply + classifier.json)")
    parser.add_argument("out", type=output_dir, help="output folder: point_cloud.ply, removed.ply, masks/, removal.json")
    add_click_arguments(parser)
    parser.add_argument("--threshold", type=fraction, default=d.threshold, help=f"remove Gaussians whose probability of the object exceeds this (default {d.threshold})")
    parser.add_argument("--no-hull", action="store_true", help="do not also remove what lies inside the convex hull of the selected Gaussians")
    parser.add_argument("--no-protect-support", action="store_true",
                        help="let the hull step take background Gaussians on the support plane too (the authors' code; default: kept)")
    column = parser.add_mutually_exclusive_group()
    column.add_argument("--support-column", type=fraction, nargs="?", const=d.support_column, default=d.support_column, metavar="R",
                        help="also take background Gaussians hanging below the removed ones, in steps of at most R x the orbit radius "
                             f"(thin parts near the floor, e.g. a stool's leg ends; default: on, R = {d.support_column})")
    column.add_argument("--no-support-column", dest="support_column", action="store_const", const=None,
                        help="do not (the authors' code)")
    parser.add_argument("--protect-background", type=fraction, default=None, metavar="P", help="the hull step keeps Gaussians whose background probability exceeds P (default: off, as the authors' code)")
    add_scene_arguments(parser)
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    add_backend_argument(parser)
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs remove`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.io.atomic import check_output_dir
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.remove.config import RemovalConfig
    from inpaint360gs.remove.stage import load_field, remove_stage
    from inpaint360gs.remove.select import Click, check_clicks

    set_threads(args.threads)
    check_apart({"OUT": args.out}, {"SCENE": args.scene, "DISTILL": args.distill})  # --overwrite replaces OUT as a whole
    check_output_dir(args.out, args.overwrite)
    clicks = [Click.parse(c) for c in args.click]
    cfg = RemovalConfig(threshold=args.threshold, hull=not args.no_hull, protect_background=args.protect_background,
                        protect_support=None if args.no_protect_support else RemovalConfig.protect_support,
                        support_column=args.support_column)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False)
    where = None  # the command line: check_clicks names the --click option
    if not clicks and not args.id:  # as `inpaint360gs run`: the clicks scene.json names
        from inpaint360gs.core.errors import InputError
        from inpaint360gs.pipeline.run import no_clicks_reason, scene_clicks

        clicks, where = scene_clicks(scene), scene.root / "scene.json"
        if not clicks:
            raise InputError(f"nothing selected: give --click VIEW:X,Y or --id N ({no_clicks_reason(scene)})", scene.root / "scene.json")
    check_clicks(scene, clicks, where)
    field = load_field(args.distill, scene)
    info = remove_stage(scene, field, args.out, clicks=clicks, ids=args.id, cfg=cfg, backend=args.backend, overwrite=args.overwrite,
                         meta={"scene": str(scene.root), "distill": str(args.distill)})  # fmt: skip
    print(f"{scene.name}: removed object(s) {info['objects']} ({info['removed_gaussians']} Gaussians); AMCR {info['amcr_percent']:.2f}% -> {args.out}")
    return 0
