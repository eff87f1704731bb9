"""The before/after plot of an as-left run on shifted targets (compare's overlay needs common targets)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from saved_runs.results.figures import legend_above_data  # noqa: E402

from ..compare.figures import COLOURS, UNIT_LABELS  # noqa: E402
from ..compare.positioning import PositioningComparison  # noqa: E402


def shifted_overlay(d: PositioningComparison) -> Figure:
    """The mean deviation per direction of AS_FOUND (dashed, open markers, at its targets) and AS_LEFT (solid, at
    the shifted targets).  The caller closes the figure."""
    unit = UNIT_LABELS.get(d.unit, d.unit)
    fig, ax = plt.subplots(figsize=(9, 5), dpi=110)
    for label, ev, style, mfc in (("AS_FOUND", d.a, "o--", "none"), ("AS_LEFT", d.b, "o-", None)):
        pt = ev.result.per_target
        for name, direction in (("up", 1), ("down", -1)):
            if int(pt[f"n_{name}"].max()) == 0:
                continue
            ax.plot(pt["target"], pt[f"mean_{name}"], style, color=COLOURS[direction], mfc=mfc or COLOURS[direction],
                    ms=4, lw=1.2, label=f"{label} mean {name}")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel(f"target ({d.target_unit})")
    ax.set_ylabel(f"mean deviation ({unit})")
    ax.set_title("AS_FOUND at its targets (dashed), AS_LEFT between the table's points (solid)", fontsize=10)
    ax.grid(True, alpha=0.3)
    legend_above_data(ax, ncol=2)
    fig.tight_layout()
    return fig
