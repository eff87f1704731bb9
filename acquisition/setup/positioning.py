"""Validated set-up of an ISO 230-2 positioning run, from TOML (docs/setup-positioning.toml)."""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from processing.air_index import DEFAULT_EQUATION
from processing.environment import EnvironmentSettings
from processing.iso230_2 import LONG_AXIS_MM
from processing.positioning_budget import BudgetSettings
from saved_runs import nc_text
from saved_runs.errors import SetupError, UserError
from saved_runs.evaluation.tolerance import positioning_tolerance
from saved_runs.store.instruments import instrument_tables
from saved_runs.toml_file import TomlTable, naming_source, read_toml

from .compensation import CompensationSetup, compensation_setup
from .conditions import check_conditions
from .cycles import CYCLES, Cycle, check_targets, cycle, linear_targets, rotary_targets
from .maxima import check_size
from .shared_tables import DeviceSetup, catalog_table, check_devices, controller_timing_keys, scenario_path

TRIGGERS = ("in-position", "stability", "manual")
DIALECTS = ("fanuc", "linuxcnc")
AXIS_TYPES = ("linear", "rotary")


@dataclass(frozen=True)
class EnvironmentSetup:
    """run.json ``setup.environment`` (docs/run-format.md): what ``reading_mm`` already contains."""

    refractive_index_assumed: float = 1.0
    wavelength_nm: float = 632.991
    expansion_ppm_per_k: float = 11.5
    dead_path_mm: float = 0.0
    abbe_offset_mm: tuple[float, float] = (0.0, 0.0)
    co2_ppm: float = 450.0
    readings_compensated: bool = False
    index_equation: str = DEFAULT_EQUATION  # "ciddor" or "edlen" (docs/positioning.md)

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "abbe_offset_mm": list(self.abbe_offset_mm)}


@dataclass(frozen=True)
class TriggerSetup:
    """How each point is captured: ``in-position`` (PLC register), ``stability`` (the position stays
    within ``stability_window`` (um or arcsec) for ``dwell_s`` near a target), or ``manual``."""

    mode: str = "in-position"
    dwell_s: float = 2.0
    timeout_s: float = 120.0
    stability_window: float = 1.0
    near: float = 0.5  # mm or deg: how close to the target the stability check starts
    poll_s: float = 0.05

    def __post_init__(self) -> None:
        if self.mode not in TRIGGERS:
            raise SetupError(f"[trigger] mode must be one of {', '.join(TRIGGERS)}, got {self.mode!r}")
        for name in ("dwell_s", "timeout_s", "stability_window", "near", "poll_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise SetupError(f"[trigger] {name} must be a number >= 0, got {v}")


@dataclass(frozen=True)
class SimulatedAxisSetup:
    """Errors of the simulated machine axis (``--simulate``): um (linear) or arcsec (rotary), and the
    conditions its controller measures (air C, hPa, %RH, material C, drift C per hour of machine time)."""

    pitch_amplitude: float = 4.0
    pitch_wavelength: float = 700.0
    slope_per_m: float = 6.0
    backlash: float = 3.0
    periodic: float = 0.6
    periodic_period: float = 10.0
    thermal_per_m_per_h: float = 4.0
    noise: float = 0.15
    air_temp_c: float = 20.4
    air_pressure_hpa: float = 1012.8
    humidity_pct: float = 45.0
    material_temp_c: float = 20.2
    drift_c_per_h: float = 0.05
    plc_bits_left_set: bool = False  # the PLC left in position / cycle finished set from an earlier cycle
    program_start_s: float = 0.0  # the program reaches its first block this long after Cycle Start
    # a reversal error varying along the axis: e↑ − e↓ gains amplitude·sin(2π p / wavelength), ↑ and ↓ cross
    reversal_amplitude: float = 0.0
    reversal_wavelength: float = 360.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.reversal_wavelength) and self.reversal_wavelength > 0):
            raise SetupError(f"[simulation] reversal_wavelength must be a number > 0, got {self.reversal_wavelength}")
        if not (math.isfinite(self.program_start_s) and self.program_start_s >= 0):
            raise SetupError(f"[simulation] program_start_s must be a number >= 0, got {self.program_start_s}")

    def errors(self) -> tuple[float, ...]:
        """The error-model values (without the environment)."""
        return (self.pitch_amplitude, self.pitch_wavelength, self.slope_per_m, self.backlash, self.periodic,
                self.periodic_period, self.thermal_per_m_per_h, self.noise)


