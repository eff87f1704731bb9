"""Write straightness results next to a run: results/profile.csv, summary.json and, on request,
profile.png (matplotlib is imported only to draw)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from processing.straightness import StraightnessResult

from ..store.files import write_json_atomic, write_text_atomic
from .result_set import write_result_set

if TYPE_CHECKING:
    from matplotlib.figure import Figure

LINE_LABELS = {"endpoint": "end-point line", "least_squares": "least-squares line",
               "minimum_zone": "minimum-zone line"}


def write_straightness_results(results_dir: Path, result: StraightnessResult,
                               summary: dict[str, Any] | None = None, *, plot: bool = True) -> Path:
    """Write profile.csv, summary.json and (``plot``) profile.png into ``results_dir`` as one set (a kill
    leaves the old set or the new one, .result_set; a set written without the plot leaves no older
    profile.png behind); return it.  summary.json holds ``summary`` (the evaluation's ``process --json``
    object, with its verdict), else the result's own object."""
    return write_result_set(results_dir, lambda out: _write_files(out, result, summary, plot))


def profile_table(result: StraightnessResult) -> dict[str, np.ndarray]:
    """The columns of profile.csv (docs/run-format.md): station, x_mm, height_um, dev_<line>_um per
    reference line, u_um (standard uncertainty, k = 1) when evaluated."""
    prof = dict(result.profile_columns)
    for name, fit in result.lines.items():
        prof[f"dev_{name}_um"] = np.asarray(fit.deviations_um, dtype=float)
    if result.uncertainty is not None:
        prof["u_um"] = np.asarray(result.uncertainty.per_station_u_um, dtype=float)
    return prof


def csv_text(columns: dict[str, np.ndarray]) -> str:
    """Columns as CSV: a header line, integers as written, floats with 6 decimals (``%.6f``), a
    missing value (NaN) as an empty field, ``\n`` line ends (what pandas' ``to_csv(index=False,
    float_format="%.6f")`` writes)."""
    cells = []
    for v in columns.values():
        a = np.asarray(v)
        if a.dtype.kind in "iub":
            cells.append([str(int(e)) for e in a.tolist()])
        else:
            cells.append(["" if e != e else f"{e:.6f}" for e in a.astype(float).tolist()])
    lines = [",".join(columns)] + [",".join(row) for row in zip(*cells, strict=True)]
    return "\n".join(lines) + "\n"


def _write_files(out: Path, result: StraightnessResult, summary: dict[str, Any] | None, plot: bool) -> None:
    write_text_atomic(out / "profile.csv", csv_text(profile_table(result)))
    write_json_atomic(out / "summary.json", result.to_dict() if summary is None else summary)
    if plot:
        plot_profile(result, out / "profile.png")


def plot_profile(result: StraightnessResult, path: Path) -> None:
    """Write :func:`profile_figure` to ``path`` (PNG, atomically)."""
    from .figures import save_figure

    save_figure(profile_figure(result), path)


def profile_figure(result: StraightnessResult) -> Figure:
    """Profile with its reference lines (straightness per line in the legend), the
    expanded-uncertainty band (k = 2) and, when present, the two passes; below it the
    deviation from the minimum-zone line.  The caller closes the figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figures import legend_above_data

    x = np.asarray(result.profile_columns["x_mm"])
    h = np.asarray(result.profile_columns["height_um"])
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 7), dpi=110, sharex=True, height_ratios=(3, 2))
    band = 2.0 * result.uncertainty.per_station_u_um if result.uncertainty is not None else None
    if band is not None:
        ax.fill_between(x, h - band, h + band, color="tab:blue", alpha=0.18, lw=0,
                        label="expanded uncertainty U (k = 2)")
    rp = result.return_pass
    if rp is not None:
        ax.plot(rp.forward["x_mm"], rp.forward["height_um"], ".", color="tab:green", ms=5, label="forward pass")
        ax.plot(rp.backward["x_mm"], rp.backward["height_um"], "x", color="tab:red", ms=5, label="return pass")
    label = "surface profile (mean of both passes)" if rp is not None else "surface profile"
    ax.plot(x, h, "o-", color="black", lw=1.2, ms=4, label=label)
    xx = np.array([x.min(), x.max()]) if len(x) else np.array([0.0, 1.0])
    mc = result.uncertainty.to_dict().get("straightness", {}) if result.uncertainty is not None else {}
    for (name, fit), style in zip(result.lines.items(), ("--", ":", "-."), strict=False):
        unc = f" +/- {mc[name]:.3f}" if name in mc else ""
        ax.plot(xx, fit.intercept_um + fit.slope_um_per_mm * xx, style,
                label=f"{LINE_LABELS.get(name, name)}: straightness {fit.straightness_um:.3f}{unc} µm")
    ax.set_ylabel("height (µm), +Y")
    ax.set_title(f"Guideway base-surface profile ({result.method} decoupling)")
    ax.grid(True, alpha=0.3)
    legend_above_data(ax, ncol=2)
    fit = result.lines.get("minimum_zone")
    if fit is not None:
        d = fit.deviations_um
        if band is not None:
            ax2.fill_between(x, d - band, d + band, color="tab:blue", alpha=0.18, lw=0, label="U (k = 2)")
        ax2.plot(x, d, "o-", color="black", lw=1.2, ms=4, label="deviation from the minimum-zone line")
        half = fit.straightness_um / 2
        ax2.axhline(half, color="tab:green", ls="-.", lw=1)
        ax2.axhline(-half, color="tab:green", ls="-.", lw=1, label=f"zone: {fit.straightness_um:.3f} µm")
        legend_above_data(ax2, ncol=3)
    ax2.set_ylabel("deviation (µm)")
    ax2.set_xlabel("x (mm), position of the sensor sample point from the first station")
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
