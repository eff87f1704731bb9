"""Physical effects of a simulation scenario, as the simulated devices apply them.

Written from the equations of docs/diagnosis.md (the effect vocabulary), independently of the
diagnosis code in ``processing/``: a test that the diagnosis finds what the simulation hid
compares two separate implementations of the documented physics.  Effects arrive as plain
``(type, parameters)`` pairs, units in the parameter names.

Positioning (the true axis position moves by e, µm; P = target position, mm; t = minutes since
the first measured point; s = +1 / −1 approach direction; ε the axis' angular motion at P, µrad;
Δn the air index change since the first measured point)::

    error_table     interp(P)            linear_scale    ppm · P / 1000
    quadratic       um_per_m2 · (P / 1000)²               backlash        s · reversal_um / 2
    periodic        amplitude_um · sin(2π P / wavelength_mm + phase_rad)
    thermal_drift   um_per_min · t       thermal_growth  ppm_per_min · P · t / 1000
    abbe            offset_mm · ε / 1000 dead_path       length_mm · Δn · 1000

Straightness: the sensor reports (1 + ppm·1e-6) times the true height-sense value plus
um_per_min · t (sensor_gain, sensor_drift); the true block is longer than recorded by
um_per_block (block_length) and its sensor sits error_mm closer to P along X than recorded,
whether it is ahead of P or behind it (lever_arm); a profile_table adds its heights to the surface (x from
the first sample point).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from .world import BlockSetup, Environment, Guideway

EffectSpec = tuple[str, Mapping[str, Any]]


def interpolate(x: float, xs: Sequence[float], ys: Sequence[float]) -> float:
    """Piecewise-linear interpolation, constant beyond the first and last position."""
    if x <= xs[0]:
        return float(ys[0])
    if x >= xs[-1]:
        return float(ys[-1])
    i = bisect.bisect_right(xs, x) - 1
    w = (x - xs[i]) / (xs[i + 1] - xs[i])
    return float(ys[i] + w * (ys[i + 1] - ys[i]))


@dataclass(frozen=True)
class AngularMotion:
    """Pitch and yaw of the moving axis against its position (µrad): a linear part plus one wave each."""

    pitch_urad_per_m: float = 0.0
    pitch_amplitude_urad: float = 0.0
    pitch_wavelength_mm: float = 1000.0
    pitch_phase_rad: float = 0.0
    yaw_urad_per_m: float = 0.0
    yaw_amplitude_urad: float = 0.0
    yaw_wavelength_mm: float = 1000.0
    yaw_phase_rad: float = 0.0

    def angles_urad(self, position_mm: float) -> tuple[float, float]:
        p = position_mm
        pitch = self.pitch_urad_per_m * p / 1000 + self.pitch_amplitude_urad * math.sin(
            2 * math.pi * p / self.pitch_wavelength_mm + self.pitch_phase_rad)
        yaw = self.yaw_urad_per_m * p / 1000 + self.yaw_amplitude_urad * math.sin(
            2 * math.pi * p / self.yaw_wavelength_mm + self.yaw_phase_rad)
        return pitch, yaw


@dataclass(frozen=True)
class AxisEffects:
    """The positioning effects of a scenario and the axis' angular motion."""

    effects: tuple[EffectSpec, ...] = ()
    motion: AngularMotion = AngularMotion()
    angle_noise_urad: float = 0.0

    def needs_air_index(self) -> bool:
        return any(t == "dead_path" for t, _ in self.effects)

    def error_um(self, position_mm: float, direction: int, minutes: float, index_change: float) -> float:
        """How far the axis stands from its target because of the effects (µm, + = further along)."""
        p = position_mm
        pitch, yaw = self.motion.angles_urad(p)
        e = 0.0
        for kind, q in self.effects:
            if kind == "error_table":
                e += interpolate(p, q["positions_mm"], q["error_um"])
            elif kind == "linear_scale":
                e += q["ppm"] * p / 1000
            elif kind == "quadratic":
                e += q["um_per_m2"] * (p / 1000) ** 2
            elif kind == "backlash":
                e += direction * q["reversal_um"] / 2
            elif kind == "periodic":
                e += q["amplitude_um"] * math.sin(2 * math.pi * p / q["wavelength_mm"] + q["phase_rad"])
            elif kind == "thermal_drift":
                e += q["um_per_min"] * minutes
            elif kind == "thermal_growth":
                e += q["ppm_per_min"] * p * minutes / 1000
            elif kind == "abbe":
                e += q["offset_mm"] * (pitch if q["channel"] == "pitch" else yaw) / 1000
            elif kind == "dead_path":
                e += q["length_mm"] * index_change * 1000
            else:
                raise ValueError(f"effect {kind!r} does not act on a positioning axis")
        return e