def check_simulated_axis(sim: SimulatedAxisSetup, where: str) -> None:
    """The ``[simulation]`` values within their bounds (one line naming the key): the conditions within the
    plausible ranges of :mod:`.conditions`, the error values finite, the periods positive, the noise >= 0."""
    check_conditions(asdict(sim), where)
    for key in ("pitch_amplitude", "slope_per_m", "backlash", "periodic", "thermal_per_m_per_h"):
        if not math.isfinite(v := getattr(sim, key)):
            raise SetupError(f"{where} {key} = {v:g} must be a finite number")
    for key in ("pitch_wavelength", "periodic_period"):
        if not (math.isfinite(v := getattr(sim, key)) and v > 0):
            raise SetupError(f"{where} {key} = {v:g} must be a positive number (a period along the axis)")
    if not (math.isfinite(sim.noise) and sim.noise >= 0):
        raise SetupError(f"{where} noise = {sim.noise:g} is a standard deviation and must be a number >= 0")


@dataclass(frozen=True)
class PositioningSetup:
    """Everything an ISO 230-2 positioning run needs before it starts."""

    axis_name: str
    axis_type: str
    targets: tuple[float, ...]
    runs: int = 5
    cycle: str = "linear"
    overrun: float = 5.0
    feed_per_min: float = 2000.0
    datum: float = 0.0
    trigger: TriggerSetup = field(default_factory=TriggerSetup)
    environment: EnvironmentSetup = field(default_factory=EnvironmentSetup)
    devices: DeviceSetup = field(default_factory=DeviceSetup)
    dialect: str = "fanuc"
    program_number: int = 1000
    max_deviation: float = 1.0  # mm or deg: a reading further than this from its target is rejected
    simulation: SimulatedAxisSetup = field(default_factory=SimulatedAxisSetup)
    long_axis: bool = False
    machine: str = ""
    operator: str = ""
    notes: str = ""
    tolerance: dict[str, float] = field(default_factory=dict)  # [tolerance], saved_runs.evaluation.tolerance
    # [uncertainty]: the figures of the ISO 230-2 values' budget (processing.positioning_budget.BudgetSettings)
    uncertainty: dict[str, float] = field(default_factory=dict)
    scenario: str = ""  # [simulation] scenario: the file --simulate takes its effects from ("" = none)
    # [[instrument]]: the calibrated instruments (saved_runs.store.instruments), run.json setup.instruments
    instruments: list[dict[str, str]] = field(default_factory=list)
    compensation: CompensationSetup | None = None  # [compensation]: the table active in the controller
    target_shift: float = 0.0  # [axis] shift_targets_mm (deg): the targets moved by this, between a table's points

    def __post_init__(self) -> None:
        if self.axis_type not in AXIS_TYPES:
            raise SetupError(f"[axis] type must be linear or rotary, got {self.axis_type!r}")
        if self.cycle not in CYCLES:
            raise SetupError(f"[axis] cycle must be one of {', '.join(CYCLES)}, got {self.cycle!r}")
        if self.dialect not in DIALECTS:
            raise SetupError(f"[gcode] dialect must be one of {', '.join(DIALECTS)}, got {self.dialect!r}")
        if not (math.isfinite(self.feed_per_min) and self.feed_per_min > 0):
            raise SetupError(f"[axis] feed must be positive, got {self.feed_per_min}")
        check_size("targets", len(self.targets), "[axis]")  # sizes before the cycle is looked at
        check_size("runs", self.runs, "[axis]")
        if self.axis_type == "linear" and self.targets:
            check_size("travel_mm", max(self.targets) - min(self.targets), "[axis] targets span:")
        try:
            self.stops()  # validates targets, runs and overrun
        except SetupError as exc:  # the cycle's own words name its arguments; the set-up's keys live in [axis]
            raise SetupError(f"[axis] {str(exc).replace('overrun ', f'overrun_{self.unit} ', 1)}") from None
        if self.trigger.mode == "stability" and (problem := self.stability_problem()):
            raise SetupError(f"[trigger] mode = \"stability\" cannot follow this cycle: {problem}")

    def stability_problem(self) -> str | None:
        """Why the stability trigger cannot tell every stop of this cycle apart (one line), or None.

        It polls the interferometer every ``poll_s`` (plus the controller's measurement time) and
        must see (1) the axis leave each target's ``near`` window at every reversal, which takes
        2 (overrun - near) / feed and must last two polls; (2) neighbouring targets' windows apart;
        (3) two readings half a dwell apart inside the dwell, the first up to a poll after arrival.
        """
        u, tr = self.unit, self.trigger
        if tr.near <= 0 or tr.stability_window <= 0 or tr.dwell_s <= 0 or tr.poll_s <= 0:
            return f"dwell_s, poll_s, near_{u} and the stability window must all be positive"
        beyond_s = 2 * (self.overrun - tr.near) / (self.feed_per_min / 60.0)
        if beyond_s < 2 * tr.poll_s:
            return (f"at each reversal the axis is beyond near_{u} = {tr.near:g} for {max(beyond_s, 0.0):.3g} s "
                    f"(overrun_{u} {self.overrun:g} at feed {self.feed_per_min:g} {u}/min), shorter than two polls "
                    f"(poll_s {tr.poll_s:g}): the direction change would go unseen; raise overrun_{u}, lower the "
                    f"feed or poll_s")
        gap = min(b - a for a, b in zip(self.targets, self.targets[1:], strict=False))
        if gap <= 2 * tr.near:
            return (f"targets {gap:g} {u} apart lie inside each other's near_{u} = {tr.near:g} windows; "
                    f"lower near_{u} below {gap / 2:g}")
        if tr.poll_s > tr.dwell_s / 4:
            return (f"poll_s {tr.poll_s:g} s is too long for dwell_s {tr.dwell_s:g} s: a stable capture needs "
                    f"readings half a dwell apart inside the dwell (poll_s <= dwell_s / 4)")
        return None

    @property
    def unit(self) -> str:
        return "deg" if self.axis_type == "rotary" else "mm"

    def stops(self) -> Cycle:
        """Every stop of the cycle, overruns included (computed when asked for, never a list)."""
        return cycle(self.cycle, self.targets, self.runs, self.overrun)

    def measured_stops(self) -> Cycle:
        """The stops where a point is captured, in the order the cycle reaches them."""
        return cycle(self.cycle, self.targets, self.runs, self.overrun, measured=True)

    def to_run_setup(self) -> dict[str, Any]:
        """run.json ``setup`` of a positioning run (docs/run-format.md, version 2)."""
        u = self.unit
        return {
            "axis_name": self.axis_name,
            f"targets_{u}": list(self.targets),
            "runs": self.runs,
            "cycle": self.cycle,
            f"overrun_{u}": self.overrun,
            "trigger": self.trigger.mode,
            "dwell_s": self.trigger.dwell_s,
            f"feed_{u}_min": self.feed_per_min,
            f"datum_{u}": self.datum,
            "long_axis": self.long_axis,
            "trigger_options": asdict(self.trigger),
            f"max_deviation_{u}": self.max_deviation,
            "gcode": {"dialect": self.dialect, "program_number": self.program_number},
            "environment": self.environment.to_dict(),
            "devices": asdict(self.devices),
            **({"tolerance": dict(self.tolerance)} if self.tolerance else {}),
            **({"uncertainty": dict(self.uncertainty)} if self.uncertainty else {}),
            **({f"shift_targets_{u}": self.target_shift} if self.target_shift else {}),
            **({"instruments": [dict(i) for i in self.instruments]} if self.instruments else {}),
        }

    def header(self) -> dict[str, Any]:
        return {"machine": self.machine, "axis": self.axis_name, "operator": self.operator, "notes": self.notes,
                "axis_type": self.axis_type, "setup": self.to_run_setup()}


