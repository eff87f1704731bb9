"""Validated set-up of a gauge-block straightness run, from a TOML file.

``docs/setup-straightness.toml`` is the commented example of every key.  Every
problem is a one-line :class:`~saved_runs.errors.SetupError` naming the file,
the table and the key.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from processing.geometry import BlockGeometry, DatumAngles
from saved_runs.errors import SetupError
from saved_runs.evaluation.limits import ValidationSetup
from saved_runs.evaluation.tolerance import straightness_tolerance
from saved_runs.store.instruments import instrument_tables
from saved_runs.toml_file import TomlTable, naming_source, read_toml

from .computed import Computed
from .maxima import check_size
from .shared_tables import DeviceSetup, catalog_table, check_devices, controller_timing_keys, scenario_path

UNCERTAINTY_KEYS = ("sensor_noise_um", "sensor_resolution_um", "straightness_um", "angle_urad",
                    "position_um", "offset_mm", "step_mm")


@dataclass(frozen=True)
class WarmupSetup:
    """Warm-up: readings every ``interval_s`` until the peak-to-peak drift over the last
    ``window`` readings stays below both limits, or ``timeout_s`` passes (then the
    operator waits on, overrides or aborts)."""

    enabled: bool = True
    window: int = 5
    interval_s: float = 2.0
    max_drift_ifm_um: float = 0.5
    max_drift_sensor_um: float = 0.5
    timeout_s: float = 1800.0

    def __post_init__(self) -> None:
        check_size("window", self.window, "[warmup]")
        if self.window < 2:
            raise SetupError(f"[warmup] window must be at least 2 readings, got {self.window}")
        for name in ("interval_s", "max_drift_ifm_um", "max_drift_sensor_um", "timeout_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise SetupError(f"[warmup] {name} must be a finite number >= 0, got {v}")


@dataclass(frozen=True)
class HandsFreeSetup:
    """``[auto]``: ``guideway acquire --auto`` with real devices captures hands-free.  At each
    station the tool polls the interferometer every ``poll_s`` until the block is at the station
    (|lin| within ``[validation] max_lin_um``) and still (position, straightness Y and Z within
    ``still_um`` peak to peak for ``still_s``), then captures; after ``station_timeout_s`` it asks
    the operator (keep waiting, skip the station, abort)."""

    station_timeout_s: float = 300.0
    still_s: float = 2.0
    still_um: float = 2.0
    poll_s: float = 0.25

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
                raise SetupError(f"[auto] {f.name} must be a positive number, got {v!r}")
        if self.poll_s > self.still_s / 2:
            raise SetupError(f"[auto] poll_s ({self.poll_s:g} s) must be at most half of still_s "
                             f"({self.still_s:g} s): stillness needs at least three readings")


class Steps(Computed[tuple[int, int]]):
    """The (pass, station) steps of a run, each computed from its index: forward 0..n-1, then with
    a return pass n-1..0.  Holds two numbers whatever the station count."""

    what = "step"

    def __init__(self, stations: int, return_pass: bool) -> None:
        self.stations, self.return_pass = stations, return_pass

    def __len__(self) -> int:
        return self.stations * (2 if self.return_pass else 1)

    def at(self, i: int) -> tuple[int, int]:
        return (0, i) if i < self.stations else (1, 2 * self.stations - 1 - i)

    def index(self, step: Any, start: int = 0, stop: int | None = None) -> int:
        """Position of ``(pass, station)`` in the order (ValueError if the run has no such step)."""
        p, k = step
        if not (0 <= k < self.stations and (p == 0 or (p == 1 and self.return_pass))):
            raise ValueError(f"{step!r} is not a step of this run")
        i = k if p == 0 else 2 * self.stations - 1 - k
        if i < start or (stop is not None and i >= stop):
            raise ValueError(f"{step!r} is not between steps {start} and {stop}")
        return i

    def __contains__(self, step: object) -> bool:
        try:
            self.index(step)
        except (ValueError, TypeError):
            return False
        return True


@dataclass(frozen=True)
class StraightnessSetup:
    """Everything a straightness run needs before it starts."""

    block_length_mm: float
    stations: int
    geometry: BlockGeometry
    devices: DeviceSetup = field(default_factory=DeviceSetup)
    samples_per_reading: int = 5
    return_pass: bool = False
    warmup: WarmupSetup = field(default_factory=lambda: WarmupSetup(enabled=False))
    validation: ValidationSetup = field(default_factory=ValidationSetup)
    uncertainty: dict[str, float] = field(default_factory=dict)
    auto: HandsFreeSetup = field(default_factory=HandsFreeSetup)
    machine: str = ""
    axis: str = ""
    operator: str = ""
    notes: str = ""
    tolerance: dict[str, Any] = field(default_factory=dict)  # [tolerance], saved_runs.evaluation.tolerance
    scenario: str = ""  # [simulation] scenario: the file --simulate takes its effects from ("" = none)
    # [[instrument]]: the calibrated instruments (saved_runs.store.instruments), run.json setup.instruments
    instruments: list[dict[str, str]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.block_length_mm) and self.block_length_mm > 0):
            raise SetupError(f"block_length_mm must be a positive length, got {self.block_length_mm}")
        check_size("length_mm", self.block_length_mm, "[block]")
        check_size("stations", self.stations, "[block]")
        check_size("samples_per_reading", self.samples_per_reading, "[block]")
        if self.stations < 2:
            raise SetupError(f"stations must be at least 2 (datum + one step), got {self.stations}")
        if self.samples_per_reading < 1:
            raise SetupError(f"samples_per_reading must be >= 1, got {self.samples_per_reading}")
        for k, v in self.uncertainty.items():
            if k not in UNCERTAINTY_KEYS:
                raise SetupError(f"[uncertainty] unknown key {k!r}; use {', '.join(UNCERTAINTY_KEYS)}")
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise SetupError(f"[uncertainty] {k} must be a number >= 0, got {v!r}")

    def station_x_mm(self, k: int) -> float:
        """Nominal block position of station k: k times the block length."""
        return k * self.block_length_mm

    def steps(self) -> Steps:
        """The (pass, station) steps in order: forward 0..n-1, then (return pass) n-1..0 (computed
        when asked for, never a list)."""
        return Steps(self.stations, self.return_pass)

    def to_run_setup(self) -> dict[str, Any]:
        """run.json ``setup`` object (run format version 2)."""
        out: dict[str, Any] = {
            "block_length_mm": self.block_length_mm,
            "stations": self.stations,
            "samples_per_reading": self.samples_per_reading,
            "geometry": self.geometry.to_dict(),
            "return_pass": self.return_pass,
            "warmup": asdict(self.warmup),
            "validation": {**asdict(self.validation), "sensor_range_mm": list(self.validation.sensor_range_mm)},
            "devices": asdict(self.devices),
            "auto": asdict(self.auto),
        }
        if self.uncertainty:
            out["uncertainty"] = dict(self.uncertainty)
        if self.tolerance:
            out["tolerance"] = dict(self.tolerance)
        if self.instruments:
            out["instruments"] = [dict(i) for i in self.instruments]
        return out

    def header(self) -> dict[str, Any]:
        """run.json's descriptive fields (the run store adds the rest)."""
        return {"machine": self.machine, "axis": self.axis, "operator": self.operator, "notes": self.notes,
                "setup": self.to_run_setup()}


