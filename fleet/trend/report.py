"""The printable HTML page of a trend (``guideway trend --report FILE``): the plot of the values with
their uncertainty bars, the fitted line and the limit, then the table of runs and the fit."""

from __future__ import annotations

from pathlib import Path

from saved_runs.report.html import HtmlPage, figure_png, write_page

from .fit import DAYS_PER_YEAR, STEP_K, parse_date
from .of_catalog import AxisTrend


def _figure(at: AxisTrend) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, u = at.trend, at.unit
    dates = [parse_date(p.date) for p in t.points]
    fig, ax = plt.subplots(figsize=(8, 4.2))
    yerr = [p.u_um if p.u_um is not None else 0.0 for p in t.points]
    ax.errorbar(dates, [p.value_um for p in t.points], yerr=yerr, fmt="o", capsize=3, label=f"{at.value} (± u)")
    ends = list(dates)
    if t.crossing_date is not None:
        ends.append(parse_date(t.crossing_date))
    if t.slope_um_per_year is not None and len(ends) >= 2:
        lo, hi = min(ends), max(ends)
        line = [t.line_um(d) for d in (lo, hi)]
        ax.plot([lo, hi], line, "-", color="C1",
                label=f"trend {t.slope_um_per_year:+.3f} {u}/year")
    if t.limit_um is not None:
        ax.axhline(t.limit_um, color="C3", linestyle="--", label=f"limit {t.limit_um:g} {u}")
    for s in t.steps:
        ax.axvline(parse_date(s.date), color="0.6", linestyle=":", linewidth=1)
    ax.set_ylabel(f"{at.value} / {u}")
    ax.set_xlabel("run date (UTC)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    fig.autofmt_xdate()
    fig.tight_layout()
    return figure_png(fig)


def write_trend_report(at: AxisTrend, out: Path | str) -> Path:
    """Write the report of ``at`` to ``out`` (atomically); return the path."""
    t, u = at.trend, at.unit
    page = HtmlPage(f"Trend of {at.value}: machine {at.machine or '-'}, axis {at.axis or '-'}")
    page.image(_figure(at), f"{at.value} of every catalogued run of the axis with its standard uncertainty (k = 1), "
                            "the weighted least-squares line and the limit; dotted: steps between runs")
    page.heading("Fit")
    rows = [("runs", len(t.points)), ("weights", t.weights),
            (f"slope ({u}/year, years of {DAYS_PER_YEAR} days)", t.slope_um_per_year),
            (f"standard uncertainty of the slope ({u}/year)", t.u_slope_um_per_year),
            ("chi² per degree of freedom", t.chi2_per_dof),
            ("uncertainties scaled by √(χ²/dof)", t.u_scale),
            (f"limit ({u})", t.limit_um), ("limit from", at.limit_source or "—"),
            ("beyond the limit", at.beyond_text or "no"),
            ("limit reached (UTC)", t.crossing_date or (t.crossing_note or "—")),
            ("standard uncertainty of that date (days)", t.u_crossing_days)]
    if t.crossing_note and t.crossing_date:
        rows.append(("note", t.crossing_note))
    page.key_values(rows)
    page.paragraph("slope b and intercept a minimise Σ w_i (y_i − a − b t_i)² with w_i = 1/u_i²; "
                   "u(b)² = 1/Σ w_i (t_i − t̄)²; the limit L is reached at t* = (L − a)/b with "
                   "u(t*)² = (u(a)² + t*² u(b)² + 2 t* cov(a, b))/b² (docs/fleet.md).", cls="note")
    page.heading("Runs (oldest first)")
    stepped = {s.to_run: s for s in t.steps}
    page.table(("date (UTC)", f"{at.value} ({u})", f"u ({u})", f"step ({u})", "run", "directory"),
               [(p.date, p.value_um, p.u_um, stepped[p.run].change_um if p.run in stepped else None, p.name, p.path)
                for p in t.points], text_columns=(0, 4, 5))
    page.paragraph(f"A step is a run whose value departs from the line of the runs before it (since the last step) "
                   f"by more than {STEP_K:g} times the combined standard uncertainty of the value and of the line's "
                   "prediction: a crash, a repair, a new compensation, not the wear between runs.", cls="note")
    return write_page(out, page.render(), option="--report", example="trend.html")
