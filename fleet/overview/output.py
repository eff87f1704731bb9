"""The fleet overview as text (a table for the terminal), CSV (one header line, for a spreadsheet) and a
printable HTML page with a small inline SVG trend plot per row (no matplotlib: a page of 150 rows is written
in milliseconds)."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import TextIO

from saved_runs.errors import printable  # control characters escaped, as everywhere a name is shown
from saved_runs.report.html import HtmlPage, esc, write_page

from .overview import COVERAGE_K, FleetRow, Overview

CSV_COLUMNS = ("machine", "axis", "value", "unit", "limit", "limit_source", "run_date", "operator", "run",
               "value_measured", f"U_k{COVERAGE_K:g}", "verdict", "decision_rule", "runs", "slope_per_year",
               "u_slope_per_year", "crossing_date", "u_crossing_days", "beyond_limit_since", "last_step_date",
               "last_step_change", "compensation", "compensation_sha256", "interval_days", "calibration_due",
               "overdue")


def _num(x: float | None, digits: int = 3) -> str:
    return "" if x is None else f"{x:.{digits}f}"


def limit_text(r: FleetRow) -> str:
    """The row's state against its limit in a few words: beyond since, the crossing date, or why none."""
    t = r.trend
    if r.limit_um is None:
        return "no limit"
    if t is None:
        return "no run"
    if t.beyond_limit and t.beyond_since is not None:
        return f"BEYOND since {t.beyond_since.date[:10]}"
    if t.crossing_date is not None:
        ud = f" ± {t.u_crossing_days:.0f} d" if t.u_crossing_days is not None else ""
        return f"reaches {t.crossing_date[:10]}{ud}"
    return "no date: " + _short_note(t.crossing_note)


def _short_note(note: str) -> str:
    """The crossing note's reason, shortened for a table cell."""
    if "does not grow" in note or "does not change" in note:
        return "not growing"
    if "falls" in note:
        return "falling"
    if "span" in note:
        return "span < 30 days"
    if "runs: a crossing date needs" in note or "at least two runs" in note:
        return "< 3 runs"
    return note[:30] or "-"


def row_cells(r: FleetRow) -> list[str]:
    """The cells of the text table."""
    t = r.trend
    run = f"{r.run.date[:10]} {r.run.operator or '-'}" if r.run else "no complete run"
    val = "-" if r.value_um is None else f"{r.value_um:.3f}" + ("" if r.u_um is None else
                                                                f" ± {r.expanded_u_um:.3f}")
    slope = "-" if t is None or t.slope_um_per_year is None else (
        f"{t.slope_um_per_year:+.3f}" + ("" if t.u_slope_um_per_year is None else f" ± {t.u_slope_um_per_year:.3f}"))
    step = r.last_step
    due = "-" if r.calibration_due is None else (("OVERDUE " if r.overdue else "") + r.calibration_due[:10])
    return [r.machine or "-", r.axis or "-", r.value, run, val, r.verdict or "-",
            "-" if r.limit_um is None else f"{r.limit_um:g}", slope, limit_text(r),
            "-" if step is None else f"{step.date[:10]} {step.change_um:+.3f}", _comp_short(r), due]


def _comp_short(r: FleetRow) -> str:
    c = r.compensation
    if c.get("active"):
        return f"{c.get('file') or '?'} {str(c.get('sha256') or '')[:8]}"
    return r.compensation_text()


HEADER = ["machine", "axis", "value", "last run, operator", "value ± U (k=2)", "verdict", "limit", "trend /year ± u",
          "limit state", "last step", "compensation", "calibration due"]


def print_text(ov: Overview, stream: TextIO) -> None:
    """The table, then the instruments and the runs left out."""
    table = [HEADER] + [[printable(c) for c in row_cells(r)] for r in ov.rows]
    widths = [max(len(row[i]) for row in table) for i in range(len(HEADER))]
    for row in table:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip(), file=stream)
    units = sorted({r.unit for r in ov.rows})
    print(f"{len(ov.rows)} row(s) in {ov.url}; values, U and limits in {', '.join(units) or 'um'}; U = "
          f"{COVERAGE_K:g} u; urgency order: beyond the limit, crossing date, age of the last run", file=stream)
    if ov.instruments:
        print("instruments (latest calibration record):", file=stream)
        for i in ov.instruments:
            due = i.due.isoformat() if i.due else (f"{i.record['due']!r} (not a date)" if i.record.get("due")
                                                   else "no due date")
            print(printable(f"  {i.label}: due {due}; certificate {i.record.get('certificate') or '-'}; last used "
                            f"{i.run.date[:10]} in run {i.run.name} on {i.machine or '-'}"), file=stream)
    if ov.left_out:
        print(printable(f"left out: {', '.join(ov.left_out)}"), file=stream)