def _nc_checked(check: Any, value: Any, what: str) -> Any:
    """``check(value, what)`` of saved_runs.nc_text, its refusal as a :class:`SetupError`: a string
    that reaches the part program must be one the controller accepts."""
    try:
        return check(value, what)
    except UserError as exc:
        raise SetupError(str(exc)) from None


def positioning_setup_from_dict(data: dict[str, Any], source: str = "setup", *,
                                stored: bool = False) -> PositioningSetup:
    """Build and validate a :class:`PositioningSetup` from the TOML structure; every refusal names ``source``
    (the set-up file) first.  ``stored``: the set-up of a run being resumed (run.json ``setup_source``),
    which a version before the NC-string checks may have written with an axis name or program number the
    controller would refuse; resuming writes no NC code (the part program checks its strings itself), so
    those are not checked here, and the run's points are not stranded."""
    return naming_source(functools.partial(_positioning_setup, nc_checked=not stored), data, source)


def _positioning_setup(data: dict[str, Any], source: str, nc_checked: bool = True) -> PositioningSetup:
    top = TomlTable(source, "", data)
    kind = top.get("kind", str, "positioning")
    if kind != "positioning":
        raise SetupError(f"{source}: kind is {kind!r}; this command needs a positioning setup")
    text = {k: top.get(k, str, "") for k in ("machine", "operator", "notes")}
    ax = top.table("axis")
    axis_type = ax.get("type", str, "linear")
    if axis_type not in AXIS_TYPES:
        raise SetupError(f"{source}: [axis] type must be linear or rotary, got {axis_type!r}")
    u = "deg" if axis_type == "rotary" else "mm"
    name = ax.get("name", str, "C" if axis_type == "rotary" else "X")
    if nc_checked:
        name = _nc_checked(nc_text.axis_letter, name, f"{source}: [axis] name")
    seed = ax.get("seed", int, 0)
    explicit = ax.get(f"targets_{u}", list, None)
    allow_nonconforming = ax.get("allow_nonconforming_targets", bool, False)
    start = ax.get(f"start_{u}", float, 0.0)
    end = ax.get(f"end_{u}", float, 360.0 if axis_type == "rotary" else None)
    long_axis = False
    # sizes first, before targets are generated or a cycle is looked at (acquisition/setup/maxima.py)
    if explicit is not None:
        check_size("targets", len(explicit), f"[axis] targets_{u}:")
    elif end is not None and axis_type == "linear" and math.isfinite(end - start):
        check_size("travel_mm", abs(end - start), f"[axis] end_{u} - start_{u}:")
    if explicit is not None:
        if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in explicit):
            raise SetupError(f"{source}: [axis] targets_{u} must be a list of numbers")
        targets = tuple(float(v) for v in explicit)
    elif end is None:
        raise SetupError(f"{source}: [axis] give end_{u} (targets are generated per ISO 230-2) or targets_{u}")
    elif axis_type == "rotary":
        per_rev = ax.get("targets_per_rev", int, 8)
        check_size("targets_per_rev", per_rev, "[axis]")
        targets = rotary_targets(start, end, seed=seed, per_rev=per_rev)
    else:
        targets = linear_targets(start, end, seed=seed)
        long_axis = end - start > LONG_AXIS_MM
    shift = ax.get(f"shift_targets_{u}", float, 0.0)
    measured = shifted_targets(targets, shift, f"{source}: [axis] shift_targets_{u}") if shift else targets
    runs = ax.get("runs", int, 1 if long_axis else 5)
    cyc = ax.get("cycle", str, "linear")
    overrun = ax.get(f"overrun_{u}", float, 5.0 if u == "mm" else 2.0)
    feed = ax.get(f"feed_{u}_min", float, 2000.0 if u == "mm" else 1800.0)
    datum = ax.get(f"datum_{u}", float, start)
    max_dev = ax.get(f"max_deviation_{u}", float, 1.0 if u == "mm" else 0.1)
    if not (math.isfinite(max_dev) and max_dev > 0):  # 0 would reject every reading of the run
        raise SetupError(f"{source}: [axis] max_deviation_{u} must be a positive {u} value (a reading further "
                         f"from its target is rejected), got {max_dev:g}")

    tr = top.table("trigger")
    d = TriggerSetup()
    trigger = TriggerSetup(
        mode=tr.get("mode", str, d.mode), dwell_s=tr.get("dwell_s", float, d.dwell_s),
        timeout_s=tr.get("timeout_s", float, d.timeout_s),
        stability_window=tr.get("stability_window_arcsec" if u == "deg" else "stability_window_um", float,
                                d.stability_window),
        near=tr.get(f"near_{u}", float, d.near), poll_s=tr.get("poll_s", float, d.poll_s),
    )
    en = top.table("environment")
    e = EnvironmentSetup()
    environment = EnvironmentSetup(
        refractive_index_assumed=en.get("refractive_index_assumed", float, e.refractive_index_assumed),
        wavelength_nm=en.get("wavelength_nm", float, e.wavelength_nm),
        expansion_ppm_per_k=en.get("expansion_ppm_per_k", float, e.expansion_ppm_per_k),
        dead_path_mm=en.get("dead_path_mm", float, e.dead_path_mm),
        abbe_offset_mm=en.vector("abbe_offset_mm", 2, list(e.abbe_offset_mm)),  # type: ignore[arg-type]
        co2_ppm=en.get("co2_ppm", float, e.co2_ppm),
        readings_compensated=en.get("readings_compensated", bool, e.readings_compensated),
        index_equation=en.get("index_equation", str, e.index_equation),
    )
    try:  # the checks processing makes, now rather than after the run is captured
        EnvironmentSettings.from_dict(environment.to_dict())
    except ValueError as exc:
        raise SetupError(f"{source}: {str(exc).replace('setup.environment.', '[environment] ')}") from None
    ctl = top.table("controller")
    devices = DeviceSetup(sensor_url="", controller_url=ctl.get("url", str, ""),
                          word_order=ctl.get("word_order", str, "ABCD"),
                          environment_url=top.table("transmitter").get("url", str, ""),
                          **controller_timing_keys(ctl))
    check_devices(devices, source, sensor=False)
    gc = top.table("gcode")
    dialect, program_number = gc.get("dialect", str, "fanuc"), gc.get("program_number", int, 1000)
    if nc_checked:
        program_number = _nc_checked(nc_text.program_number, program_number, f"{source}: [gcode] program_number")
    sim = top.table("simulation")
    s = SimulatedAxisSetup()
    simulation = SimulatedAxisSetup(**{k: sim.get(k, bool if isinstance(v, bool) else float, v)
                                       for k, v in asdict(s).items()})
    check_simulated_axis(simulation, f"{source}: [simulation]")
    tolerance = positioning_tolerance(top.table("tolerance").data, "arcsec" if axis_type == "rotary" else "um",
                                      source)
    uncertainty = top.table("uncertainty").data or {}
    try:
        BudgetSettings.from_dict(uncertainty)
    except ValueError as exc:
        raise SetupError(f"{source}: {exc}") from None
    scenario = scenario_path(sim.get("scenario", str, ""), source)
    compensation = compensation_setup(top, source, u)
    instruments = instrument_tables(top.get("instrument", list, None), source, stored=not nc_checked)
    for t in (top, ax, tr, en, ctl, gc, sim, catalog_table(top)):
        t.check_unknown()
    setup = PositioningSetup(
        axis_name=name, axis_type=axis_type, targets=measured, runs=runs, cycle=cyc, overrun=overrun,
        feed_per_min=feed, datum=datum, trigger=trigger, environment=environment, devices=devices,
        dialect=dialect, program_number=program_number,
        max_deviation=max_dev, simulation=simulation, long_axis=long_axis, tolerance=tolerance,
        uncertainty={k: float(v) for k, v in uncertainty.items()},
        scenario=scenario, compensation=compensation, target_shift=shift, instruments=instruments, **text,
    )
    if explicit is not None:  # generated targets follow the rule by construction
        span = end - start if end is not None and axis_type == "linear" else None
        check_targets(targets, axis_type, span, allow_nonconforming=allow_nonconforming)
    return setup


def shifted_targets(targets: tuple[float, ...], shift: float, what: str) -> tuple[float, ...]:
    """The targets moved by ``shift`` (mm or deg), those that stay within the first … last target: an as-left run
    that measures between the points of a table made on ``targets`` (docs/compensation.md, "Shifted targets")."""
    if not math.isfinite(shift):
        raise SetupError(f"{what} must be a number, got {shift!r}")
    lo, hi = min(targets), max(targets)
    out = tuple(round(t + shift, 9) for t in targets if lo <= t + shift <= hi)  # no float fuzz in run.json
    if len(out) < 2:
        raise SetupError(f"{what} = {shift:g} leaves {len(out)} target(s) within {lo:g} … {hi:g}; shift by less than "
                         "the span (half the target spacing measures midway between the table's points)")
    return out


def load_positioning_setup(path: Path | str) -> PositioningSetup:
    return positioning_setup_from_dict(read_toml(path), str(path))