@dataclass(frozen=True)
class SensorEffects:
    """What the displacement sensor adds to the true surface height it sees (height sense)."""

    gain_ppm: float = 0.0
    drift_um_per_min: float = 0.0

    def reading_mm(self, height_mm: float, minutes: float) -> float:
        return height_mm * (1 + self.gain_ppm * 1e-6) + self.drift_um_per_min * minutes * 1e-3


@dataclass(frozen=True)
class ProfiledGuideway(Guideway):
    """A guideway whose base surface carries reference-profile tables on top of its waves:
    ``profile`` = ((positions_mm, height_um), ...) in profile coordinates (x − ``origin_mm``)."""

    profile: tuple[tuple[tuple[float, ...], tuple[float, ...]], ...] = ()
    origin_mm: float = 0.0

    def height_mm(self, x_mm: float, z_mm: float) -> float:
        return super().height_mm(x_mm, z_mm) + sum(
            interpolate(x_mm - self.origin_mm, xs, hs) for xs, hs in self.profile) * 1e-3

    def height_slope(self, x_mm: float, z_mm: float) -> tuple[float, float]:
        dx, dz = super().height_slope(x_mm, z_mm)
        for xs, hs in self.profile:
            u = x_mm - self.origin_mm
            if xs[0] < u < xs[-1]:
                i = bisect.bisect_right(xs, u) - 1
                dx += (hs[i + 1] - hs[i]) / (xs[i + 1] - xs[i]) * 1e-3
        return dx, dz


def straightness_parts(effects: Sequence[EffectSpec], recorded: BlockSetup, base: Guideway
                       ) -> tuple[BlockSetup, Guideway, SensorEffects]:
    """The true block, the true surface and the sensor's own effects of a straightness scenario.

    ``recorded``: the block as the set-up describes it; ``base``: the surface before any profile table.
    """
    block, tables = recorded, []
    gain = drift = 0.0
    for kind, q in effects:
        if kind == "block_length":
            block = replace(block, length_mm=block.length_mm + q["um_per_block"] * 1e-3)
        elif kind == "lever_arm":
            # the recorded P–Q distance along X is longer than the true one by error_mm: the true Q sits
            # error_mm nearer P, on whichever side of P the sensor is
            head = block.sensor_head_mm
            q_x = head[0] + block.standoff_mm * block.beam[0]
            toward_p = -1.0 if q_x >= block.mirror_mm[0] else 1.0
            block = replace(block, sensor_head_mm=(head[0] + toward_p * q["error_mm"], head[1], head[2]))
        elif kind == "profile_table":
            tables.append((tuple(q["positions_mm"]), tuple(q["height_um"])))
        elif kind == "sensor_gain":
            gain += q["ppm"]
        elif kind == "sensor_drift":
            drift += q["um_per_min"]
        else:
            raise ValueError(f"effect {kind!r} does not act on a straightness run")
    surface = base
    if tables:
        # profile x counts from the first sample point: the (true) sensor point Q of the block at station 0
        origin = block.sensor_head_mm[0] + block.standoff_mm * block.beam[0]
        surface = ProfiledGuideway(waves=base.waves, slope_urad=base.slope_urad, twist0_urad=base.twist0_urad,
                                   twist_urad_per_m=base.twist_urad_per_m, side_waves=base.side_waves,
                                   profile=tuple(tables), origin_mm=origin)
    return block, surface, SensorEffects(gain, drift)


@dataclass(frozen=True)
class Conditions(Environment):
    """Air and material during a scenario: the linear drift of :class:`Environment` plus an air
    conditioning cycle (``air_cycle_c`` amplitude, ``cycle_period_min``) and a pressure drift and
    cycle (hPa; weather, doors); the material follows the air temperature at half the swing."""

    air_cycle_c: float = 0.0
    cycle_period_min: float = 20.0
    pressure_drift_hpa_per_h: float = 0.0
    pressure_cycle_hpa: float = 0.0

    def at(self, hours: float) -> tuple[float, float, float, float]:
        """(air temp C, pressure hPa, humidity %RH, material temp C) ``hours`` after the start."""
        wave = math.sin(2 * math.pi * hours * 60.0 / self.cycle_period_min)
        air = self.drift_c_per_h * hours + self.air_cycle_c * wave
        pressure = self.air_pressure_hpa + self.pressure_drift_hpa_per_h * hours + self.pressure_cycle_hpa * wave
        return (self.air_temp_c + air, pressure, self.humidity_pct, self.material_temp_c + 0.5 * air)
