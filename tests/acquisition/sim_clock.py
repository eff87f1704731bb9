"""A simulated clock for the timed dwell of the simulated machine (tests only).

With the stability trigger the simulated axis (mocks/machine_axis.py, handshake "timed") leaves a
target ``dwell_s`` of wall-clock time after it arrived, and the plan must see the position still for
half the dwell (by the interferometer readings' timestamps) before that.  On a loaded machine a poll
can take longer than the whole margin, the axis moves on unseen and the run reports "a stop was
missed": the test then measures the CPU, not the plan.

:func:`simulated_clock` replaces the wall clock of both sides by one clock that advances by
``step_s`` at every interferometer reading (the controller driver's timestamp): the axis's dwell
and the plan's stillness window then count readings, so a loaded machine runs the same run, only
slower.  Everything else (the engine's waits, the controller's trigger timeout, the emulator's
measuring time) keeps the real clock.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import pytest


class SimulatedClock:
    """Time that moves only when a reading is taken: ``step_s`` per reading."""

    def __init__(self, step_s: float, start_s: float | None = None) -> None:
        self.step_s = step_s
        self._now = time.time() if start_s is None else start_s
        self._lock = threading.Lock()
        self.readings = 0
        # called with the reading's number after each reading, in the thread that read: a simulated
        # person acting "0.1 s later" acts at a reading, not after a wall-clock sleep of another thread
        self.on_reading: Callable[[int], None] | None = None

    def now(self) -> float:
        with self._lock:
            return self._now

    def reading(self) -> float:
        """The timestamp of a new reading: the clock moves on by one step first."""
        with self._lock:
            self._now += self.step_s
            self.readings += 1
            now, n = self._now, self.readings
        if self.on_reading is not None:
            self.on_reading(n)
        return now


class _Time:
    """The ``time`` module with some functions replaced (what a module under test sees as ``time``)."""

    def __init__(self, **overrides: Any) -> None:
        self._overrides = overrides

    def __getattr__(self, name: str) -> Any:
        return self._overrides[name] if name in self._overrides else getattr(time, name)


@contextmanager
def simulated_clock(monkeypatch: pytest.MonkeyPatch, step_s: float) -> Iterator[SimulatedClock]:
    """Run the simulated machine's dwell and the interferometer timestamps on a :class:`SimulatedClock`."""
    import drivers.interferometer.controller as controller
    import mocks.machine_axis as machine_axis

    clock = SimulatedClock(step_s)
    with monkeypatch.context() as mp:
        mp.setattr(machine_axis, "time", _Time(monotonic=clock.now))
        mp.setattr(controller, "time", _Time(time=clock.reading))
        yield clock
