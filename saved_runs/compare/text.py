"""The terminal summary of a comparison (``guideway compare`` without ``--json``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TextIO

from .positioning import PositioningComparison

if TYPE_CHECKING:
    from .compare import Comparison

MAX_ROWS = 60  # rows printed in the terminal; all of them are in --json and the report
UNIT_TEXT = {"um": "um", "arcsec": "arcsec"}


def num(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def flag(significant: bool | None) -> str:
    return {True: "yes", False: "no", None: "n/a"}[significant]


def run_line(label: str, r: Any) -> str:
    what = ", ".join(filter(None, [r.machine, f"axis {r.axis}" if r.axis else "", r.created, r.status]))
    return f"{label}: {r.path} ({what})" + (" SIMULATED" if r.simulated else "")


def print_comparison(c: Comparison, stream: TextIO) -> None:
    print(f"compare {c.kind} runs, change = B - A", file=stream)
    print(run_line("A", c.a), file=stream)
    print(run_line("B", c.b), file=stream)
    d = c.detail
    sig, of = c.significant_count()
    if isinstance(d, PositioningComparison):
        u, tu = UNIT_TEXT.get(d.unit, d.unit), d.target_unit
        print(f"per target and direction ({u}; U = {d.k:g} * sqrt(s_a^2/n_a + s_b^2/n_b)): {sig} of {of} changes "
              "larger than U", file=stream)
        print(f"  {'target ' + tu:>12} {'dir':>3} {'A':>9} {'B':>9} {'change':>9} {'U':>8} {'> U':>4}", file=stream)
        for t in d.targets[:MAX_ROWS]:
            a = t.a.mean if t.a else None
            b = t.b.mean if t.b else None
            only = f"  only in {t.only_in.upper()}" if t.only_in else ""
            print(f"  {t.target:>12.4f} {'+' if t.direction > 0 else '-':>3} {num(a):>9} {num(b):>9} "
                  f"{num(t.change):>9} {num(t.expanded):>8} {flag(t.significant):>4}{only}", file=stream)
    else:
        print(f"per station (um; each profile's own least-squares line over the common stations removed; "
              f"U = {d.k:g} * sqrt(u_a^2 + u_b^2)): {sig} of {of} changes larger than U", file=stream)
        print(f"  {'station':>7} {'x mm':>9} {'A':>9} {'B':>9} {'change':>9} {'U':>8} {'> U':>4}", file=stream)
        for s in d.stations[:MAX_ROWS]:
            only = f"  only in {s.only_in.upper()}" if s.only_in else ""
            print(f"  {s.station:>7} {s.x_mm:>9.2f} {num(s.a):>9} {num(s.b):>9} {num(s.change):>9} "
                  f"{num(s.expanded):>8} {flag(s.significant):>4}{only}", file=stream)
    rows = len(d.targets) if isinstance(d, PositioningComparison) else len(d.stations)
    if rows > MAX_ROWS:
        print(f"  ... {rows - MAX_ROWS} more rows (--json, --report)", file=stream)
    print("values:", file=stream)
    for name, v in d.values().items():
        pct = "n/a" if v["change_pct"] is None else f"{v['change_pct']:+.1f} %"
        extra = ""
        if "U" in v:
            extra = f"  U of change {num(v['U'])}, larger than U: {flag(v['significant'])}"
        print(f"  {name:<14} A {num(v['a']):>9}  B {num(v['b']):>9}  change {num(v['change']):>9} ({pct}){extra}",
              file=stream)
    for note in (*c.notes, *d.notes):
        print(f"note: {note}", file=stream)
