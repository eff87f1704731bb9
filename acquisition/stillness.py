"""When is a reading "still"?  The one rule behind hands-free capture and the TUI's stability light.

``guideway acquire straightness --auto`` (``plans.straightness.arrival``), the positioning
stability trigger (``plans.positioning``) and the TUI's stability light and auto-capture
(:class:`LiveStability`, fed from the live readings) all decide with :class:`StillnessWindow`:

* a reading off the target (or not valid) empties the window: **moving**;
* a reading that moves the span of the window (peak to peak of every channel) beyond
  ``tolerance`` drops the oldest readings until the span fits again (a move restarts the window);
  a window of one reading is **moving** (nothing to compare it with yet);
* a window of two or more readings shorter than ``duration_s`` is **settling**;
* a window spanning ``duration_s`` or more is **stable**.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

MOVING, SETTLING, STABLE = "moving", "settling", "stable"
LOOK = "look"  # messages.Stillness: the operator has no live view; the plan looks with the interferometer


def straightness_channels(ifm: Any) -> tuple[float, float, float]:
    """What must stay still at a straightness station (µm): the position, straightness Y and Z."""
    return ifm.position_mm * 1000.0, ifm.stry_um, ifm.strz_um


def position_channel(position: float, axis_type: str) -> float:
    """An axis position (mm or deg) in the unit of ``[trigger] stability_window`` (µm or arcsec)."""
    return position * (3600.0 if axis_type == "rotary" else 1000.0)


@dataclass
class StillnessWindow:
    """The readings since the last move: ``(time s, channel values)``; ``tolerance`` in the channels'
    unit (µm, arcsec), peak to peak per channel; ``duration_s`` the time the window must span."""

    tolerance: float
    duration_s: float
    readings: list[tuple[float, tuple[float, ...]]] = field(default_factory=list)

    def clear(self) -> str:
        """Off the target or not valid: the window starts again."""
        self.readings.clear()
        return MOVING

    def add(self, time_s: float, values: tuple[float, ...]) -> str:
        """One reading on the target; the state after it."""
        self.readings.append((time_s, tuple(values)))
        while len(self.readings) > 1 and self.span() > self.tolerance:
            self.readings.pop(0)  # the reading moved: the window starts after the move
        return self.state

    def span(self) -> float:
        """Largest peak-to-peak of one channel over the window (0 for fewer than two readings)."""
        if len(self.readings) < 2:
            return 0.0
        channels = zip(*(v for _, v in self.readings), strict=True)
        return max(max(c) - min(c) for c in channels)

    @property
    def elapsed_s(self) -> float:
        return self.readings[-1][0] - self.readings[0][0] if self.readings else 0.0

    @property
    def state(self) -> str:
        if len(self.readings) < 2:
            return MOVING
        return STABLE if self.elapsed_s >= self.duration_s else SETTLING


@dataclass(frozen=True)
class StabilityRule:
    """The thresholds of one run kind: on target when |reading − target| ≤ ``near`` (the unit of
    ``offset``), still when every channel stays within ``tolerance`` for ``duration_s``."""

    near: float
    tolerance: float
    duration_s: float
    unit: str  # of near and of the offset shown (um, mm or deg)
    channel_unit: str  # of tolerance (um or arcsec)
    kind: str  # straightness (position, straightness Y and Z still) or positioning (the position still)

    @classmethod
    def of(cls, setup: Any) -> StabilityRule:
        """Straightness: ``[auto]`` (still_um for still_s, at the station within ``[validation] max_lin_um``),
        as ``acquire --auto``; positioning: ``[trigger]`` (the position within stability_window for half
        the dwell, within ``near`` of the target), as the stability trigger."""
        if hasattr(setup, "auto"):
            return cls(setup.validation.max_lin_um, setup.auto.still_um, setup.auto.still_s, "um", "um",
                       "straightness")
        tr = setup.trigger
        rotary = setup.axis_type == "rotary"
        return cls(tr.near, tr.stability_window, tr.dwell_s / 2, "deg" if rotary else "mm",
                   "arcsec" if rotary else "um", "positioning")

    def text(self) -> str:
        """The rule in words (the capture screen, docs/tui.md)."""
        where = "station" if self.kind == "straightness" else "target"
        return (f"at the {where} (within {self.near:g} {self.unit}) and still within {self.tolerance:g} "
                f"{self.channel_unit} for {self.duration_s:g} s")


class LiveStability:
    """The stability light of a live stream: each new interferometer capture against the target
    (straightness: the station's x; positioning: the target's position), by :class:`StillnessWindow`
    with the run's :class:`StabilityRule`.  Readings that repeat the last capture are ignored (the
    live monitor triggers the interferometer at most every 0.25 s; the [auto] poll is 0.25 s too)."""

    def __init__(self, rule: StabilityRule) -> None:
        self.rule = rule
        self.window = StillnessWindow(rule.tolerance, rule.duration_s)
        self.target: float | None = None
        self._last: Any = None
        self.state = MOVING

    def retarget(self, target: float | None) -> None:
        """A new target (or None: none now): the window starts again."""
        if target != self.target:
            self.target = target
            self.window.clear()
            self.state = MOVING

    def update(self, ifm: Any, position: float) -> str:
        """A live capture ``ifm`` (InterferometerReading) with ``position``, where the axis is in the frame of
        the target (mm or deg: straightness the interferometer position, positioning the axis reading)."""
        if ifm is None or ifm is self._last:
            return self.state
        self._last = ifm
        if self.rule.kind == "straightness":
            channels: tuple[float, ...] = straightness_channels(ifm)
        else:
            channels = (position_channel(position, "rotary" if self.rule.unit == "deg" else "linear"),)
        if self.target is None or not ifm.ok or not all(math.isfinite(c) for c in (position, *channels)) \
                or abs(self.offset(position)) > self.rule.near:
            self.state = self.window.clear()
        else:
            self.state = self.window.add(ifm.timestamp_s, channels)
        return self.state

    def offset(self, position: float) -> float:
        """position − target in the unit of ``rule.near`` (straightness: µm from mm)."""
        assert self.target is not None
        return (position - self.target) * (1000.0 if self.rule.unit == "um" else 1.0)
