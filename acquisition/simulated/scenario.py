"""Scenario files (TOML): what ``guideway simulate`` and ``acquire --simulate --scenario`` put behind
the simulated devices (docs/diagnosis.md).

A scenario file holds the ``[[effect]]`` tables of a model file (saved_runs/diagnosis/model_file.py)
and adds the test cycle, timing and noise: for positioning the ``[axis]``, ``[trigger]`` and
``[environment]`` tables of a positioning set-up (docs/setup-positioning.toml) plus
``[conditions]``, ``[motion]`` and ``[noise]``; for straightness the ``[block]`` and optional
``[geometry]`` tables of a straightness set-up plus ``[timing]``, ``[surface]`` and ``[noise]``.  The
cycle tables (``[axis]``, ``[block]``) are needed by ``guideway simulate`` only: ``acquire
--simulate`` runs the set-up's cycle.  Every problem is a one-line :class:`SetupError` naming the
file and the key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from processing.effects import Effect
from saved_runs.diagnosis.model_file import effects_from_tables, file_kind
from saved_runs.errors import SetupError
from saved_runs.toml_file import TomlTable, read_toml

from ..setup.conditions import check_conditions
from ..setup.positioning import PositioningSetup, positioning_setup_from_dict
from ..setup.straightness import StraightnessSetup, straightness_setup_from_dict
from .sensors import default_block

# Defaults of the scenario tables (units in the names).
POSITIONING_NOISE = {"reading_um": 0.15, "angle_urad": 0.1}
STRAIGHTNESS_NOISE = {"sensor_um": 0.05, "straightness_um": 0.05, "position_um": 0.05, "angle_urad": 0.1,
                      "placement_um": 20.0}
CONDITIONS = {"air_temp_c": 20.4, "air_pressure_hpa": 1012.8, "humidity_pct": 45.0, "material_temp_c": 20.2,
              "drift_c_per_h": 0.05, "air_cycle_c": 0.0, "cycle_period_min": 20.0,
              "pressure_drift_hpa_per_h": 0.0, "pressure_cycle_hpa": 0.0}
MOTION = {f"{a}_{k}": d for a in ("pitch", "yaw") for k, d in
          (("urad_per_m", 0.0), ("amplitude_urad", 0.0), ("wavelength_mm", 1000.0), ("phase_rad", 0.0))}
TIMING = {"seconds_per_station": 30.0}


@dataclass(frozen=True)
class Scenario:
    """A scenario file: what ``guideway simulate`` and ``acquire --simulate --scenario`` put behind
    the simulated devices."""

    kind: str
    effects: tuple[Effect, ...]
    source: str
    seed: int = 0
    positioning: PositioningSetup | None = None
    straightness: StraightnessSetup | None = None
    setup_source: dict[str, Any] = field(default_factory=dict)
    noise: dict[str, float] = field(default_factory=dict)
    conditions: dict[str, float] = field(default_factory=dict)
    motion: dict[str, float] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)
    surface: dict[str, Any] | None = None

    def effect_specs(self) -> tuple[tuple[str, dict[str, Any]], ...]:
        """The effects as plain (type, parameters) pairs, for the simulated devices."""
        return tuple((e.type, {k: (list(v) if isinstance(v, tuple) else v) for k, v in e.params.items()})
                     for e in self.effects)


def _numbers(table: TomlTable, defaults: Mapping[str, float], *, non_negative: bool = False) -> dict[str, float]:
    """The table's numbers (``defaults`` for those absent); ``non_negative``: each must be >= 0 (a
    standard deviation)."""
    out = {}
    for key, default in defaults.items():
        v = table.get(key, float, default)
        if not math.isfinite(v):
            raise SetupError(f"{table.source}: [{table.name}] {key} must be a finite number, got {v}")
        if non_negative and v < 0:
            raise SetupError(f"{table.source}: [{table.name}] {key} is a standard deviation and must be >= 0, "
                             f"got {v:g}")
        out[key] = v
    table.check_unknown()
    return out


def scenario_from_dict(data: Mapping[str, Any], source: str = "scenario") -> Scenario:
    """A scenario from its TOML structure."""
    kind = file_kind(data, source)
    top = TomlTable(source, "", dict(data))
    top.get("kind", str)
    seed = top.get("seed", int, 0)
    if seed < 0:
        raise SetupError(f"{source}: seed must be a whole number >= 0, got {seed}")
    effects = effects_from_tables(data, kind, source, simulation=True)
    top.used.add("effect")
    if kind == "positioning":
        setup_keys = ("axis", "trigger", "environment", "machine", "operator", "notes", "instrument")
        setup_source = {"kind": "positioning", **{k: data[k] for k in setup_keys if k in data}}
        top.used.update(setup_keys)
        # the cycle is optional: acquire --simulate takes it from the set-up file
        setup = positioning_setup_from_dict(setup_source, source) if "axis" in data else None
        if setup is not None and setup.axis_type != "linear":
            raise SetupError(f"{source}: [axis] type: scenarios simulate linear axes")
        noise = _numbers(top.table("noise"), POSITIONING_NOISE, non_negative=True)
        conditions = _numbers(top.table("conditions"), CONDITIONS)
        motion = _numbers(top.table("motion"), MOTION)
        for key in ("pitch_wavelength_mm", "yaw_wavelength_mm"):
            if not motion[key] > 0:
                raise SetupError(f"{source}: [motion] {key} must be positive, got {motion[key]}")
        if not conditions["cycle_period_min"] > 0:
            raise SetupError(f"{source}: [conditions] cycle_period_min must be positive")
        check_conditions(conditions, f"{source}: [conditions]")
        top.check_unknown()
        return Scenario(kind, effects, source, seed, positioning=setup, setup_source=setup_source, noise=noise,
                        conditions=conditions, motion=motion)
    setup_keys = ("block", "geometry", "machine", "axis", "operator", "notes", "instrument")
    setup_source = {"kind": "straightness", **{k: data[k] for k in setup_keys if k in data}}
    top.used.update(setup_keys)
    if "geometry" not in setup_source:
        setup_source["geometry"] = default_geometry()
    ssetup = straightness_setup_from_dict(setup_source, source) if "block" in data else None
    noise = _numbers(top.table("noise"), STRAIGHTNESS_NOISE, non_negative=True)
    timing = _numbers(top.table("timing"), TIMING)
    if not timing["seconds_per_station"] > 0:
        raise SetupError(f"{source}: [timing] seconds_per_station must be positive")
    surface = _surface(top.table("surface")) if "surface" in data else None
    top.check_unknown()
    return Scenario(kind, effects, source, seed, straightness=ssetup, setup_source=setup_source, noise=noise,
                    timing=timing, surface=surface)


def default_geometry() -> dict[str, Any]:
    """The set-up geometry of the default simulated block (a Keyence head, height sign)."""
    return default_block("keyence-lkg")[1].to_dict()


def _surface(table: TomlTable) -> dict[str, Any]:
    """``[surface]``: ``waves`` = [[amplitude_um, wavelength_mm, phase_rad], ...] and ``slope_urad``."""
    waves = table.get("waves", list, [])
    if not all(isinstance(w, list) and len(w) == 3 and all(isinstance(v, int | float) and not isinstance(v, bool)
                                                         for v in w) and w[1] > 0 for w in waves):
        raise SetupError(f"{table.source}: [surface] waves must be a list of [amplitude_um, wavelength_mm, "
                         "phase_rad] with a positive wavelength")
    slope = table.get("slope_urad", float, 0.0)
    table.check_unknown()
    return {"waves": [tuple(float(v) for v in w) for w in waves], "slope_urad": slope}


def load_scenario(path: Path | str) -> Scenario:
    return scenario_from_dict(read_toml(path), str(path))