def csv_text(ov: Overview) -> str:
    """One header line, then one line per row (numbers with a dot, dates as YYYY-MM-DD)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in ov.rows:
        t = r.trend
        step = r.last_step
        since = t.beyond_since if t is not None else None
        w.writerow([r.machine, r.axis, r.value, r.unit, _num(r.limit_um, 6), r.limit_source,
                    r.run.date if r.run else "", r.run.operator if r.run else "", r.run.name if r.run else "",
                    _num(r.value_um, 6), _num(r.expanded_u_um, 6), r.verdict or "", r.decision_rule,
                    0 if t is None else len(t.points), _num(t and t.slope_um_per_year, 6),
                    _num(t and t.u_slope_um_per_year, 6), (r.crossing_date or "")[:10],
                    _num(t and t.u_crossing_days, 1), since.date[:10] if since else "",
                    step.date[:10] if step else "", _num(step.change_um, 6) if step else "",
                    r.compensation_text() if not r.compensation.get("active") else str(r.compensation.get("file")),
                    str(r.compensation.get("sha256") or ""), _num(r.interval_days, 1),
                    (r.calibration_due or "")[:10], "yes" if r.overdue else "no"])
    return buf.getvalue()


def sparkline_svg(r: FleetRow, width: int = 160, height: int = 36) -> str:
    """A small plot of the row's values against time: points (black), the fitted line (blue), the limit (red,
    dashed); an empty string when there is nothing to plot.  Black on white with solid strokes: legible when
    printed in grey."""
    t = r.trend
    if t is None or not t.points:
        return ""
    from fleet.trend.fit import parse_date, years_between

    t0 = parse_date(t.points[0].date)
    xs = [years_between(t0, parse_date(p.date)) for p in t.points]
    ys = [p.value_um for p in t.points]
    lo_y = min([*ys, *([r.limit_um] if r.limit_um is not None else [])])
    hi_y = max([*ys, *([r.limit_um] if r.limit_um is not None else [])])
    if t.signed and r.limit_um is not None:
        lo_y = min(lo_y, -r.limit_um)
    span_x = (max(xs) - min(xs)) or 1.0
    span_y = (hi_y - lo_y) or 1.0
    pad = 3.0

    def px(x: float) -> float:
        return pad + (x - min(xs)) / span_x * (width - 2 * pad)

    def py(y: float) -> float:
        return height - pad - (y - lo_y) / span_y * (height - 2 * pad)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'viewBox="0 0 {width} {height}" role="img" aria-label="trend of {esc(r.value)}">']
    if r.limit_um is not None:
        for lim in ([r.limit_um, -r.limit_um] if t.signed else [r.limit_um]):
            parts.append(f'<line x1="{pad}" y1="{py(lim):.1f}" x2="{width - pad}" y2="{py(lim):.1f}" '
                         'stroke="#c00" stroke-width="1" stroke-dasharray="3,2"/>')
    if t.slope_um_per_year is not None and t.intercept_um is not None:
        a, b = t.intercept_um, t.slope_um_per_year
        parts.append(f'<line x1="{px(min(xs)):.1f}" y1="{py(a + b * min(xs)):.1f}" x2="{px(max(xs)):.1f}" '
                     f'y2="{py(a + b * max(xs)):.1f}" stroke="#04c" stroke-width="1.2"/>')
    parts.append('<polyline fill="none" stroke="#888" stroke-width="0.6" points="'
                 + " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in zip(xs, ys, strict=True)) + '"/>')
    parts += [f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="1.4" fill="#000"/>' for x, y in zip(xs, ys, strict=True)]
    parts.append("</svg>")
    return "".join(parts)


class _Page(HtmlPage):
    """An HtmlPage that takes a table of its own making (cells holding SVG)."""

    def raw(self, html: str) -> None:
        self._parts.append(html)


def write_report(ov: Overview, out: Path | str) -> Path:
    """Write the printable HTML page of ``ov`` to ``out`` (atomically); return the path."""
    page = _Page("Fleet overview")
    page.paragraph(f"Catalogue {ov.url}, as of {ov.now.strftime('%Y-%m-%d %H:%M')} UTC: {len(ov.rows)} row(s), "
                   "most urgent first (beyond the limit, then by the date the trend reaches it, then by the age of "
                   f"the last run). Values, U (k = {COVERAGE_K:g}) and limits in µm (arc-seconds on a rotary axis); "
                   "trend per year with its standard uncertainty u.", cls="note")
    head = ["machine", "axis", "value", "last run", "operator", "value ± U", "verdict (rule)", "limit",
            "trend /year ± u", "limit state", "last step", "compensation", "calibration due", "trend"]
    lines = ['<table class="fleet"><thead><tr>' + "".join(f'<th class="text">{esc(h)}</th>' for h in head)
             + "</tr></thead>"]
    for r in ov.rows:
        c = row_cells(r)
        cls = ' class="beyond"' if r.beyond else (' class="soon"' if r.crossing_date else "")
        cells = [c[0], c[1], c[2], f"{r.run.name} ({r.run.date[:10]})" if r.run else "no complete run",
                 r.run.operator if r.run else "", c[4], f"{c[5]} ({r.decision_rule})", c[6], c[7], c[8], c[9],
                 r.compensation_text(), c[11]]
        lines.append(f"<tr{cls}>" + "".join(f'<td class="text">{esc(x)}</td>' for x in cells)
                     + f"<td>{sparkline_svg(r)}</td></tr>")
    lines.append("</table>")
    page.raw("<style>table.fleet { font-size: .75em; } table.fleet td { vertical-align: middle; } "
             "tr.beyond td { font-weight: bold; } tr.beyond td:first-child { border-left: 4px solid #c00; } "
             "tr.soon td:first-child { border-left: 4px solid #a60; } "
             "@media print { table.fleet { font-size: 7pt; } }</style>")
    page.raw("\n".join(lines))
    page.paragraph("Plot per row: the runs' values (dots), the weighted least-squares line (blue) and the limit (red, "
                   "dashed), from the first to the latest complete run. A row marked at the left in red is beyond "
                   "its limit; in amber, its trend reaches the limit at the date given.", cls="note")
    if ov.instruments:
        page.heading("Instruments (latest calibration record)")
        page.table(("instrument", "certificate", "calibrated", "due", "last used", "run", "machine"),
                   [(i.label, i.record.get("certificate", ""), i.record.get("calibrated", ""),
                     i.record.get("due", ""), i.run.date[:10], i.run.name, i.machine) for i in ov.instruments],
                   text_columns=tuple(range(7)))
    if ov.left_out:
        page.paragraph(f"Left out: {', '.join(ov.left_out)}", cls="note")
    return write_page(out, page.render(), option="--report", example="fleet.html")
