"""Live compensation (seed 003; docs/compensation.md, "Live compensation"): every cycle read the axis
position and direction from the controller, predict the error with a model fitted to an as-found
run, write the opposite value as the controller's external offset and bump the heartbeat.

Units: positions mm (rotary: deg); errors and offsets um (rotary: arcsec).

Safety: the offset's change per cycle is limited (``max_jump``; larger steps are clamped and
logged), the controller drops the offset when the heartbeat stops (its rule, not ours), the off
switch (register 8 = 0, written by anyone) and Ctrl+C / :meth:`LiveCompensator.stop` end the loop
after writing offset 0 and enable 0.  A lost connection ends it with :class:`LiveLinkLost`.
"""

from __future__ import annotations

import hashlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from drivers.errors import DriverError, TransportError
from drivers.live_compensation.client import LiveCompensationClient
from processing.compensation.models import DEFAULT_POLYNOMIAL_DEGREE, fit_model
from saved_runs.errors import UserError

LIVE_MODELS = ("spline", "linear", "polynomial", "bidirectional-table")
MAX_JUMP_LINES = 10  # jump events printed one per line; the rest only counted


class LiveLinkLost(Exception):
    """The controller stopped answering or closed the connection: the compensator cannot write 0, the
    controller's stale-heartbeat rule drops the offset."""


@dataclass(frozen=True)
class LivePredictor:
    """The error e(position, direction) of an axis (um or arcsec), a model per direction."""

    model: str
    rotary: bool
    first: float
    last: float
    _up: Callable[[float], float]
    _down: Callable[[float], float]
    run: str = ""
    points_sha256: str = ""
    detail: str = ""

    @property
    def unit(self) -> str:
        return "arcsec" if self.rotary else "um"

    @property
    def position_unit(self) -> str:
        return "deg" if self.rotary else "mm"

    def error(self, position: float, direction: int) -> float:
        """Predicted error at ``position`` approached in ``direction`` (+1 / -1); 0 before any motion
        (direction 0).  Outside [first, last] the end value is held."""
        if direction == 0:
            return 0.0
        return float((self._up if direction > 0 else self._down)(position))


def predictor_from_means(model: str, target: np.ndarray, mean_up: np.ndarray, mean_down: np.ndarray, *,
                         rotary: bool, degree: int = DEFAULT_POLYNOMIAL_DEGREE, tolerance: float | None = None
                         ) -> LivePredictor:
    """Fit ``model`` to the per-target means of each direction (``processing.compensation.models``).

    ``bidirectional-table``: the means of each direction linearly interpolated onto an equidistant grid
    of as many points as targets (first to last target), applied linearly between grid points: what a
    controller's bidirectional pitch table holds."""
    if model not in LIVE_MODELS:
        raise UserError(f"unknown live model {model!r}; choose one of {', '.join(LIVE_MODELS)}")
    x = np.asarray(target, float)
    curves = []
    for e in (np.asarray(mean_up, float), np.asarray(mean_down, float)):
        if model == "bidirectional-table":
            grid = np.linspace(x[0], x[-1], len(x))
            values = np.interp(grid, x, e)
            curves.append(lambda p, g=grid, v=values: float(np.interp(p, g, v)))
        else:
            try:
                fitted = fit_model(model, x, e, degree=degree, tolerance=tolerance)
            except ValueError as exc:  # too few or unmeasured targets
                raise UserError(f"live compensation: cannot fit the {model} model: {exc}") from None
            curves.append(lambda p, f=fitted: float(f(p)))
    return LivePredictor(model, rotary, float(x[0]), float(x[-1]), curves[0], curves[1])


