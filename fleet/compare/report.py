"""The HTML report of a comparison (``guideway compare --report FILE``): the two runs, the headline, the
overlay plot, the values side by side and the per-target or per-station table, in the conventions of the
run report (saved_runs/report: self-contained, plots embedded, every text escaped)."""

from __future__ import annotations

import shlex
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from saved_runs.report.build import tool_version
from saved_runs.report.common import UNIT_LABELS, conventions_section
from saved_runs.report.html import HtmlPage, figure_png, write_page

from .positioning import PositioningComparison

if TYPE_CHECKING:
    from .compare import Comparison

LINE_LABELS = {"endpoint": "end-point line", "least_squares": "least-squares line", "minimum_zone": "minimum-zone line"}


def compare_command(run_a: Any, run_b: Any, report: Any, options: dict[str, Any]) -> str:
    """The ``guideway compare`` command line that reproduces the report."""
    return two_run_command("compare", run_a, run_b, report, options)


def two_run_command(command: str, run_a: Any, run_b: Any, report: Any, options: dict[str, Any]) -> str:
    """The ``guideway COMMAND RUN_A RUN_B --report FILE [options]`` line that reproduces a report of two runs
    (``options``: name -> value; True a flag, False/None left out)."""
    args = ["guideway", command, str(run_a), str(run_b), "--report", str(report)]
    for key, value in options.items():
        if value is True:
            args.append(f"--{key.replace('_', '-')}")
        elif value not in (False, None):
            args += [f"--{key.replace('_', '-')}", str(value)]
    return shlex.join(args)


def render_comparison(c: Comparison, *, command: str = "") -> str:
    """The HTML document of comparison ``c``."""
    from .figures import overlay_figure

    d = c.detail
    axis = c.b.axis or c.a.axis
    machine = c.b.machine or c.a.machine or "machine"
    page = HtmlPage(f"guideway compare — {c.kind}, {machine}" + (f", axis {axis}" if axis else ""))
    if c.a.simulated or c.b.simulated:
        which = " and ".join(label for label, r in (("A", c.a), ("B", c.b)) if r.simulated)
        page.banner(f"SIMULATED RUN ({which}) — not a measurement of a machine")
    for label, r in (("A", c.a), ("B", c.b)):
        if r.status != "complete":
            page.alert(f"Run {label} is {r.status or 'of unknown status'}: only its {r.points} recorded points are "
                       "compared.")
    sig, of = c.significant_count()
    page.heading("Result")
    unit = UNIT_LABELS.get(getattr(d, "unit", "um"), "µm")
    rows = d.matched()
    changes = [abs(r.change) for r in rows if r.change is not None]
    largest = f"; largest |change| {max(changes):.3f} {unit}" if changes else ""
    where = "target/direction rows" if isinstance(d, PositioningComparison) else "stations"
    page.paragraph(f"{sig} of {of} {where} changed by more than the expanded uncertainty of the change (k = "
                   f"{d.k:g}){largest}.", "headline")
    page.heading("Runs")
    page.table(("", "run directory", "uid", "machine", "axis", "created (UTC)", "status", "points", "verdict"),
               [(label, r.path, r.uid, r.machine, r.axis, r.created, r.status, r.points, r.verdict or "—")
                for label, r in (("A (before)", c.a), ("B (after)", c.b))], text_columns=(0, 1, 2, 3, 4, 5, 6, 8))
    page.paragraph("Change = B − A. Both runs are evaluated as guideway process evaluates them (same options); "
                   "nothing is written into the runs.", "note")
    page.heading("Overlay")
    if isinstance(d, PositioningComparison):
        caption = (f"Top: the mean deviation per target, ↑ blue, ↓ red; A dashed with open markers, B solid. "
                   f"Bottom: the change B − A with its expanded uncertainty U (k = {d.k:g}); filled where "
                   "|change| > U.")
    else:
        caption = ("Top: both profiles, each with its own least-squares line over the common stations removed, with "
                   f"their U bands (k = {d.k:g}). Bottom: the change B − A per station with its U; filled where "
                   "|change| > U.")
    page.image(figure_png(overlay_figure(d)), caption)
    values_section(page, c)
    if isinstance(d, PositioningComparison):
        targets_section(page, d)
    else:
        stations_section(page, d)
    notes = (*c.notes, *d.notes)
    if notes:
        page.heading("Notes", 3)
        for note in notes:
            page.paragraph(f"Note: {note}")
    conventions_section(page, c.kind)
    generated = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    page.paragraph(f"Produced by guideway {tool_version()} on {generated} with: {command}", "note footer")
    return page.render()


