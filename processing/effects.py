"""The vocabulary of physical effects (docs/diagnosis.md): one list of effect types that serves
as simulation input (a scenario) and as the model a run is compared with.

An :class:`Effect` is a ``type``, its parameters (units in their names) and the set of
parameters the diagnosis may fit (``free``).  This module only describes and validates
effects; their contributions to a run's observations are in
:mod:`processing.diagnosis.basis` (the simulated devices in ``mocks/`` implement the same
documented equations on their own).

Positioning runs (deviation e = reading − target, µm; P = target position in axis
coordinates, mm; t = time since the run started, min; s = +1 for an approach in the
positive direction, −1 for the negative one)::

    error_table     e = interp(P; positions_mm, error_um)              (linear, flat beyond the ends)
    linear_scale    e = ppm · P · 1e-3
    quadratic       e = um_per_m2 · (P / 1000)²
    backlash        e = s · reversal_um / 2                           (reversal_um = ISO 230-2 B = x̄↑ − x̄↓)
    periodic        e = amplitude_um · sin(2π P / wavelength_mm + phase_rad)
    thermal_drift   e = um_per_min · t
    thermal_growth  e = ppm_per_min · P · t · 1e-3
    abbe            e = offset_mm · ε · 1e-3          (ε = recorded pitch_urad or yaw_urad, channel)
    dead_path       e = length_mm · (n − n₀) · 1e3    (n air index of the point, n₀ of the first point)

Straightness runs (h = the decoupled surface height of each point, µm; t in min; s_k the
sensor reading change since the first point in the height sense, µm; Δε the pitch change
since the first point, µrad; k the station)::

    profile_table   h = interp(x; positions_mm, height_um)   (+ offset and slope, nuisance)
    sensor_drift    h += um_per_min · t
    sensor_gain     h += ppm · 1e-6 · s_k
    lever_arm       h += ±error_mm · Δε · 1e-3         (error_mm = recorded |xQ − xP| minus the true one;
                                                       + with the sensor ahead of P, xQ > xP; − behind it)
    block_length    lin_um += um_per_block · k         (the block is longer than recorded)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

KINDS = ("positioning", "straightness")
ANGLE_CHANNELS = ("pitch", "yaw")

ParamValue = float | tuple[float, ...] | str | None


@dataclass(frozen=True)
class Param:
    """One parameter of an effect type: ``name`` (unit in the name), what it means, its form:
    ``number``, ``numbers`` (a list, table values) or ``nodes`` / ``channel`` (structural,
    never fitted)."""

    name: str
    doc: str
    form: str = "number"
    default: ParamValue = 0.0

    @property
    def fittable(self) -> bool:
        return self.form in ("number", "numbers")


@dataclass(frozen=True)
class EffectType:
    """An effect type of the library: the run kind it applies to, its parameters, its equation."""

    name: str
    kind: str
    params: tuple[Param, ...]
    equation: str
    meaning: str
    channel: str = "deviation"  # the observation it acts on: deviation | height | lin

    @property
    def fittable(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params if p.fittable)


def _p(name: str, doc: str, form: str = "number", default: ParamValue = 0.0) -> Param:
    return Param(name, doc, form, default)


EFFECT_TYPES: dict[str, EffectType] = {t.name: t for t in (
    EffectType("error_table", "positioning", (
        _p("positions_mm", "table positions, strictly increasing", "nodes", None),
        _p("error_um", "error at each position", "numbers", None)),
        "e = interp(P; positions_mm, error_um)",
        "a known error curve (an earlier calibration), linear interpolation, constant beyond the ends"),
    EffectType("linear_scale", "positioning", (_p("ppm", "scale error, µm per m of travel"),),
               "e = ppm · P · 1e-3",
               "scale or lead error, wrong material temperature or expansion coefficient, air-index error"),
    EffectType("quadratic", "positioning", (_p("um_per_m2", "error per square metre of position"),),
               "e = um_per_m2 · (P / 1000)²", "sag, a bent scale"),
    EffectType("backlash", "positioning", (_p("reversal_um", "x̄↑ − x̄↓, the signed ISO 230-2 reversal B"),),
               "e = s · reversal_um / 2", "lost motion on reversal: half the reversal by approach direction"),
    EffectType("periodic", "positioning", (
        _p("amplitude_um", "amplitude"), _p("wavelength_mm", "period along the travel", default=None),
        _p("phase_rad", "phase at P = 0")),
        "e = amplitude_um · sin(2π P / wavelength_mm + phase_rad)", "screw lead error, scale period"),
    EffectType("thermal_drift", "positioning", (_p("um_per_min", "drift rate"),),
               "e = um_per_min · t", "thermal drift of the set-up (laser mount, spindle, workpiece)"),
    EffectType("thermal_growth", "positioning", (_p("ppm_per_min", "rate of change of the scale"),),
               "e = ppm_per_min · P · t · 1e-3", "the axis grows with its temperature during the run"),
    EffectType("abbe", "positioning", (
        _p("offset_mm", "Abbe offset h: e = h · ε"),
        _p("channel", "the recorded angle the offset acts through: pitch or yaw", "channel", "pitch")),
        "e = offset_mm · ε · 1e-3 (ε = pitch_urad or yaw_urad of the point)",
        "an offset between the measuring line and the functional point, times the axis' angular motion"),
    EffectType("dead_path", "positioning", (_p("length_mm", "dead path not corrected"),),
               "e = length_mm · (n − n₀) · 1e3 (air index from the point's air temperature, pressure, humidity)",
               "an uncorrected dead path: the air index change since the first point times its length"),
    EffectType("profile_table", "straightness", (
        _p("positions_mm", "profile positions (x from the first station's sample point), increasing",
           "nodes", None),
        _p("height_um", "surface height at each position", "numbers", None)),
        "h = interp(x; positions_mm, height_um) + offset + slope · x (nuisance)",
        "a reference surface (e.g. a certified straightedge)", "height"),
    EffectType("sensor_drift", "straightness", (_p("um_per_min", "drift of the reading, height sense"),),
               "h += um_per_min · t", "the displacement sensor's reading drifts with time", "height"),
    EffectType("sensor_gain", "straightness", (_p("ppm", "scale error of the reading change"),),
               "h += ppm · 1e-6 · s (s = sensor change since the first point, height sense, µm)",
               "sensor scale error or the cosine of its tilt", "height"),
    EffectType("lever_arm", "straightness", (_p("error_mm", "recorded |xQ − xP| minus the true distance"),),
               "h += sign(xQ − xP) · error_mm · Δpitch_urad · 1e-3",
               "the recorded X distance between P and Q is wrong", "height"),
    EffectType("block_length", "straightness", (_p("um_per_block", "block longer than recorded by this"),),
               "lin_um += um_per_block · k (k = station)",
               "the block is longer than recorded; its position error accumulates with the station", "lin"),
)}


def types_of(kind: str) -> tuple[str, ...]:
    return tuple(n for n, t in EFFECT_TYPES.items() if t.kind == kind)


@dataclass(frozen=True)
class Effect:
    """One effect: its type, parameter values (None = not given: fitted if free, else an error)
    and the names of the free parameters the diagnosis fits."""

    type: str
    params: Mapping[str, ParamValue]
    free: frozenset[str] = field(default_factory=frozenset)

    @property
    def spec(self) -> EffectType:
        return EFFECT_TYPES[self.type]

    @property
    def variant(self) -> str:
        """What tells two effects of the same type apart: the angle channel of an Abbe effect."""
        return str(self.params.get("channel", "")) if self.type == "abbe" else ""

    @property
    def label(self) -> str:
        return f"{self.type}({self.variant})" if self.variant else self.type

    def value(self, name: str) -> float:
        v = self.params.get(name)
        return 0.0 if v is None else float(v)  # type: ignore[arg-type]

    def with_params(self, values: Mapping[str, ParamValue], free: Iterable[str] | None = None) -> Effect:
        return Effect(self.type, {**self.params, **values}, self.free if free is None else frozenset(free))

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"type": self.type}
        for p in self.spec.params:
            v = self.params.get(p.name)
            if v is not None:
                d[p.name] = list(v) if isinstance(v, tuple) else v
        if self.free:
            d["free"] = sorted(self.free) if self.free != set(self.spec.fittable) else True
        return d


# Periodic effects: the free combinations the fit supports (the others are not identifiable or
# would need a nonlinear amplitude-only fit of the phase).
PERIODIC_FREE = (frozenset({"amplitude_um", "wavelength_mm", "phase_rad"}),
                 frozenset({"amplitude_um", "phase_rad"}), frozenset({"amplitude_um"}))


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def make_effect(kind: str, data: Mapping[str, Any]) -> Effect:
    """Validate one ``[[effect]]`` table of a ``kind`` run; ValueError with a one-line reason."""
    data = dict(data)
    name = data.pop("type", None)
    if not isinstance(name, str):
        raise ValueError("an effect needs type = \"...\"")
    spec = EFFECT_TYPES.get(name)
    if spec is None or spec.kind != kind:
        raise ValueError(f"type {name!r} is not a {kind} effect; use one of {', '.join(types_of(kind))}")
    free_spec = data.pop("free", False)
    unknown = sorted(set(data) - {p.name for p in spec.params})
    if unknown:
        raise ValueError(f"{name}: unknown parameter {unknown[0]!r}; it takes {', '.join(p.name for p in spec.params)}")
    if free_spec is True:
        free = frozenset(spec.fittable)
    elif free_spec is False:
        free = frozenset()
    elif isinstance(free_spec, list) and all(isinstance(f, str) for f in free_spec):
        free = frozenset(free_spec)
        bad = sorted(free - set(spec.fittable))
        if bad:
            raise ValueError(f"{name}: free {bad[0]!r} is not a parameter that can be fitted "
                             f"({', '.join(spec.fittable)})")
    else:
        raise ValueError(f"{name}: free must be true, false or a list of parameter names, got {free_spec!r}")
    params: dict[str, ParamValue] = {}
    for p in spec.params:
        v = data.get(p.name)
        if p.form == "number":
            if v is None:
                v = None if (p.name in free or p.default is None) else p.default
            elif not _number(v):
                raise ValueError(f"{name}: {p.name} must be a number, got {v!r}")
            params[p.name] = None if v is None else float(v)
        elif p.form == "channel":
            v = p.default if v is None else v
            if v not in ANGLE_CHANNELS:
                raise ValueError(f"{name}: {p.name} must be one of {', '.join(ANGLE_CHANNELS)}, got {v!r}")
            params[p.name] = v
        else:  # nodes / numbers
            if v is None:
                params[p.name] = None
                continue
            if not (isinstance(v, list) and all(_number(x) for x in v)):
                raise ValueError(f"{name}: {p.name} must be a list of numbers")
            params[p.name] = tuple(float(x) for x in v)
    _check_effect(name, spec, params, free)
    return Effect(name, params, free)


def _check_effect(name: str, spec: EffectType, params: dict[str, ParamValue], free: frozenset[str]) -> None:
    if name in ("error_table", "profile_table"):
        values_key = spec.params[1].name
        pos = params["positions_mm"]
        if pos is None:
            raise ValueError(f"{name}: positions_mm is missing; give the table's positions")
        if len(pos) < 2 or any(b <= a for a, b in zip(pos, pos[1:], strict=False)):  # type: ignore[arg-type]
            raise ValueError(f"{name}: positions_mm must hold at least 2 strictly increasing positions")
        vals = params[values_key]
        if vals is None:
            if values_key not in free:
                raise ValueError(f"{name}: {values_key} is missing; give the values or set free = true")
            params[values_key] = tuple(0.0 for _ in pos)  # type: ignore[union-attr]
        elif len(vals) != len(pos):  # type: ignore[arg-type]
            raise ValueError(f"{name}: {values_key} has {len(vals)} values for {len(pos)} positions")  # type: ignore
    for p in spec.params:
        if p.form == "number" and params[p.name] is None and p.name not in free:
            raise ValueError(f"{name}: {p.name} is missing; give it or make it free")
    if name == "periodic":
        wl = params["wavelength_mm"]
        if wl is not None and not wl > 0:  # type: ignore[operator]
            raise ValueError(f"periodic: wavelength_mm must be positive, got {wl}")
        if free and free not in PERIODIC_FREE:
            raise ValueError("periodic: free must be true (all three), [\"amplitude_um\", \"phase_rad\"] "
                             "(known wavelength) or [\"amplitude_um\"]")
    # a free parameter without a value starts at zero (the periodic wavelength is searched)
    for p in spec.params:
        if p.form == "number" and params[p.name] is None and not (name == "periodic" and p.name == "wavelength_mm"):
            params[p.name] = 0.0