def predictor_from_run(run_dir: Path | str, model: str, *, degree: int = DEFAULT_POLYNOMIAL_DEGREE) -> LivePredictor:
    """The model of an as-found positioning run (its per-target means, ``saved_runs`` evaluation).
    A run measured with compensation active is refused: the model must be the axis's own error."""
    from saved_runs.evaluation.evaluate import evaluate_run
    from saved_runs.export.axis import axis_data
    from saved_runs.store.compensation import run_compensation
    from saved_runs.store.reader import load_run

    run = load_run(run_dir)
    if run.kind != "positioning":
        raise UserError(f"{run.path} is a {run.kind} run; live compensation models an as-found positioning run")
    if run_compensation(run.meta).get("active"):
        raise UserError(f"{run.path} was measured with compensation active; live compensation needs the axis's own "
                        "error: give an as-found run measured without compensation")
    d = axis_data(evaluate_run(run).result)
    missing = ~(np.isfinite(d.mean_up) & np.isfinite(d.mean_down))
    if missing.any():  # a direction not measured at a target: take the other direction's mean there
        up = np.where(np.isfinite(d.mean_up), d.mean_up, d.mean_down)
        down = np.where(np.isfinite(d.mean_down), d.mean_down, d.mean_up)
    else:
        up, down = d.mean_up, d.mean_down
    p = predictor_from_means(model, d.target, up, down, rotary=d.axis_type == "rotary", degree=degree)
    points = Path(run.path) / "points.csv"
    sha = hashlib.sha256(points.read_bytes()).hexdigest() if points.exists() else ""
    return LivePredictor(p.model, p.rotary, p.first, p.last, p._up, p._down, str(run.path), sha)


@dataclass
class LiveStats:
    """What a live-compensation session did."""

    cycles: int = 0
    overruns: int = 0  # cycles that took longer than the cycle time
    jumps_clamped: int = 0
    cycle_s: list[float] = field(default_factory=list)  # duration of each cycle's read + predict + write
    reason: str = ""
    last_offset: float = 0.0


