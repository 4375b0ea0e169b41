"""``inpaint360gs table``: the tables.

- ``table reconstruction METRICS.json ... --csv OUT.csv --md OUT.md``: per-scene 3DGS reconstruction
  table with an average row;
- ``table record OUT.json --label scene=S --label method=M --label segmenter=G [--label kind=K]
  [--eval EVAL.json] [--removal-scores SCORES.json] [--stage NAME=BENCH.tsv ...] [--model PLY ...]
  [--skip-reason TEXT]``: one run's record (:mod:`inpaint360gs.report.records`);
- ``table paper RECORD.json ... --out-dir DIR [--config CONFIG.yaml] [--seeds N ...] [--confidence C]
  [--resamples N] [--bootstrap-seed S] [--keep-failed DIR]``: the paper's tables from records, with seed
  spreads and scene-level paired bootstrap intervals (:mod:`inpaint360gs.report.paper`,
  :mod:`inpaint360gs.report.stats`); ``--keep-failed`` copies the renders and removal masks of the
  runs above a removal limit into DIR (:mod:`inpaint360gs.report.failed`).
"""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import OneLineParser, check_apart, nonneg_int, number, output_dir, output_file, positive_int
from inpaint360gs.core.errors import EXIT_INPUT

# table kind -> (title, {metrics.json key: column title}, markdown float format)
TABLES: dict[str, tuple[str, dict[str, str], str]] = {
    "reconstruction": (
        "3DGS reconstruction on held-out (non-test) views",
        {
            "psnr": "PSNR (dB)",
            "ssim": "SSIM",
            "num_gaussians": "Gaussians",
            "iterations": "steps",
            "train_seconds": "train (s)",
            "eval_seconds": "eval (s)",
            "peak_rss_mb": "peak RSS (MiB)",
        },
        ".4g",
    ),
}


class _SubParser(OneLineParser):
    """Usage errors of ``table <kind>`` on one line that starts like every error of the stage:
    ``inpaint360gs table: error: <kind>: message (see --help)``."""

    def error(self, message: str):  # type: ignore[override]
        head, _, kind = self.prog.rpartition(" ")
        self.exit(EXIT_INPUT, f"{head}: error: {kind}: {message} (see --help)\n")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs table``'s subcommands (one per table kind) to ``parser``."""
    sub = parser.add_subparsers(dest="kind", metavar="KIND", required=True, parser_class=_SubParser)
    for kind, (title, _, _) in TABLES.items():
        p = sub.add_parser(kind, help=title, description=title)
        p.add_argument("metrics", nargs="+", help="per-scene metrics.json files")
        p.add_argument("--csv", type=output_file, help="write the table as CSV here")
        p.add_argument("--md", type=output_file, help="write the table as Markdown (with provenance) here")

    h = "one run's record for the paper's tables: labels, evaluation means, stage times and memory, model size"
    p = sub.add_parser("record", help=h, description=h)
    p.add_argument("out", type=output_file, help="record JSON to write")
    p.add_argument("--label", action="append", default=[], metavar="KEY=VALUE",
                   help="scene=, method=, segmenter= (required), kind=method|baseline|ablation (default method), seed= (the run's "
                        "seed, an integer), name= (display name), ablation=a..e (row of paper Tab. 3); repeat the option")
    p.add_argument("--eval", default=None, metavar="EVAL.json", help="metrics JSON written by inpaint360gs evaluate")
    p.add_argument("--removal-scores", default=None, metavar="SCORES.json",
                   help="the run's removal scores written by inpaint360gs score-removal (residual, collateral, true footprint share)")
    p.add_argument("--stage", dest="stage_benchmarks", action="append", default=[], metavar="NAME=BENCH.tsv",
                   help="a stage's Snakemake benchmark file (wall seconds, max RSS); repeat per stage")
    p.add_argument("--model", nargs="+", action="extend", default=[], metavar="PLY", help="model files whose total size is the storage")
    p.add_argument("--skip-reason", default=None, metavar="TEXT", help="why there is no evaluation (e.g. a scene without ground truth)")

    h = "the paper's tables (per scene, Tab. 1 average, Tab. 3 ablation, Tab. 2 runtime) from records"
    p = sub.add_parser("paper", help=h, description=h)
    p.add_argument("records", nargs="+", help="record JSON files written by `table record`")
    p.add_argument("--out-dir", type=output_dir, required=True, help="folder for the .csv/.md/.tex tables and provenance.json")
    p.add_argument("--config", default=None, help="the workflow config YAML (copied into provenance.json)")
    p.add_argument("--seeds", type=int, nargs="+", default=None, help="seeds of the runs (recorded in provenance.json; default: the records' seed labels)")
    p.add_argument("--confidence", type=number(float, lo=0.0, hi=1.0, lo_open=True, hi_open=True), default=0.95, help="level of the paired bootstrap intervals (default 0.95)")
    p.add_argument("--resamples", type=positive_int, default=10_000, help="bootstrap resamples (default 10000)")
    p.add_argument("--bootstrap-seed", type=nonneg_int, default=0, help="seed of the bootstrap's generator (default 0: the same records give the same tables)")
    p.add_argument("--keep-failed", type=output_dir, default=None, metavar="DIR",
                   help="copy the test renders and removal masks of every run above a removal limit into DIR (replaced as a whole)")


