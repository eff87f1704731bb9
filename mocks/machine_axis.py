"""A simulated machine axis that runs an ISO 230-2 test cycle, seen by the
interferometer emulator, and its PLC's in-position handshake registers
(docs/modbus-map.md, registers 200-211).

The axis works through a list of stops (position, target index, run,
direction).  At a measured stop it comes to rest, the PLC sets *in position*
with the target index, run and direction and increments the in-position
counter; what releases it depends on the program the machine runs:

* ``handshake="ack"`` (in-position trigger): the tool writes the counter value
  to the acknowledge register; the axis moves on at once.
* ``handshake="cycle-start"`` (manual trigger, M00 at each target): the
  simulated technician presses Cycle Start (:meth:`MachineAxis.cycle_start`).
* ``handshake="timed"`` (stability trigger, plain dwell): the axis stays
  ``dwell_s`` of wall-clock time at each target, then moves on.

The PLC's status bits (docs/modbus-map.md): *cycle running* (b1) is set when
the program starts and cleared at its end, when *cycle finished* (b2) is set;
b2 stays set until the next program start.  Real PLCs also leave bits from an
earlier cycle: ``bits_left_set`` starts the axis with *in position* (b0, at
the cycle's last stop, counter 57) and *cycle finished* set, both cleared when
the program starts; ``program_start_s`` is how long after Cycle Start the
program starts (b1 set, b0/b2 cleared).  An acknowledge before the program
runs is ignored.

Motion itself takes no simulated time; machine time advances by move time at
the feed rate plus the dwell at each stop, so thermal drift depends on the
cycle, not on how fast the test runs.  Actual position at rest::

    X_20   = P + e(P, direction, t) + noise      (the axis at 20 C)
    e = pitch(P) + periodic(P) + direction-dependent backlash + thermal(P, t)
    P = commanded + c                           (c: the controller's compensation, 0 without one)

With a ``compensator`` (the controller's compensation stage) the controller adds its correction c
to each commanded position, so the axis goes to commanded + c and meets its error there.  The
datum (before the program's first move) is uncompensated: the interferometer is zeroed there.

The interferometer is zeroed at the datum.  Rotary axes: it reports
``angle_deg = X_20 - datum`` (an angular interferometer's two beams share the air).
Linear axes with :class:`LinearOptics` (what a real controller sees, standards.md §3.5):
the scale is at material temperature T_m and the beam runs through air of index n₁::

    X_T     = X_20 (1 + α (T_m − 20 °C))
    reading = (X_T n₁ + D (n₁ − n₀)) / n_assumed            (raw counts, n_assumed = 1.0 in vacuum)
    reading = X_20                                            (readings_compensated)

the exact inverse of :mod:`processing.environment` (n₀: the index at the first measured
point, D: the dead path); the controller reports ``reading - datum``.  Without optics
it reports ``X_20 - datum`` (the true position).  This module is written from the
documentation and never imports ``drivers``.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pymodbus.simulator import DataType, SimData

from processing.air_index import DEFAULT_CO2_PPM, DEFAULT_EQUATION, HENE_WAVELENGTH_NM, air_index

from .effects import AxisEffects
from .world import Capture, Environment

# Registers (docs/modbus-map.md), holding registers, 0-based.
REG_INPOS_STATUS, REG_INPOS_TARGET, REG_INPOS_RUN, REG_INPOS_DIRECTION = 200, 201, 202, 203
REG_INPOS_COUNT, REG_INPOS_ACK = 204, 205
REG_ANGLE = 208  # FLOAT64, 4 registers
EXT_END = 212
IP_IN_POSITION, IP_RUNNING, IP_DONE = 1, 2, 4


@dataclass(frozen=True)
class AxisErrors:
    """Error model of the axis, in um (linear) or arcsec (rotary) and mm (or deg) positions.

    ``pitch`` waves (amplitude, wavelength, phase) plus a linear ``slope_per_m`` (um per metre or
    arcsec per revolution...), ``backlash``: lost motion on reversal (the axis stops short by half
    of it in the approach direction), ``periodic``: screw / worm periodic error of period
    ``periodic_period``, ``thermal_per_m_per_h``: expansion growing with machine time, ``noise``:
    standard deviation of each reading.
    """

    pitch: tuple[tuple[float, float, float], ...] = ((4.0, 700.0, 0.4), (1.5, 230.0, 1.1))
    slope_per_m: float = 6.0
    backlash: float = 3.0
    periodic: float = 0.6
    periodic_period: float = 10.0
    thermal_per_m_per_h: float = 4.0
    noise: float = 0.15
    # a reversal error that varies along the axis (amplitude, wavelength, phase): e↑ − e↓ gains
    # amplitude·sin(2π p / wavelength + phase), so the ↑ and ↓ curves cross (seed 003's rotary axis)
    reversal: tuple[tuple[float, float, float], ...] = ()

    def deviation(self, p: float, direction: int, t_h: float) -> float:
        """Error (um or arcsec) of a stop at ``p`` approached in ``direction`` at machine time ``t_h`` hours."""
        e = self.slope_per_m * p / 1000.0
        for amp, wl, ph in self.pitch:
            e += amp * math.sin(2 * math.pi * p / wl + ph)
        e += self.periodic * math.sin(2 * math.pi * p / self.periodic_period)
        e -= direction * self.backlash / 2.0
        for amp, wl, ph in self.reversal:
            e += direction * amp / 2.0 * math.sin(2 * math.pi * p / wl + ph)
        e += self.thermal_per_m_per_h * p / 1000.0 * t_h
        return e


@dataclass(frozen=True)
class LinearOptics:
    """What the controller of a linear axis folds into its reading (run.json ``setup.environment``).

    ``expansion_ppm_per_k``: of the axis / scale (None: no expansion simulated),
    ``refractive_index_assumed``: the index the controller divides by (1.0 = vacuum counts),
    ``readings_compensated``: the controller reports the axis at 20 C itself.
    """

    expansion_ppm_per_k: float | None = 11.5
    refractive_index_assumed: float = 1.0
    wavelength_nm: float = HENE_WAVELENGTH_NM
    co2_ppm: float = DEFAULT_CO2_PPM
    index_equation: str = DEFAULT_EQUATION
    dead_path_mm: float = 0.0
    readings_compensated: bool = False

    def index(self, air_temp_c: float, air_pressure_hpa: float, humidity_pct: float) -> float:
        """Air index n along the beam (``processing.air_index``, pressure converted to Pa)."""
        return float(air_index(air_temp_c, air_pressure_hpa * 100.0, humidity_pct, co2_ppm=self.co2_ppm,
                               wavelength_nm=self.wavelength_nm, equation=self.index_equation))

    def reading(self, x20_mm: float, material_temp_c: float, n1: float, n0: float) -> float:
        """Controller reading (mm) of an axis at ``x20_mm`` (at 20 C) in air of index ``n1``
        (``n0``: the index when the dead path was last equal, at the first point)."""
        if self.readings_compensated:
            return x20_mm
        alpha = self.expansion_ppm_per_k or 0.0
        x_t = x20_mm * (1 + alpha * 1e-6 * (material_temp_c - 20.0))
        return (x_t * n1 + self.dead_path_mm * (n1 - n0)) / self.refractive_index_assumed


@dataclass(frozen=True)
class MachineStop:
    position: float
    target_index: int
    run: int
    direction: int


@dataclass
class MachineAxis:
    """The axis, its cycle and the PLC handshake; duck-types the ``World`` the emulator reads."""

    stops: Sequence[MachineStop]
    rotary: bool = False
    errors: AxisErrors = field(default_factory=AxisErrors)
    feed_per_min: float = 2000.0
    dwell_s: float = 1.0
    handshake: str = "ack"
    datum: float = 0.0
    seed: int = 0
    environment: Environment = field(default_factory=Environment)
    optics: LinearOptics | None = None
    # a scenario's effects (mocks/effects.py) on top of ``errors``; their time is machine time, or the
    # wall-clock time since the axis was built with ``wall_clock_effects`` (behind the real transports)
    effects: AxisEffects | None = None
    wall_clock_effects: bool = False
    bits_left_set: bool = False
    program_start_s: float = 0.0
    # the controller's compensation stage (processing.compensation.stage.Compensator or alike): told
    # every commanded position, it returns the correction (mm or deg) the controller adds to it
    compensator: Any = None

    def __post_init__(self) -> None:
        if self.handshake not in ("ack", "cycle-start", "timed"):
            raise ValueError(f"unknown handshake {self.handshake!r}")
        self._rng = np.random.default_rng([self.seed, 11])
        self._lock = threading.RLock()
        self.beam_blocked = False
        self.index = -1  # the stop the axis is at; -1 = at the datum, program not started
        self.commanded = self.datum
        self.machine_time_s = 0.0
        self.in_position = self.bits_left_set  # at the last stop of an earlier cycle (index -1 = stops[-1])
        self.count = 57 if self.bits_left_set else 0
        self.running = False
        self.done = self.bits_left_set
        self._start_at: float | None = None  # Cycle Start pressed, the program not started yet
        self._datum_actual = self.datum
        self.last_angle_deg = 0.0
        self._arrived = 0.0
        self._at_overrun = False
        self.captured: list[tuple[int, float]] = []  # (stop index, true actual position) per capture
        self._n0: float | None = None  # air index at the first measured point (dead path)
        self._effects_n0: float | None = None  # the same for a scenario's dead_path effect
        self._effects_t0: float | None = None  # time (s) of the first measured point: the effects' t = 0
        self._t_built = time.monotonic()
        self.correction = 0.0  # the compensation stage's correction at the current stop (mm or deg)

    # -- units: errors are um (linear) or arcsec (rotary) -------------------------------------
    def _unit(self, e: float) -> float:
        return e / 3600.0 if self.rotary else e * 1e-3

    def actual(self) -> float:
        """True position of the axis now (mm or deg) normalised to 20 C, without reading noise."""
        if self.index < 0:
            return self.datum
        s = self.stops[self.index]
        # the controller adds its correction to the command: the axis goes there and meets its error there
        p = s.position + self.correction
        e = self.errors.deviation(p, s.direction, self.machine_time_s / 3600)
        if self.effects is not None:
            e += self._effect_error(s, p)
        return p + self._unit(e)

    def _effect_error(self, s: MachineStop, position: float) -> float:
        """The scenario effects' error (um) at stop ``s`` now, the axis at ``position``.

        Time and air index count from the first measured point (docs/diagnosis.md: t = minutes since
        the first point, n₀ = the index of the first point), wherever the program started."""
        assert self.effects is not None
        t_s = time.monotonic() - self._t_built if self.wall_clock_effects else self.machine_time_s
        if self._effects_t0 is None and s.target_index:
            self._effects_t0 = t_s
        dn = 0.0
        if self.effects.needs_air_index():
            air_t, p, rh, _ = self.environment_now()
            n = (self.optics or LinearOptics()).index(air_t, p, rh)
            if self._effects_n0 is None and s.target_index:
                self._effects_n0 = n
            dn = n - (n if self._effects_n0 is None else self._effects_n0)
        t0 = t_s if self._effects_t0 is None else self._effects_t0
        return self.effects.error_um(position, s.direction, (t_s - t0) / 60.0, dn)

    # -- the program ---------------------------------------------------------------------------
    def _advance(self) -> None:
        """Move through stops until the next measured one (where the PLC signals in position)."""
        while self.index + 1 < len(self.stops):
            self.index += 1
            s = self.stops[self.index]
            dist = abs(s.position - self.commanded)
            self.commanded = s.position
            self.correction = self.compensator.move_to(s.position) if self.compensator is not None else 0.0
            self.machine_time_s += 60.0 * dist / self.feed_per_min + (self.dwell_s if s.target_index else 0.0)
            self._arrived = time.monotonic()
            if s.target_index:
                self.in_position = True
                self.count = (self.count + 1) & 0xFFFF
                return
            if self.handshake == "timed":  # reversing at the overrun takes time too
                self._at_overrun = True
                return
        self.in_position = False
        self.running = False
        self.done = True

    def cycle_start(self, **_: object) -> None:
        """Cycle Start: start the program (after ``program_start_s``), or continue from an M00 stop."""
        with self._lock:
            if self.running:
                self.in_position = False
                self._advance()
            elif self._start_at is None and self.index + 1 < len(self.stops):
                self._start_at = time.monotonic() + self.program_start_s
                self._start_program()

    def _start_program(self) -> None:
        """The program starts once ``program_start_s`` has passed: b1 set, bits of an earlier cycle cleared."""
        if self._start_at is None or time.monotonic() < self._start_at:
            return
        self._start_at = None
        self.running, self.done, self.in_position = True, False, False
        self._advance()

    def tick(self) -> None:
        """Timed dwell: leave the target once ``dwell_s`` has passed (called on every access)."""
        with self._lock:
            self._start_program()
            resting = self.in_position or self._at_overrun
            if self.handshake == "timed" and resting and time.monotonic() - self._arrived >= self.dwell_s:
                self.in_position = self._at_overrun = False
                self._advance()

    def acknowledge(self, value: int) -> None:
        """The tool wrote ``value`` to the acknowledge register (ignored before the program runs)."""
        with self._lock:
            if self.handshake == "ack" and self.running and self.in_position and value == self.count:
                self.in_position = False
                self._advance()

    # -- what the interferometer emulator reads --------------------------------------------------
    def set_datum(self) -> None:
        with self._lock:
            self._datum_actual = self.actual()

    def capture(self) -> Capture:
        with self._lock:
            self.tick()
            actual = self.actual()
            self.captured.append((self.index, actual))
            noise = self._unit(float(self._rng.normal(0.0, self.errors.noise))) if self.errors.noise else 0.0
            rel = self._reading(actual + noise) - self._datum_actual
            self.last_angle_deg = rel if self.rotary else 0.0
            pitch = yaw = 0.0
            if self.effects is not None and self.index >= 0:
                pitch, yaw = self.effects.motion.angles_urad(self.stops[self.index].position)
                if self.effects.angle_noise_urad:
                    pitch += float(self._rng.normal(0.0, self.effects.angle_noise_urad))
                    yaw += float(self._rng.normal(0.0, self.effects.angle_noise_urad))
            return Capture(position_mm=0.0 if self.rotary else rel, stry_um=0.0, strz_um=0.0,
                           pitch_urad=pitch, yaw_urad=yaw, roll_urad=0.0)

    def _reading(self, x20: float) -> float:
        """What the controller reports for the axis at ``x20`` (before subtracting the datum)."""
        if self.optics is None or self.rotary:
            return x20
        air_t, p, rh, mat_t = self.environment_now()
        n1 = self.optics.index(air_t, p, rh)
        if self._n0 is None and self.index >= 0:
            self._n0 = n1
        return self.optics.reading(x20, mat_t, n1, n1 if self._n0 is None else self._n0)

    def environment_now(self) -> tuple[float, float, float, float]:
        with self._lock:
            env = self.environment
            at = getattr(env, "at", None)  # a scenario's conditions (mocks/effects.py)
            if at is not None:
                return at(self.machine_time_s / 3600.0)
            drift = env.drift_c_per_h * self.machine_time_s / 3600.0
            return (env.air_temp_c + drift, env.air_pressure_hpa, env.humidity_pct,
                    env.material_temp_c + 0.5 * drift)


def _float64_registers(value: float, word_order: str) -> list[int]:
    raw = struct.pack(">d", value)
    words = [int.from_bytes(raw[i:i + 2], "big") for i in range(0, 8, 2)]
    return words[::-1] if word_order == "CDAB" else words


class InPositionRegisters:
    """Emulator extension serving registers 200-211 from a :class:`MachineAxis`."""

    def __init__(self, axis: MachineAxis, word_order: str = "ABCD") -> None:
        self.axis = axis
        self.word_order = word_order

    def simdata(self) -> list[SimData]:
        return [
            SimData(REG_INPOS_STATUS, count=REG_INPOS_ACK - REG_INPOS_STATUS, values=0,
                    datatype=DataType.REGISTERS, readonly=True),
            SimData(REG_INPOS_ACK, values=0, datatype=DataType.REGISTERS),
            SimData(REG_INPOS_ACK + 1, count=EXT_END - REG_INPOS_ACK - 1, values=0, datatype=DataType.REGISTERS,
                    readonly=True),
        ]

    def command(self, code: int) -> None:
        """The in-position handshake adds no command codes."""
        return None

    def access(self, start: int, address: int, registers: list[int], set_values: list[int] | None) -> None:
        """Called by the emulator on every access, after its own registers are up to date."""
        a = self.axis
        a.tick()
        if set_values is not None and address == REG_INPOS_ACK:
            a.acknowledge(int(set_values[0]))
        with a._lock:
            status = (IP_IN_POSITION if a.in_position else 0) | (IP_RUNNING if a.running else 0) | (
                IP_DONE if a.done else 0)
            s = a.stops[a.index] if a.in_position else None
            values = [status, s.target_index if s else 0, s.run if s else 0,
                      (s.direction & 0xFFFF) if s else 0, a.count]
            angle = _float64_registers(a.last_angle_deg, self.word_order)
        registers[REG_INPOS_STATUS - start: REG_INPOS_ACK - start] = values
        registers[REG_ANGLE - start: EXT_END - start] = angle
