"""The HTML report of a verification (``guideway verify --report FILE``): the runs, the table, the verdict,
the before/after overlay and the prediction against AS_LEFT (both compare's overlay plot), the values and
the per-target table; in the conventions of the compare report (self-contained, every text escaped)."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from saved_runs.report.build import tool_version
from saved_runs.report.common import UNIT_LABELS, conventions_section
from saved_runs.report.html import HtmlPage, figure_png, write_page

if TYPE_CHECKING:
    from .verify import Verification


def verify_command(found: Any, left: Any, report: Any, options: dict[str, Any]) -> str:
    """The ``guideway verify`` command line that reproduces the report."""
    from ..compare.report import two_run_command

    return two_run_command("verify", found, left, report, options)


def render_verification(c: Verification, *, command: str = "") -> str:
    from processing.iso230_2 import QUANTITY_NAMES

    from ..compare.figures import positioning_overlay

    d = c.detail
    unit = UNIT_LABELS.get(d.unit, d.unit)
    machine = c.left.machine or c.found.machine or "machine"
    axis = c.left.axis or c.found.axis
    page = HtmlPage(f"guideway verify — {machine}" + (f", axis {axis}" if axis else ""))
    if c.found.simulated or c.left.simulated:
        page.banner("SIMULATED RUN — not a measurement of a machine")
    page.heading("Result")
    page.paragraph(c.verdict(), "headline")
    page.paragraph(f"Table: {c.table.text()}.")
    flagged = c.flagged()
    if flagged:
        page.alert(f"Flagged: {', '.join(flagged)} — the gain is smaller than AS_LEFT's repeatability or than the "
                   "drift between the runs.")
    page.heading("Runs")
    page.table(("", "run directory", "uid", "machine", "axis", "created (UTC)", "status", "points"),
               [(label, r.path, r.uid, r.machine, r.axis, r.created, r.status, r.points)
                for label, r in (("AS_FOUND", c.found), ("AS_LEFT", c.left))], text_columns=(0, 1, 2, 3, 4, 5, 6))
    page.heading("Before and after")
    if c.drift is None:
        from .figures import shifted_overlay

        page.image(figure_png(shifted_overlay(d)), "The mean deviation per target, ↑ blue, ↓ red; AS_FOUND at its "
                   "targets dashed with open markers, AS_LEFT on the shifted targets (between the table's points) "
                   "solid.")
        page.paragraph(c.between.text(d.unit, d.target_unit) + ".")  # type: ignore[union-attr]
    else:
        page.image(figure_png(positioning_overlay(d)),
                   f"Top: the mean deviation per target, ↑ blue, ↓ red; AS_FOUND (A) dashed with open markers, "
                   f"AS_LEFT (B) solid. Bottom: the change AS_LEFT − AS_FOUND with its expanded uncertainty "
                   f"(k = {d.k:g}).")
        page.image(figure_png(positioning_overlay(c.drift.residual)),
                   "The prediction (A, dashed: AS_FOUND with the table applied as the controller applies it) against "
                   "AS_LEFT (B, solid); bottom: AS_LEFT − prediction, the change the table does not explain (drift).")
    page.heading(f"ISO 230-2 values ({unit}, {d.a.result.edition}, k = {d.k:g})", 3)
    rows = []
    for q, v in c.values.items():
        rows.append((q, v.found, v.u_found, v.left, v.u_left, v.predicted, v.u_predicted, v.expected, v.reduction_pct,
                     v.u_reduction_pct, v.predicted_reduction_pct, {True: "yes", False: "no", None: "—"}[v.agrees],
                     "; ".join(v.flags), QUANTITY_NAMES[q][0]))
    page.table(("value", "found", "u", "left", "u", "predicted", "u", "again", "reduction %", "u %", "predicted %",
                "as predicted", "flags", "name"), rows, text_columns=(0, 11, 12, 13))
    page.paragraph("u of found and left = standard uncertainty of each value from its run's repeated approaches "
                   "(parametric Monte Carlo); u of predicted = the spread of the value a repeat measurement with the "
                   "table shows (the as-found means' noise carried into the prediction and the repeat's own), "
                   "again = its mean; reduction = 100·(1 − |left|/|found|); as predicted: |left − again| ≤ "
                   "k·u_predicted. Flags: the gain |found| − |left| is smaller than AS_LEFT's repeatability or than "
                   "the drift." + ("" if c.drift is None else f" {c.drift.text(d.unit)}."), "note")
    if c.drift is not None:
        page.heading(f"Per target and direction ({unit})", 3)
        trows = []
        for t, p in zip(d.targets, c.drift.residual.targets, strict=True):
            trows.append((t.target, "↑" if t.direction > 0 else "↓", t.a.mean if t.a else None,
                          t.b.mean if t.b else None, p.a.mean if p.a else None, p.change, p.expanded))
        page.table((f"target ({UNIT_LABELS.get(d.target_unit, d.target_unit)})", "dir.", "found", "left",
                    "predicted", "left − predicted", f"U, k = {d.k:g}"), trows, text_columns=(1,))
    notes = (*c.notes, *c.comparison.notes, *d.notes)
    if notes:
        page.heading("Notes", 3)
        for note in notes:
            page.paragraph(f"Note: {note}")
    conventions_section(page, "positioning")
    generated = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    page.paragraph(f"Produced by guideway {tool_version()} on {generated} with: {command}", "note footer")
    return page.render()


def write_verification_report(c: Verification, out: Path | str, *, command: str = "") -> Path:
    return write_page(out, render_verification(c, command=command), option="--report", example="verify.html")
