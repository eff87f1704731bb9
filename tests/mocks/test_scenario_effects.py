"""The simulated machine axis applies every positioning effect of a scenario with the equation,
sign and units docs/diagnosis.md gives it (e = reading − target, µm; P in mm; t = minutes since
the first measured point; s = ±1 by approach direction; ε the recorded angle in µrad; n − n₀ the
air index change since the first point).

The expected values come from the documented equations (tests/effect_equations.py); the axis' angular motion
and the air index change are computed from their own definitions (a tilt per metre plus a wave;
(n − 1) proportional to the air density at constant temperature and humidity, standards.md 3.4),
not taken from mocks/ or processing/.
"""

from __future__ import annotations

import math

import pytest

from mocks.effects import AngularMotion, AxisEffects, Conditions
from mocks.machine_axis import AxisErrors, MachineAxis, MachineStop
from mocks.offline import axis_captures
from tests.effect_equations import positioning_effect_um

TARGETS_MM = (0.0, 240.5, 498.2, 751.9, 1000.0)
N_REF = 1.000271373  # NIST: 20 C, 101325 Pa, 50 %RH, 450 ppm CO2, 633 nm (standards.md 3.4)
PITCH = {"pitch_urad_per_m": 5.0, "pitch_amplitude_urad": 8.0, "pitch_wavelength_mm": 350.0, "pitch_phase_rad": 0.3}
YAW = {"yaw_urad_per_m": -3.0, "yaw_amplitude_urad": 4.0, "yaw_wavelength_mm": 520.0, "yaw_phase_rad": -1.0}
AIR = {"air_temp_c": 20.0, "air_pressure_hpa": 1013.25, "humidity_pct": 50.0, "material_temp_c": 20.0,
       "drift_c_per_h": 0.0, "pressure_cycle_hpa": 6.0, "cycle_period_min": 1.5}


def stops(runs: int = 2) -> list[MachineStop]:
    """A linear cycle: 5 mm overrun before each approach series (target index 0: not measured)."""
    out = []
    for run in range(1, runs + 1):
        out.append(MachineStop(TARGETS_MM[0] - 5.0, 0, run, 1))
        out += [MachineStop(p, i + 1, run, 1) for i, p in enumerate(TARGETS_MM)]
        out.append(MachineStop(TARGETS_MM[-1] + 5.0, 0, run, -1))
        out += [MachineStop(p, i + 1, run, -1) for i, p in reversed(list(enumerate(TARGETS_MM)))]
    return out


def pitch_urad(p: float) -> float:
    return 5.0 * p / 1000 + 8.0 * math.sin(2 * math.pi * p / 350.0 + 0.3)


def yaw_urad(p: float) -> float:
    return -3.0 * p / 1000 + 4.0 * math.sin(2 * math.pi * p / 520.0 - 1.0)


CASES = {
    "error_table": {"positions_mm": [0.0, 400.0, 1000.0], "error_um": [0.5, -1.5, 2.0]},
    "linear_scale": {"ppm": 4.0},
    "quadratic": {"um_per_m2": -6.0},
    "backlash": {"reversal_um": -2.5},
    "periodic": {"amplitude_um": 0.8, "wavelength_mm": 230.0, "phase_rad": 1.0},
    "thermal_drift": {"um_per_min": 0.6},
    "thermal_growth": {"ppm_per_min": 5.0},
    "abbe": {"offset_mm": 150.0, "channel": "pitch"},
    "abbe_yaw": {"offset_mm": -80.0, "channel": "yaw"},
    "dead_path": {"length_mm": 1000.0},
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_axis_applies_each_effect_as_documented(case: str) -> None:
    kind = case.removesuffix("_yaw")
    q = CASES[case]
    axis = MachineAxis(stops(), errors=AxisErrors(pitch=(), slope_per_m=0.0, backlash=0.0, periodic=0.0,
                                                  thermal_per_m_per_h=0.0, noise=0.0),
                       feed_per_min=2000.0, dwell_s=2.0, environment=Conditions(**AIR),
                       effects=AxisEffects(((kind, q),), AngularMotion(**PITCH, **YAW)))
    recs = axis_captures(axis)
    assert len(recs) == 2 * 2 * len(TARGETS_MM)
    t0 = recs[0]["time_s"]
    assert t0 > 0  # the program started earlier (the move from the datum, the first dwell)
    p0 = recs[0]["environment"][1]
    worst = 0.0
    for r in recs:
        stop, c = r["stop"], r["capture"]
        assert c.pitch_urad == pytest.approx(pitch_urad(stop.position), abs=1e-9)
        assert c.yaw_urad == pytest.approx(yaw_urad(stop.position), abs=1e-9)
        # (n - 1) proportional to the pressure at 20 C and 50 %RH
        dn = (N_REF - 1) * (r["environment"][1] - p0) / p0
        want = float(positioning_effect_um(kind, q, stop.position, stop.direction, (r["time_s"] - t0) / 60.0,
                                           pitch_urad(stop.position), yaw_urad(stop.position), dn))
        got = (c.position_mm - stop.position) * 1000.0
        # the ideal-gas index change is good to a few 0.1 % of itself; everything else is exact
        assert got == pytest.approx(want, abs=1e-6 + (0.01 * abs(want) if kind == "dead_path" else 0.0)), (
            stop, got, want)
        worst = max(worst, abs(want))
    assert worst > 0.5  # the effect is large enough for the comparison to mean something
