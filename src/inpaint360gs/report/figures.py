"""Plots of the paper's tables: the supplementary's distance against the number of virtual views."""

from __future__ import annotations

from inpaint360gs.report.table_model import Table


def sweep_plot(table: Table) -> bytes:
    """PNG: FD-VGG16 (and FID when present) against L, from :func:`views_sweep`'s table."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = [int(r["virtual_views"]) for r in table.rows]
    fig, ax = plt.subplots(figsize=(4.5, 3.2), dpi=120)
    for key, title in (("fid", "FID"), ("fd_vgg16", "FD-VGG16 (FID substitute)")):
        ys = [r.get(key) for r in table.rows]
        if any(y is not None for y in ys):
            ax.plot(xs, [float("nan") if y is None else y for y in ys], marker="o", label=title)
    ax.set_xlabel("virtual views L")
    ax.set_ylabel("distance (lower is better)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()