class LiveCompensator:
    """The compensation loop against one controller (:class:`LiveCompensationClient`)."""

    def __init__(self, predictor: LivePredictor, url: str, *, cycle_ms: float = 8.0, max_jump: float = 5.0,
                 word_order: str = "ABCD", timeout_s: float = 0.5, stream: TextIO | None = None,
                 keep_cycle_times: bool = False) -> None:
        if not (cycle_ms > 0 and np.isfinite(cycle_ms)):
            raise UserError(f"--cycle-ms must be a number > 0, got {cycle_ms}")
        if not (max_jump > 0 and np.isfinite(max_jump)):
            raise UserError(f"--max-jump-um must be a number > 0, got {max_jump}")
        try:
            self.client = LiveCompensationClient(url, rotary=predictor.rotary, word_order=word_order,
                                                 timeout_s=timeout_s)
        except ValueError as exc:
            raise UserError(f"--controller: {exc}") from None
        self.predictor = predictor
        self.cycle_s = cycle_ms / 1000.0
        self.max_jump = max_jump
        self.stream = stream
        self.keep_cycle_times = keep_cycle_times
        self.stats = LiveStats()
        self._stop = threading.Event()
        self.heartbeat = 0
        self.offset = 0.0

    def stop(self) -> None:
        """Ask the loop to end after the current cycle (it writes offset 0 and enable 0)."""
        self._stop.set()

    def _say(self, text: str) -> None:
        if self.stream is not None:
            print(text, file=self.stream, flush=True)

    def _limit(self, target: float, position: float, direction: int) -> float:
        """The offset for this cycle: ``target`` unless it is more than ``max_jump`` from the last one."""
        step = target - self.offset
        if abs(step) <= self.max_jump:
            return target
        clamped = self.offset + (self.max_jump if step > 0 else -self.max_jump)
        self.stats.jumps_clamped += 1
        if self.stats.jumps_clamped <= MAX_JUMP_LINES:
            p = self.predictor
            self._say(f"jump: offset {self.offset:+.3f} -> {target:+.3f} {p.unit} at {position:.4f} "
                      f"{p.position_unit} ({'+' if direction > 0 else '-'}): clamped to {clamped:+.3f}")
        return clamped

    def cycle(self) -> bool:
        """One cycle: read, predict, write.  False when the off switch is set."""
        state = self.client.read_state()
        if state.enable != 1:
            return False
        target = 0.0 - self.predictor.error(state.position, state.direction)  # never -0.0
        self.offset = self._limit(target, state.position, state.direction)
        self.heartbeat = (self.heartbeat + 1) & 0xFFFF
        self.client.write_cycle(self.heartbeat, state.sample, self.offset)
        self.stats.last_offset = self.offset
        return True

    def _release(self) -> None:
        """Offset 0 and enable 0, best effort (on the way out)."""
        try:
            self.heartbeat = (self.heartbeat + 1) & 0xFFFF
            self.client.write_cycle(self.heartbeat, 0, 0.0)
            self.client.set_enable(False)
        except DriverError:
            pass
        self.offset = 0.0

    def run(self, max_cycles: int | None = None, ready: threading.Event | None = None) -> LiveStats:
        """Run until the off switch, :meth:`stop`, Ctrl+C or ``max_cycles``; :class:`LiveLinkLost` when the
        controller stops answering; :class:`UserError` when it is not the live-compensation interface."""
        try:
            self.client.connect()
            state = self.client.read_state()
            self.heartbeat = state.heartbeat
            self.client.set_enable(True)
        except TransportError as exc:
            self.client.close()
            raise LiveLinkLost(f"cannot reach the live-compensation controller: {exc}") from None
        except DriverError as exc:
            self.client.close()
            raise UserError(str(exc)) from None
        timeout_ms = state.timeout_ms
        if timeout_ms and self.cycle_s * 1000.0 >= timeout_ms:
            self._release()
            self.client.close()
            raise UserError(f"--cycle-ms {self.cycle_s * 1000:g} is not shorter than the controller's heartbeat "
                            f"timeout ({timeout_ms} ms): the controller would drop every offset")
        if ready is not None:
            ready.set()
        stats = self.stats
        next_at = time.perf_counter()
        try:
            while not self._stop.is_set() and (max_cycles is None or stats.cycles < max_cycles):
                t0 = time.perf_counter()
                if not self.cycle():
                    stats.reason = "switched off at the controller (register 8 = 0)"
                    break
                took = time.perf_counter() - t0
                stats.cycles += 1
                if self.keep_cycle_times:
                    stats.cycle_s.append(took)
                next_at += self.cycle_s
                wait = next_at - time.perf_counter()
                if wait > 0:
                    self._stop.wait(wait)
                else:
                    stats.overruns += 1
                    next_at = time.perf_counter()  # no catching up with a burst of cycles
            else:
                stats.reason = "stopped" if self._stop.is_set() else f"{stats.cycles} cycles done"
        except KeyboardInterrupt:
            stats.reason = "interrupted (Ctrl+C)"
            self._release()
            self.client.close()
            raise
        except TransportError as exc:
            self.client.close()
            raise LiveLinkLost(f"connection to the live-compensation controller {self.client.url} lost ({exc}); "
                               f"the controller drops the offset to 0 after its heartbeat timeout "
                               f"({timeout_ms} ms)") from None
        except DriverError as exc:
            self._release()
            self.client.close()
            raise UserError(str(exc)) from None
        self._release()
        self.client.close()
        return stats


def start_in_thread(compensator: LiveCompensator, timeout_s: float = 5.0) -> tuple[threading.Thread, dict[str, Any]]:
    """Run ``compensator`` in a daemon thread (simulation: the compensator in the same process as the
    run); returns the thread and a dict that receives ``stats`` or ``error`` when it ends, and ``ended_at``
    (time.time(), s) then.  Waits until the compensator has enabled the controller."""
    ready = threading.Event()
    out: dict[str, Any] = {}

    def work() -> None:
        try:
            out["stats"] = compensator.run(ready=ready)
        except Exception as exc:  # reported by the caller  # noqa: BLE001
            out["ended_at"] = time.time()  # before ``error``: whoever sees ``error`` sees when
            out["error"] = exc
            ready.set()
        else:
            out["ended_at"] = time.time()

    thread = threading.Thread(target=work, name="live-compensator", daemon=True)
    thread.start()
    if not ready.wait(timeout_s) or "error" in out:
        compensator.stop()
        raise UserError(f"the live compensator did not start: {out.get('error', 'no answer')}")
    return thread, out
