"""ISO 230-2 targets and test cycles (standards.md section 1.4).

Linear axes up to 2000 mm: at least five targets per metre and at least five
in total, irregularly spaced, ``P_i = start + (i - 1) * p + r_i`` with a
different offset ``r_i`` at every target (so periodic errors of the screw or
scale are not aliased), n runs in each direction.  Longer axes: targets at an
average interval of about 250 mm and one run in each direction.  Rotary axes
(degrees): the principal positions 0, 90, 180, 270 deg are targets exactly,
with irregularly spaced targets between them, at least ``per_rev`` per
revolution.

Cycles are lists of :class:`Stop`: every position the axis stops at, in order,
including the overrun positions beyond both ends that make each approach a
genuine one from the stated direction (``target_index`` 0 = not measured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from processing.iso230_2 import check_target_count, required_targets
from saved_runs.errors import SetupError

from .computed import Computed

CYCLES = ("linear", "step")
END_JITTER = 0.02  # largest offset of the first / last target, as a fraction of the interval


@dataclass(frozen=True)
class Stop:
    """One stop of the axis: ``position`` (mm or deg); ``target_index`` i = 1..m, 0 for an overrun
    stop; ``run`` j = 1..n; ``direction`` +1 / -1 of the approach that ends here."""

    position: float
    target_index: int
    run: int
    direction: int


def _irregular(anchors_lo: float, anchors_hi: float, count: int, rng: np.random.Generator, jitter: float,
               first_free: bool, last_free: bool) -> list[float]:
    """``count`` points spaced p = (hi - lo) / (count - 1) apart, each moved by its own offset
    r in [-jitter p, +jitter p]; at a free end r is one-sided and at most END_JITTER p, so the
    points stay inside [lo, hi] and the end targets stay close to the ends of the travel."""
    p = (anchors_hi - anchors_lo) / (count - 1)
    out = []
    for i in range(count):
        lo = 0.0 if (i == 0 and first_free) else -jitter
        hi = 0.0 if (i == count - 1 and last_free) else jitter
        if i == 0 and first_free:
            hi = END_JITTER
        if i == count - 1 and last_free:
            lo = -END_JITTER
        out.append(anchors_lo + i * p + float(rng.uniform(lo, hi)) * p)
    return out


def linear_targets(start_mm: float, end_mm: float, *, seed: int = 0, jitter: float = 0.3,
                   decimals: int = 3) -> tuple[float, ...]:
    """Targets of a linear axis over [start_mm, end_mm] (rounded to ``decimals``, all distinct offsets)."""
    span = end_mm - start_mm
    if not (math.isfinite(span) and span > 0):
        raise SetupError(f"the axis travel must have end_mm > start_mm, got {start_mm} .. {end_mm}")
    m = required_targets(span, "linear")
    rng = np.random.default_rng([seed, 230])
    p = span / (m - 1)
    for _ in range(100):
        pts = _irregular(start_mm, end_mm, m, rng, jitter, True, True)
        pts = [round(x, decimals) for x in pts]
        offsets = [round(x - (start_mm + i * p), decimals) for i, x in enumerate(pts)]
        if len(set(offsets)) == m:
            return tuple(pts)
    raise SetupError("could not draw distinct target offsets; increase the number of decimals")  # pragma: no cover


def rotary_targets(start_deg: float = 0.0, end_deg: float = 360.0, *, seed: int = 0, per_rev: int = 8,
                   jitter: float = 0.3, decimals: int = 3) -> tuple[float, ...]:
    """Targets of a rotary axis: principal positions (multiples of 90 deg) exactly, irregular ones between.

    A full revolution (end - start = 360) does not repeat its start position at the end.
    """
    span = end_deg - start_deg
    if not (math.isfinite(span) and 0 < span <= 360.0):
        raise SetupError(f"a rotary axis range must satisfy 0 < end_deg - start_deg <= 360, "
                         f"got {start_deg} .. {end_deg}")
    full = math.isclose(span, 360.0)
    anchors = sorted({start_deg, end_deg} | {90.0 * k for k in range(math.ceil(start_deg / 90 - 1e-9),
                                                                       math.floor(end_deg / 90 + 1e-9) + 1)})
    rng = np.random.default_rng([seed, 2302])
    pts: list[float] = []
    for a, b in zip(anchors, anchors[1:], strict=False):
        inner = max(1, math.ceil(per_rev * (b - a) / 360.0 - 1e-9)) - 1
        if inner:
            pts += _irregular(a, b, inner + 2, rng, jitter, False, False)[1:-1]
    principal = [a for a in anchors if math.isclose(a / 90.0, round(a / 90.0))]
    ends = [start_deg] + ([] if full else [end_deg])
    out = sorted({round(x, decimals) for x in pts + principal + ends})
    if full:
        out = [x for x in out if x < end_deg - 10 ** -decimals]
    return tuple(out)


def check_targets(targets: tuple[float, ...], axis_type: str, span: float | None = None, *,
                  allow_nonconforming: bool = False) -> None:
    """Refuse an explicit target list that breaks the ISO 230-2 target rule (standards.md §1.4) over
    ``span`` (mm; default: the range of the targets); with ``allow_nonconforming`` only one that
    cannot be evaluated at all (fewer than 2 targets)."""
    try:
        note = check_target_count(targets, axis_type, span)
    except ValueError as exc:
        raise SetupError(f"[axis] targets: {exc}") from None
    if note and not allow_nonconforming:
        raise SetupError(f"[axis] targets: {note}; give more targets or set allow_nonconforming_targets = true")


class Cycle(Computed[Stop]):
    """The stops of a test cycle, each computed from its index (never a list: the sizes are checked
    against acquisition/setup/maxima.py, and a plan reads one stop at a time).

    ``linear``: the standard test cycle: all targets upwards, reverse beyond the last, all
    downwards, reverse beyond the first; ``runs`` times.  ``step`` (ISO 230-2 Annex B): at each
    target all up and down approaches before moving on.  ``measured``: only the stops where a
    point is captured (``target_index`` > 0), in the same order.
    """

    what = "stop"

    def __init__(self, kind: str, targets: tuple[float, ...], runs: int, overrun: float, *,
                 measured: bool = False) -> None:
        if kind not in CYCLES:
            raise SetupError(f"unknown cycle {kind!r}; use one of {', '.join(CYCLES)}")
        _check(targets, runs, overrun)
        self.kind, self.targets, self.runs, self.overrun, self.measured = kind, tuple(targets), runs, overrun, measured
        m = len(self.targets)
        # stops per block: a run of the linear cycle, a target of the step cycle
        self._block = (2 * m if measured else 2 * m + 2) if kind == "linear" else (2 if measured else 4) * runs
        self._blocks = runs if kind == "linear" else m

    def __len__(self) -> int:
        return self._block * self._blocks

    def at(self, i: int) -> Stop:
        block, r = divmod(i, self._block)
        t, o = self.targets, self.overrun
        if self.kind == "linear":
            j, m = block + 1, len(t)
            if self.measured:
                return Stop(t[r], r + 1, j, +1) if r < m else Stop(t[2 * m - 1 - r], 2 * m - r, j, -1)
            if r == 0:
                return Stop(t[0] - o, 0, j, +1)
            if r <= m:
                return Stop(t[r - 1], r, j, +1)
            if r == m + 1:
                return Stop(t[-1] + o, 0, j, -1)
            return Stop(t[2 * m + 1 - r], 2 * m + 2 - r, j, -1)
        p, k = t[block], block + 1
        if self.measured:
            j, up = divmod(r, 2)
            return Stop(p, k, j + 1, -1 if up else +1)
        j, q = divmod(r, 4)
        return (Stop(p - o, 0, j + 1, +1), Stop(p, k, j + 1, +1), Stop(p + o, 0, j + 1, -1), Stop(p, k, j + 1, -1))[q]


def linear_cycle(targets: tuple[float, ...], runs: int, overrun: float) -> Cycle:
    """The standard test cycle (:class:`Cycle`)."""
    return Cycle("linear", targets, runs, overrun)


def step_cycle(targets: tuple[float, ...], runs: int, overrun: float) -> Cycle:
    """The step cycle, ISO 230-2 Annex B (:class:`Cycle`)."""
    return Cycle("step", targets, runs, overrun)


def cycle(kind: str, targets: tuple[float, ...], runs: int, overrun: float, *, measured: bool = False) -> Cycle:
    """The stops of the ``kind`` cycle (``measured``: only those where a point is captured)."""
    return Cycle(kind, targets, runs, overrun, measured=measured)


def _check(targets: tuple[float, ...], runs: int, overrun: float) -> None:
    if len(targets) < 2 or any(b <= a for a, b in zip(targets, targets[1:], strict=False)):
        raise SetupError("targets must be at least two strictly increasing positions")
    if runs < 1:
        raise SetupError(f"runs must be at least 1, got {runs}")
    if not (math.isfinite(overrun) and overrun > 0):
        raise SetupError(f"overrun must be a positive distance, got {overrun}")
