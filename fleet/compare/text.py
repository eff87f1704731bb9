"""The comparison as text: the terminal summary of ``guideway compare`` and the TUI's compare screen."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TextIO

from .positioning import PositioningComparison

if TYPE_CHECKING:
    from .compare import Comparison

MAX_ROWS = 60  # rows printed in the terminal; all of them are in --json and the report


def num(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def flag(significant: bool | None) -> str:
    return {True: "yes", False: "no", None: "n/a"}[significant]


def run_line(label: str, r: Any) -> str:
    what = ", ".join(filter(None, [r.machine, f"axis {r.axis}" if r.axis else "", r.created, r.status]))
    return f"{label}: {r.path} ({what})" + (" SIMULATED" if r.simulated else "")


def change_table(c: Comparison, max_rows: int | None = None) -> list[str]:
    """The per-target (per-station) table: a heading line, the column names, one line per row."""
    d = c.detail
    sig, of = c.significant_count()
    lines = []
    if isinstance(d, PositioningComparison):
        lines.append(f"per target and direction ({d.unit}; U = {d.k:g} * sqrt(s_a^2/n_a + s_b^2/n_b)): {sig} of {of} "
                     "changes larger than U")
        lines.append(f"{'target ' + d.target_unit:>12} {'dir':>3} {'A':>9} {'B':>9} {'change':>9} {'U':>8} {'> U':>4}")
        for t in d.targets[:max_rows]:
            only = f"  only in {t.only_in.upper()}" if t.only_in else ""
            lines.append(f"{t.target:>12.4f} {'+' if t.direction > 0 else '-':>3} {num(t.a.mean if t.a else None):>9} "
                         f"{num(t.b.mean if t.b else None):>9} {num(t.change):>9} {num(t.expanded):>8} "
                         f"{flag(t.significant):>4}{only}")
        rows = len(d.targets)
    else:
        lines.append(f"per station (um; each profile's own least-squares line over the common stations removed; "
                     f"U = {d.k:g} * sqrt(u_a^2 + u_b^2)): {sig} of {of} changes larger than U")
        lines.append(f"{'station':>7} {'x mm':>9} {'A':>9} {'B':>9} {'change':>9} {'U':>8} {'> U':>4}")
        for s in d.stations[:max_rows]:
            only = f"  only in {s.only_in.upper()}" if s.only_in else ""
            lines.append(f"{s.station:>7} {s.x_mm:>9.2f} {num(s.a):>9} {num(s.b):>9} {num(s.change):>9} "
                         f"{num(s.expanded):>8} {flag(s.significant):>4}{only}")
        rows = len(d.stations)
    if max_rows is not None and rows > max_rows:
        lines.append(f"... {rows - max_rows} more rows (--json, --report)")
    return lines


def value_lines(c: Comparison) -> list[str]:
    """The values of both runs side by side, one line each."""
    lines = []
    for name, v in c.detail.values().items():
        pct = "n/a" if v["change_pct"] is None else f"{v['change_pct']:+.1f} %"
        extra = f"  U {num(v['U'])}, > U: {flag(v['significant'])}" if "U" in v else ""
        lines.append(f"{name:<14} A {num(v['a']):>8}  B {num(v['b']):>8}  change {num(v['change']):>8} "
                     f"({pct}){extra}")
    return lines


def print_comparison(c: Comparison, stream: TextIO) -> None:
    print(f"compare {c.kind} runs, change = B - A", file=stream)
    print(run_line("A", c.a), file=stream)
    print(run_line("B", c.b), file=stream)
    table = change_table(c, MAX_ROWS)
    print(table[0], file=stream)
    for line in table[1:]:
        print(f"  {line}", file=stream)
    print("values:", file=stream)
    for line in value_lines(c):
        print(f"  {line}", file=stream)
    for note in (*c.notes, *c.detail.notes):
        print(f"note: {note}", file=stream)
