"""The plausible bounds of the simulated conditions: a positioning set-up's ``[simulation]`` and a scenario's
``[conditions]`` (docs/setup-positioning.toml, docs/scenario-positioning.toml).

The simulated controller reports these values with every point, and the positioning evaluation refuses a
run whose values lie outside the range of the air-index equations (saved_runs/evaluation/limits.py,
:data:`saved_runs.evaluation.air.RANGES`).  So the same ranges bound them here, when the file is read:
``air_temp_c = 1e6`` is one line naming the key before a run is recorded, not a run that cannot be
evaluated.  The rates and cycle amplitudes are bounded by what a workshop's air does (a few °C or hPa per
hour), generously.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from saved_runs.errors import SetupError
from saved_runs.evaluation.air import RANGES

_AIR = {flag: (lo, hi) for flag, lo, hi in RANGES}
TEMP_C = _AIR["--t-c"]  # -40 to 100 °C
PRESSURE_HPA = (_AIR["--p-pa"][0] / 100.0, _AIR["--p-pa"][1] / 100.0)  # 100 to 1400 hPa
HUMIDITY_PCT = _AIR["--rh"]  # 0 to 100 %RH

# key: (lowest, highest, unit); every key is a number the simulated world reports or drifts by
BOUNDS: dict[str, tuple[float, float, str]] = {
    "air_temp_c": (*TEMP_C, "°C"),
    "air_pressure_hpa": (*PRESSURE_HPA, "hPa"),
    "humidity_pct": (*HUMIDITY_PCT, "%RH"),
    "material_temp_c": (*TEMP_C, "°C"),  # the evaluation holds the material to the same range (limits.py)
    "drift_c_per_h": (-10.0, 10.0, "°C/h"),
    "air_cycle_c": (-10.0, 10.0, "°C"),
    "pressure_drift_hpa_per_h": (-10.0, 10.0, "hPa/h"),
    "pressure_cycle_hpa": (-10.0, 10.0, "hPa"),
}


def check_conditions(values: Mapping[str, float], where: str) -> None:
    """A one-line :class:`SetupError` for the first value of ``values`` (those of :data:`BOUNDS`) outside its
    bounds; ``where`` names the file and table (``setup.toml: [simulation]``)."""
    for key, (lo, hi, unit) in BOUNDS.items():
        if key not in values:
            continue
        v = values[key]
        if not (math.isfinite(v) and lo <= v <= hi):
            raise SetupError(f"{where} {key} = {v:g} is outside the plausible range {lo:g} to {hi:g} {unit}; "
                             "give a value within it")
    # a cycle swings the value both ways: its peaks must stay within the range too
    for key, cycle in (("air_temp_c", "air_cycle_c"), ("air_pressure_hpa", "pressure_cycle_hpa")):
        if key in values and cycle in values:
            lo, hi, unit = BOUNDS[key]
            v, a = values[key], abs(values[cycle])
            if not lo <= v - a <= v + a <= hi:
                raise SetupError(f"{where} {key} = {v:g} with {cycle} = {values[cycle]:g} swings outside the "
                                 f"plausible range {lo:g} to {hi:g} {unit}; give a smaller cycle or another {key}")
