"""A verification as text: the terminal output of ``guideway verify`` (and lines a TUI screen can show)."""

from __future__ import annotations

from typing import TYPE_CHECKING, TextIO

from ..compare.text import num, run_line

if TYPE_CHECKING:
    from .verify import ValueCheck, Verification

MAX_ROWS = 60  # target rows printed; all are in --json and the report


def _pm(v: float | None, u: float | None, digits: int = 3) -> str:
    return f"{num(v, digits)} ± {num(u, digits)}" if v is not None else "n/a"


def _pct(v: float | None, u: float | None = None) -> str:
    if v is None:
        return "n/a"
    return f"{v:.1f} %" if u is None else f"{v:.1f} ± {u:.1f} %"


def value_line(name: str, v: ValueCheck) -> str:
    flags = "; ".join(v.flags)
    agree = {True: "yes", False: "NO", None: "n/a"}[v.agrees]
    return (f"{name:<7} {_pm(v.found, v.u_found):>17} {_pm(v.left, v.u_left):>17} {_pm(v.predicted, v.u_predicted):>17}"
            f" {num(v.expected):>8} {_pct(v.reduction_pct, v.u_reduction_pct):>16} {_pct(v.predicted_reduction_pct):>9}"
            f" {agree:>8}"
            + (f"  {flags}" if flags else ""))


def value_lines(c: Verification) -> list[str]:
    """The heading, the column names and one line per ISO 230-2 value."""
    unit = c.unit
    lines = [f"ISO 230-2 values ({unit}; ± u, the standard uncertainty from each run's approaches; again = the "
             "prediction as a repeat measurement shows it; reduction = 100 (1 - |left| / |found|), pred. = predicted)",
             f"{'value':<7} {'found':>17} {'left':>17} {'predicted':>17} {'again':>8} {'reduction':>16} {'pred.':>9} "
             f"{'as pred.':>8}"]
    lines += [value_line(q, v) for q, v in c.values.items()]
    return lines


def shifted_lines(c: Verification, max_rows: int | None = MAX_ROWS) -> list[str]:
    """AS_LEFT's targets (between the table's points): its mean and s per direction."""
    pt = c.detail.b.result.per_target
    lines = [f"AS_LEFT per target and direction ({c.unit}), its targets shifted by "
             f"{c.between.shift:g} {c.detail.target_unit}:",  # type: ignore[union-attr]
             f"{'target ' + c.detail.target_unit:>12} {'dir':>3} {'left':>9} {'s':>8}"]
    for row in pt.itertuples(index=False):
        for name, sign in (("up", "+"), ("down", "-")):
            if getattr(row, f"n_{name}") > 0:
                lines.append(f"{row.target:>12.4f} {sign:>3} {num(getattr(row, f'mean_{name}')):>9} "
                             f"{num(getattr(row, f's_{name}')):>8}")
    return lines[: None if max_rows is None else max_rows + 2]


def target_lines(c: Verification, max_rows: int | None = MAX_ROWS) -> list[str]:
    if c.drift is None:
        return shifted_lines(c, max_rows)
    d, r = c.detail, c.drift.residual
    lines = [f"per target and direction ({c.unit}): found, left, predicted, left - predicted with its U (k = {d.k:g})",
             f"{'target ' + d.target_unit:>12} {'dir':>3} {'found':>9} {'left':>9} {'predicted':>9} {'left-pred':>9} "
             f"{'U':>8}"]
    for t, p in list(zip(d.targets, r.targets, strict=True))[:max_rows]:
        lines.append(f"{t.target:>12.4f} {'+' if t.direction > 0 else '-':>3} {num(t.a.mean if t.a else None):>9} "
                     f"{num(t.b.mean if t.b else None):>9} {num(p.a.mean if p.a else None):>9} {num(p.change):>9} "
                     f"{num(p.expanded):>8}")
    if max_rows is not None and len(d.targets) > max_rows:
        lines.append(f"... {len(d.targets) - max_rows} more rows (--json, --report)")
    return lines


def print_verification(c: Verification, stream: TextIO) -> None:
    print("verify: AS_FOUND, the table exported from it, AS_LEFT measured with the table active", file=stream)
    print(run_line("AS_FOUND", c.found), file=stream)
    print(run_line("AS_LEFT", c.left), file=stream)
    print(f"table: {c.table.text()}", file=stream)
    targets = target_lines(c)
    print(targets[0], file=stream)
    for line in targets[1:]:
        print(f"  {line}", file=stream)
    lines = value_lines(c)
    print(lines[0], file=stream)
    for line in lines[1:]:
        print(f"  {line}", file=stream)
    if c.drift is not None:
        print(c.drift.text(c.unit), file=stream)
    if c.between is not None:
        print(c.between.text(c.unit, c.detail.target_unit), file=stream)
    print(f"verdict: {c.verdict()}", file=stream)
    flagged = c.flagged()
    if flagged:
        print(f"flagged ({len(flagged)}): {', '.join(flagged)}: the gain is smaller than the repeatability or the "
              "drift between the runs", file=stream)
    for note in (*c.notes, *c.comparison.notes, *c.detail.notes):
        print(f"note: {note}", file=stream)