def straightness_setup_from_dict(data: dict[str, Any], source: str = "setup") -> StraightnessSetup:
    """Build and validate a :class:`StraightnessSetup` from the TOML structure; every refusal names ``source``."""
    return naming_source(_straightness_setup, data, source)


def _straightness_setup(data: dict[str, Any], source: str) -> StraightnessSetup:
    top = TomlTable(source, "", data)
    kind = top.get("kind", str, "straightness")
    if kind != "straightness":
        raise SetupError(f"{source}: kind is {kind!r}; this command needs a straightness setup")
    text = {k: top.get(k, str, "") for k in ("machine", "axis", "operator", "notes")}

    blk = top.table("block")
    length = blk.get("length_mm", float, required=True)
    stations = blk.get("stations", int, None)
    travel = blk.get("travel_length_mm", float, None)
    if (stations is None) == (travel is None):
        raise SetupError(f"{source}: [block] give exactly one of stations or travel_length_mm")
    if stations is not None:  # sizes first, before anything is built from them (acquisition/setup/maxima.py)
        check_size("stations", stations, "[block]")
    if travel is not None:
        if not (math.isfinite(travel) and travel > 0 and length > 0):
            raise SetupError(f"{source}: [block] travel_length_mm must be a positive length, got {travel}")
        check_size("travel_length_mm", travel, "[block]")
        # Whole steps that fit in the travel, plus the datum station (1e-9: 1000/100 is exactly 10 steps).
        steps = math.floor(travel / length + 1e-9) if math.isfinite(travel / length) else math.inf
        check_size("stations", steps + 1, f"[block] travel_length_mm / length_mm gives {steps + 1:g} stations:")
        stations = int(steps) + 1
    samples = blk.get("samples_per_reading", int, 5)
    check_size("samples_per_reading", samples, "[block]")
    return_pass = blk.get("return_pass", bool, False)

    geo = top.table("geometry")
    try:
        geometry = BlockGeometry(
            mirror_mm=geo.vector("mirror_mm", 3),  # type: ignore[arg-type]
            sensor_mm=geo.vector("sensor_mm", 3),  # type: ignore[arg-type]
            sensor_beam=geo.vector("sensor_beam", 3, [0.0, -1.0, 0.0]),  # type: ignore[arg-type]
            sensor_sign=geo.get("sensor_sign", str, "height"),
            datum_angles_urad=DatumAngles.from_dict(geo.get("datum_angles_urad", dict, None)),
        )
    except ValueError as exc:
        raise SetupError(f"{source}: [geometry] {exc}") from None

    sen = top.table("sensor")
    ctl = top.table("controller")
    devices = DeviceSetup(
        sensor_protocol=sen.get("protocol", str, "keyence-lkg"),
        sensor_url=sen.get("port", str, ""),
        sensor_baud=sen.get("baud", int, None),
        sensor_series=sen.get("series", str, None),
        sensor_output=sen.get("output", int, None),
        controller_url=ctl.get("url", str, ""),
        word_order=ctl.get("word_order", str, "ABCD"),
        environment_url=top.table("transmitter").get("url", str, ""),
        **controller_timing_keys(ctl),
    )
    if devices.word_order not in ("ABCD", "CDAB"):
        raise SetupError(f"{source}: [controller] word_order must be ABCD or CDAB, got {devices.word_order!r}")
    check_devices(devices, source, sensor=True)

    wu = top.table("warmup")
    d = WarmupSetup()
    warmup = WarmupSetup(
        enabled=wu.get("enabled", bool, True),
        window=wu.get("window", int, d.window),
        interval_s=wu.get("interval_s", float, d.interval_s),
        max_drift_ifm_um=wu.get("max_drift_ifm_um", float, d.max_drift_ifm_um),
        max_drift_sensor_um=wu.get("max_drift_sensor_um", float, d.max_drift_sensor_um),
        timeout_s=wu.get("timeout_s", float, d.timeout_s),
    )
    va = top.table("validation")
    v = ValidationSetup()
    validation = ValidationSetup(
        max_sensor_std_um=va.get("max_sensor_std_um", float, v.max_sensor_std_um),
        sensor_range_mm=va.vector("sensor_range_mm", 2, list(v.sensor_range_mm)),  # type: ignore[arg-type]
        max_straightness_um=va.get("max_straightness_um", float, v.max_straightness_um),
        max_angle_urad=va.get("max_angle_urad", float, v.max_angle_urad),
        max_lin_um=va.get("max_lin_um", float, v.max_lin_um),
        jump_ifm_um=va.get("jump_ifm_um", float, v.jump_ifm_um),
        jump_sensor_um=va.get("jump_sensor_um", float, v.jump_sensor_um),
        capture_attempts=va.get("capture_attempts", int, v.capture_attempts),
    )
    unc = top.table("uncertainty")
    uncertainty = {k: unc.get(k, float) for k in list(unc.data)}
    tolerance = straightness_tolerance(top.table("tolerance").data, source)
    instruments = instrument_tables(top.get("instrument", list, None), source)
    sim = top.table("simulation")
    scenario = scenario_path(sim.get("scenario", str, ""), source)
    au = top.table("auto")
    a = HandsFreeSetup()
    auto = HandsFreeSetup(**{f.name: au.get(f.name, float, getattr(a, f.name)) for f in fields(a)})
    for t in (top, blk, geo, sen, ctl, wu, va, sim, au, catalog_table(top)):
        t.check_unknown()
    return StraightnessSetup(
        block_length_mm=length, stations=stations, geometry=geometry, devices=devices,  # type: ignore[arg-type]
        samples_per_reading=samples, return_pass=return_pass, warmup=warmup, validation=validation,
        uncertainty=uncertainty, tolerance=tolerance, scenario=scenario, auto=auto, instruments=instruments,
        **text,
    )


def load_straightness_setup(path: Path | str) -> StraightnessSetup:
    """Read ``path`` (TOML) into a validated straightness setup."""
    return straightness_setup_from_dict(read_toml(path), str(path))
