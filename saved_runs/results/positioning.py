"""Write positioning results next to a run: results/positioning.csv, positioning.png, summary.json.

Input: the ISO 230-2 result (:class:`processing.iso230_2.Iso2302Result`), the deviations it was
evaluated from (columns ``target_index``, ``target``, ``direction``, ``run``, ``deviation``; um or
arcsec) and the summary object (``guideway process --json``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from ..store.files import write_json_atomic, write_text_atomic  # noqa: E402
from .figures import legend_above_data, save_figure  # noqa: E402
from .result_set import write_result_set  # noqa: E402

UNIT_LABELS = {"um": "µm", "arcsec": "arcsec"}  # the plots name units as the report's tables do

if TYPE_CHECKING:
    import pandas as pd

    from processing.iso230_2 import Iso2302Result


def write_positioning_results(results_dir: Path, result: Iso2302Result, deviations: pd.DataFrame,
                              summary: dict[str, Any], *, plot: bool = True) -> Path:
    """Write the per-target table (positioning.csv, target in mm or deg, values in µm or
    arcsec as the column names say), ``summary`` as summary.json and (``plot``) positioning.png as one
    set (a kill leaves the old set or the new one, .result_set); return the directory."""
    return write_result_set(results_dir, lambda out: _write_files(out, result, deviations, summary, plot))


def _write_files(out: Path, result: Iso2302Result, deviations: pd.DataFrame, summary: dict[str, Any],
                 plot: bool) -> None:
    r = result
    table = r.per_target.rename(columns={
        "target": f"target_{r.target_unit}",
        **{c: f"{c}_{r.unit}" for c in ("mean_up", "mean_down", "mean_bi", "reversal", "s_up", "s_down",
                                        "R_i_up", "R_i_down", "R_i")},
    })
    write_text_atomic(out / "positioning.csv", table.to_csv(index=False, float_format="%.6f"))
    write_json_atomic(out / "summary.json", summary)
    if plot:
        plot_positioning(result, deviations, out / "positioning.png")


def plot_positioning(result: Iso2302Result, deviations: pd.DataFrame, path: Path) -> None:
    """Write :func:`positioning_figure` to ``path`` (PNG, atomically)."""
    save_figure(positioning_figure(result, deviations), path)


def positioning_figure(result: Iso2302Result, deviations: pd.DataFrame) -> Figure:
    """Every run, the mean per direction with its ±k·s band, and the reversal B_i per target.
    The caller closes the figure."""
    r = result
    pt = r.per_target
    dev = deviations
    fig, (ax, axb) = plt.subplots(2, 1, figsize=(9, 6.5), dpi=110, sharex=True,
                                  gridspec_kw={"height_ratios": [3, 1]})
    colours = {1: "tab:blue", -1: "tab:red"}
    labelled: set[int] = set()
    runs = dev.sort_values("target").groupby(["direction", "run"])
    for (d, _run), g in sorted(runs, key=lambda item: (-item[0][0], item[0][1])):  # up first
        label = None if int(d) in labelled else f"each run {'up' if d == 1 else 'down'}"
        labelled.add(int(d))
        ax.plot(g["target"], g["deviation"], "-", color=colours[int(d)], lw=0.6, alpha=0.35, label=label)
    x = pt["target"].to_numpy()
    for d, col, s_col, label in ((1, "mean_up", "s_up", "up"), (-1, "mean_down", "s_down", "down")):
        mean = pt[col].to_numpy()
        if not np.isfinite(mean).any():
            continue
        ks = r.k * pt[s_col].to_numpy()
        ax.plot(x, mean, "o-", color=colours[d], ms=3.5, lw=1.4, label=f"mean {label}")
        ax.fill_between(x, mean - ks, mean + ks, color=colours[d], alpha=0.15,
                        label=f"mean {label} ± {r.k:g} s")
    a = r.axis
    # the bidirectional value of each family, else the unidirectional one that was evaluated
    families = (("A", "A_up", "A_down"), ("E", "E_up", "E_down"), ("R", "R_up", "R_down"), ("B",))
    shown = [next((q for q in fam if np.isfinite(a[q])), None) for fam in families]
    vals = ", ".join(f"{q} = {a[q]:.3f}" for q in shown if q is not None)
    unit = UNIT_LABELS.get(r.unit, r.unit)
    ax.set_title(f"{r.edition} positioning ({r.directions}): {vals} {unit}", fontsize=10)
    ax.set_ylabel(f"deviation actual - target ({unit})")
    ax.grid(True, alpha=0.3)
    legend_above_data(ax, ncol=3)
    rev = pt["reversal"].to_numpy()
    width = 0.6 * (np.min(np.diff(x)) if len(x) > 1 else 1.0)
    axb.bar(x, np.nan_to_num(rev), width=width, color="tab:gray")
    if not np.isfinite(rev).any():
        axb.text(0.5, 0.5, "no reversal: one direction measured", transform=axb.transAxes, ha="center",
                 va="center", fontsize=9, color="0.3")
    axb.set_ylabel(f"reversal B_i ({unit})")
    axb.set_xlabel(f"target ({r.target_unit})")
    axb.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