def _run_reconstruction(args: argparse.Namespace) -> int:
    from inpaint360gs.report.tables import load_metrics, table_with_average, write_tables

    check_apart({"--csv": args.csv, "--md": args.md}, {f"METRICS[{i}]": path for i, path in enumerate(args.metrics, 1)})
    title, columns, floatfmt = TABLES[args.kind]
    df = table_with_average(load_metrics(args.metrics), columns)
    write_tables(df, args.csv, args.md, title, floatfmt)
    print(df.to_string(float_format=lambda x: f"{x:.4g}"))
    return 0


def _run_record(args: argparse.Namespace) -> int:
    import json

    from inpaint360gs.io.atomic import write_text
    from inpaint360gs.report.records import make_record, parse_labels, parse_stage

    labels = parse_labels(args.label)
    stages = [parse_stage(s) for s in args.stage_benchmarks]  # args.stage is the CLI stage (table)
    inputs = {"--eval": args.eval, "--removal-scores": args.removal_scores, **{f"--stage {n}": p for n, p in stages},
              **{f"--model[{i}]": p for i, p in enumerate(args.model, 1)}}
    check_apart({"OUT": args.out}, inputs, replaced=False)
    rec = make_record(labels, evaluation=args.eval, removal_scores=args.removal_scores, stages=stages, models=args.model,
                      skip_reason=args.skip_reason)
    write_text(args.out, json.dumps(rec, indent=1, allow_nan=False) + "\n")
    m = rec["metrics"]
    what = f"PSNR {m['psnr']:.2f}" if m["psnr"] is not None else f"no metrics ({rec['skip_reason'] or 'see null_reasons'})"
    print(f"{labels['scene']} {labels['method']}/{labels['segmenter']}: {what}, {len(rec['stages'])} stage(s) -> {args.out}")
    return 0


def _run_paper(args: argparse.Namespace) -> int:
    from pathlib import Path

    from inpaint360gs.report.paper import Bootstrap, output_names, paper_tables

    outs = {name: Path(args.out_dir) / name for name in output_names()}
    records = {f"RECORD[{i}]": p for i, p in enumerate(args.records, 1)}
    check_apart(outs, {**records, "--config": args.config}, replaced=False)
    if args.keep_failed is not None:
        check_apart({"--keep-failed": args.keep_failed}, {**records, "--config": args.config}, replaced=True)
    boot = Bootstrap(confidence=args.confidence, resamples=args.resamples, seed=args.bootstrap_seed)
    tables = paper_tables(args.records, args.out_dir, config=args.config, seeds=args.seeds, boot=boot, keep_failed=args.keep_failed)
    for name, t in tables.items():
        print(f"{name}: {len(t.rows)} row(s)")
    print(f"-> {args.out_dir}/{{{','.join(tables)}}}.{{csv,md,tex}}, provenance.json")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs table`` for the parsed ``args.kind``; returns the exit status."""
    if args.kind == "record":
        return _run_record(args)
    if args.kind == "paper":
        return _run_paper(args)
    return _run_reconstruction(args)
