"""``inpaint360gs table KIND METRICS.json ... --csv OUT.csv --md OUT.md``: per-scene tables with an average row."""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import check_apart, output_file

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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=sorted(TABLES), help="which table")
    parser.add_argument("metrics", nargs="+", help="per-scene metrics.json files")
    parser.add_argument("--csv", type=output_file, help="write the table as CSV here")
    parser.add_argument("--md", type=output_file, help="write the table as Markdown (with provenance) here")


def run(args: argparse.Namespace) -> int:
    from inpaint360gs.report.tables import load_metrics, table_with_average, write_tables

    check_apart({"--csv": args.csv, "--md": args.md}, {f"METRICS[{i}]": path for i, path in enumerate(args.metrics, 1)})
    title, columns, floatfmt = TABLES[args.kind]
    df = table_with_average(load_metrics(args.metrics), columns)
    write_tables(df, args.csv, args.md, title, floatfmt)
    print(df.to_string(float_format=lambda x: f"{x:.4g}"))
    return 0
