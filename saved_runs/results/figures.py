"""What the result plots share: saving a figure atomically and a legend that covers no data."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402

from ..store.files import write_atomic  # noqa: E402


def save_figure(fig: Figure, path: Path) -> None:
    """Save ``fig`` to ``path`` as PNG atomically (saved_runs.store.files.write_atomic), then close it."""
    if isinstance(fig.get_layout_engine(), PlaceHolderLayoutEngine):
        # what fig.tight_layout() leaves behind: it lays out nothing, but makes savefig draw the figure
        # once more before drawing it (a draw costs as much as the rest of the save)
        fig.set_layout_engine(None)
    try:
        write_atomic(path, lambda f: fig.savefig(f, format="png"))
    finally:
        plt.close(fig)


def legend_above_data(ax: Axes, *, ncol: int = 1) -> None:
    """Legend in the upper left corner, the y axis extended upwards so that no data lies
    under it (whatever the shape of the curves)."""
    legend = ax.legend(fontsize=8, loc="upper left", ncol=ncol)
    fig = ax.figure
    fig.tight_layout()  # measure in the final layout (the caller lays out again afterwards)
    # the legend's box from the renderer, without drawing the figure (a draw costs as much as the save)
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    bottom = legend.get_window_extent(renderer).transformed(ax.transAxes.inverted()).y0  # axes fraction
    frac = max(bottom - 0.03, 0.35)  # where the current top of the data may go
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, lo + (hi - lo) / frac)
