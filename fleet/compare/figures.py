"""Overlay plots of a comparison: both runs on one set of axes, and the change with its U below."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from saved_runs.results.figures import legend_above_data  # noqa: E402

from .positioning import PositioningComparison  # noqa: E402
from .straightness import StraightnessComparison  # noqa: E402

UNIT_LABELS = {"um": "µm", "arcsec": "arcsec"}
COLOURS = {1: "tab:blue", -1: "tab:red"}


def _nan(v: float | None) -> float:
    return np.nan if v is None else v


def positioning_overlay(c: PositioningComparison) -> Figure:
    """Top: the mean deviation per direction of run A (dashed, open markers) and run B (solid). Bottom: the
    change B − A per target and direction with its ±U bar; a filled marker where |change| > U.  The
    caller closes the figure."""
    unit = UNIT_LABELS.get(c.unit, c.unit)
    fig, (ax, axc) = plt.subplots(2, 1, figsize=(9, 7), dpi=110, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    for d, name in ((1, "up"), (-1, "down")):
        rows = [t for t in c.targets if t.direction == d]
        if not rows:
            continue
        x = np.array([t.target for t in rows])
        a = np.array([_nan(t.a.mean if t.a else None) for t in rows])
        b = np.array([_nan(t.b.mean if t.b else None) for t in rows])
        ax.plot(x, a, "o--", mfc="none", color=COLOURS[d], lw=1.0, ms=4, label=f"A mean {name}")
        ax.plot(x, b, "o-", color=COLOURS[d], lw=1.4, ms=4, label=f"B mean {name}")
        ch = np.array([_nan(t.change) for t in rows])
        big_u = np.array([_nan(t.expanded) for t in rows])
        shift = 0.004 * (x.max() - x.min() if len(x) > 1 else 1.0) * d  # ↑ and ↓ side by side
        axc.errorbar(x + shift, ch, yerr=np.where(np.isfinite(big_u), big_u, 0.0), fmt="none", ecolor=COLOURS[d],
                     elinewidth=1, capsize=2, alpha=0.7)
        sig = np.array([t.significant is True for t in rows])
        axc.plot((x + shift)[~sig], ch[~sig], "o", mfc="none", color=COLOURS[d], ms=4,
                 label=f"change {name} (within U)")
        axc.plot((x + shift)[sig], ch[sig], "o", color=COLOURS[d], ms=5, label=f"change {name} > U")
    ax.set_ylabel(f"mean deviation ({unit})")
    ax.set_title(f"A (dashed) against B (solid), {c.a.result.edition}, k = {c.k:g}", fontsize=10)
    ax.grid(True, alpha=0.3)
    legend_above_data(ax, ncol=2)
    axc.axhline(0.0, color="0.3", lw=0.8)
    axc.set_ylabel(f"change B − A ({unit}) ± U")
    axc.set_xlabel(f"target ({c.target_unit})")
    axc.grid(True, alpha=0.3)
    legend_above_data(axc, ncol=2)
    fig.tight_layout()
    return fig


def straightness_overlay(c: StraightnessComparison) -> Figure:
    """Top: both profiles, each with its own least-squares line (over the common stations) removed, with
    their U bands. Bottom: the change per station with its ±U bar.  The caller closes the figure."""
    fig, (ax, axc) = plt.subplots(2, 1, figsize=(9, 7), dpi=110, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    x = np.array([s.x_mm for s in c.stations])
    for side, colour, style in (("a", "tab:orange", "o--"), ("b", "black", "o-")):
        r = np.array([_nan(getattr(s, side)) for s in c.stations])
        u = np.array([_nan(getattr(s, f"u_{side}")) for s in c.stations])
        ok = np.isfinite(r)
        if np.isfinite(u[ok]).all():
            ax.fill_between(x[ok], r[ok] - c.k * u[ok], r[ok] + c.k * u[ok], color=colour, alpha=0.15, lw=0)
        ax.plot(x[ok], r[ok], style, color=colour, ms=4, lw=1.2,
                mfc="none" if side == "a" else colour, label=f"{side.upper()} (U band, k = {c.k:g})")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_ylabel("deviation from its least-squares line (µm)")
    ax.set_title(f"A (dashed) against B (solid), {c.a.result.method} decoupling", fontsize=10)
    ax.grid(True, alpha=0.3)
    legend_above_data(ax, ncol=2)
    rows = c.matched()
    xc = np.array([s.x_mm for s in rows])
    ch = np.array([_nan(s.change) for s in rows])
    big_u = np.array([_nan(s.expanded) for s in rows])
    sig = np.array([s.significant is True for s in rows], dtype=bool)
    axc.errorbar(xc, ch, yerr=np.where(np.isfinite(big_u), big_u, 0.0), fmt="none", ecolor="tab:purple",
                 elinewidth=1, capsize=2, alpha=0.7)
    axc.plot(xc, ch, "-", color="tab:purple", lw=0.8)
    axc.plot(xc[~sig], ch[~sig], "o", mfc="none", color="tab:purple", ms=4, label="change (within U)")
    axc.plot(xc[sig], ch[sig], "o", color="tab:purple", ms=5, label="change > U")
    axc.axhline(0.0, color="0.3", lw=0.8)
    axc.set_ylabel("change B − A (µm) ± U")
    axc.set_xlabel("x (mm), position of the sensor sample point from the first station")
    axc.grid(True, alpha=0.3)
    legend_above_data(axc, ncol=2)
    fig.tight_layout()
    return fig


def overlay_figure(c: PositioningComparison | StraightnessComparison) -> Figure:
    return positioning_overlay(c) if isinstance(c, PositioningComparison) else straightness_overlay(c)