def values_section(page: HtmlPage, c: Comparison) -> None:
    d = c.detail
    values = d.values()
    if isinstance(d, PositioningComparison):
        from processing.iso230_2 import QUANTITY_NAMES

        unit = UNIT_LABELS.get(d.unit, d.unit)
        page.heading(f"ISO 230-2 values ({d.a.result.edition}, k = {d.k:g})", 3)
        page.table(("symbol", f"A ({unit})", f"B ({unit})", f"change ({unit})", "change (%)", "name"),
                   [(q, v["a"], v["b"], v["change"], v["change_pct"], QUANTITY_NAMES[q][0]) for q, v in values.items()],
                   text_columns=(0, 5))
        page.paragraph("Change in % of A's value. — = not evaluable in a run (see its notes). Each value covers all "
                       "targets of its run.", "note")
    else:
        page.heading("Straightness values", 3)
        page.table(("reference line", "A (µm)", "U A (µm)", "B (µm)", "U B (µm)", "change (µm)", "change (%)",
                    "U of change (µm)", "|change| > U"),
                   [(LINE_LABELS.get(n, n), v["a"], v["U_a"], v["b"], v["U_b"], v["change"], v["change_pct"], v["U"],
                     v["significant"]) for n, v in values.items()], text_columns=(0,))
        page.paragraph("Each run's straightness against its own reference lines over its own stations; U (k = 2) "
                       "from each run's Monte Carlo, U of change = √(U_A² + U_B²) (— with Monte Carlo off).", "note")


def targets_section(page: HtmlPage, d: PositioningComparison) -> None:
    unit = UNIT_LABELS.get(d.unit, d.unit)
    page.heading(f"Per target and direction ({unit})", 3)
    rows = []
    for t in d.targets:
        rows.append((t.target, "↑" if t.direction > 0 else "↓", t.a.mean if t.a else None, t.a.n if t.a else 0,
                     t.b.mean if t.b else None, t.b.n if t.b else 0, t.change, t.expanded, t.significant,
                     f"only in {t.only_in.upper()}" if t.only_in else ""))
    page.table((f"target ({UNIT_LABELS.get(d.target_unit, d.target_unit)})", "dir.", "x̄ A", "n A", "x̄ B", "n B",
                "change", f"U, k = {d.k:g}", "|change| > U", ""), rows, digits=3, text_columns=(1, 9))
    page.paragraph(f"x̄ = mean deviation of the approaches in that direction; change = x̄_B − x̄_A; "
                   f"U = k·√(s_A²/n_A + s_B²/n_B), the standard uncertainties of the two means from each run's own "
                   f"repeated approaches combined in quadrature, k = {d.k:g} (docs/compare.md). It holds the "
                   "run-to-run scatter only, not the laser's or the environment compensation's uncertainty.", "note")


def stations_section(page: HtmlPage, d: Any) -> None:
    page.heading("Per station (µm)", 3)
    page.table(("station", "x (mm)", "A", "B", "change", f"U, k = {d.k:g}", "|change| > U", ""),
               [(s.station, s.x_mm, s.a, s.b, s.change, s.expanded, s.significant,
                 f"only in {s.only_in.upper()}" if s.only_in else "") for s in d.stations],
               digits=3, text_columns=(7,))
    la, lb = d.lines["a"], d.lines["b"]
    page.paragraph("A, B = deviation of each profile from its own least-squares line, fitted over the stations both "
                   f"runs measured (A: slope {la[0] * 1000:.3f} µm/m, B: {lb[0] * 1000:.3f} µm/m removed); change = "
                   f"B − A; U = k·√(u_A² + u_B²), u = the per-station standard uncertainty of the height (GUM) "
                   f"propagated through the removal of the line, k = {d.k:g} (docs/compare.md).", "note")


def write_comparison_report(c: Comparison, out: Path | str, *, command: str = "") -> Path:
    """Write the HTML report of ``c`` to ``out`` (atomically); return the path."""
    return write_page(out, render_comparison(c, command=command), option="--report", example="compare.html")
