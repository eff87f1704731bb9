"""Read a machine file (``MACHINE.toml``, commented example docs/machine-example.toml) into a
:class:`~processing.volumetric.model.MachineModel`.

Every problem is a one-line :class:`~saved_runs.errors.SetupError` naming the file, the body
or table and the key.  Run directories named by the file are read relative to its directory.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from processing.decoupling import DEFAULT_METHOD, METHODS
from processing.volumetric.curves import Constant, Curve, Polynomial, Table
from processing.volumetric.model import (
    COMPONENTS,
    Body,
    Element,
    MachineModel,
    component_element,
    squareness_element,
)
from processing.volumetric.rotations import AXIS_LETTERS, signed_axis, unit_vector

from ..errors import SetupError, UserError
from ..toml_file import TomlTable, read_toml
from .run_channels import CHANNELS, LINES, RunCache, channel_vector, run_curve

EXAMPLE = "docs/machine-example.toml"
CONDITIONS = {"temperature_c": 20.0, "time_h": 0.0}
THERMAL_VARIABLES = tuple(CONDITIONS)
RUN_KEYS = {"run", "channel", "up", "travel", "start", "direction", "line", "method"}


@dataclass(frozen=True)
class MachineFile:
    """A machine file read back: the model, the conditions its thermal elements are evaluated at
    (``temperature_c``, ``time_h``) and notes for the reader (e.g. data not covering a range)."""

    path: Path
    model: MachineModel
    conditions: dict[str, float]
    notes: tuple[str, ...] = field(default_factory=tuple)


def load_machine(path: Path | str, *, conditions: dict[str, float | None] | None = None) -> MachineFile:
    """Read and validate ``path``; ``conditions`` (None values ignored) override the file's [conditions]."""
    path = Path(path)
    if not path.is_file():
        raise SetupError(f"{path}: no such machine file" + (" (it is a directory)" if path.is_dir() else ""))
    data = read_toml(path)
    return machine_from_dict(data, str(path), base_dir=path.parent, overrides=conditions)


def machine_from_dict(data: dict[str, Any], source: str, *, base_dir: Path = Path("."),
                      overrides: dict[str, float | None] | None = None) -> MachineFile:
    top = TomlTable(source, "", data, EXAMPLE)
    kind = top.get("kind", str, "machine")
    if kind != "machine":
        raise SetupError(f"{source}: kind is {kind!r}; guideway volumetric needs a machine file (kind = \"machine\")")
    name = top.get("name", str, "")
    cond_t = top.table("conditions")
    conds = {k: _finite(cond_t, k, v) for k, v in CONDITIONS.items()}
    for k, v in (overrides or {}).items():
        if v is not None:
            conds[k] = float(v)
    tool_t = top.table("tool")
    tool_offset = tool_t.vector("offset_mm", 3, [0.0, 0.0, 0.0])
    frame_t = top.table("frame")
    reader = _Reader(source, base_dir)
    chains: dict[str, list[Body]] = {}
    raw: list[tuple[Body, TomlTable]] = []
    for chain in ("workpiece", "tool"):
        items = top.get(f"{chain}_chain", list, [])
        chains[chain] = []
        for i, item in enumerate(items):
            t = TomlTable(source, f"{chain}_chain {i + 1}", item, EXAMPLE)
            body = reader.body(t, chain)
            t.name = f"{chain}_chain {body.name}"
            chains[chain].append(body)
            raw.append((body, t))
    if not raw:
        raise SetupError(f"{source}: no bodies; give [[workpiece_chain]] and/or [[tool_chain]] tables "
                         f"(see {EXAMPLE})")
    elements: list[Element] = []
    for body, t in raw:
        elements += reader.body_elements(body, t)
    primary = frame_t.get("primary", str, None)
    secondary = frame_t.get("secondary", str, None)
    bodies = tuple(chains["workpiece"] + chains["tool"])
    squareness = top.get("squareness", list, [])
    if squareness and (primary is None or secondary is None):
        raise SetupError(f"{source}: [frame] primary and secondary are needed for squareness terms (seed 002: "
                         "the primary axis defines its direction, the secondary lies in their plane)")
    for i, item in enumerate(squareness):
        sq = TomlTable(source, f"squareness {i + 1}", item, EXAMPLE)
        pair = sq.get("axes", list, required=True)
        if len(pair) != 2 or not all(isinstance(n, str) for n in pair):
            raise SetupError(f"{source}: [squareness {i + 1}] axes must be two axis names, got {pair!r}")
        value = _finite(sq, "value_urad", required=True)
        sq.check_unknown()
        try:
            elements.append(squareness_element(bodies, (pair[0], pair[1]), value, primary, secondary))  # type: ignore[arg-type]
        except ValueError as exc:
            raise SetupError(f"{source}: [squareness {i + 1}] {exc}") from None
    for t in (top, cond_t, tool_t, frame_t):
        t.check_unknown()
    try:
        model = MachineModel(tuple(chains["workpiece"]), tuple(chains["tool"]), tuple(elements),
                             tool_offset, name, primary, secondary)  # type: ignore[arg-type]
    except ValueError as exc:
        raise SetupError(f"{source}: {exc}") from None
    return MachineFile(Path(source), model, conds, tuple(reader.notes))


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and bool(np.isfinite(v))


def _finite(t: TomlTable, key: str, default: Any = ..., *, required: bool = False) -> float:
    """A number of the table (TOML allows nan and inf, which would make every result nan)."""
    v = t.get(key, float, default, required=required)
    if not np.isfinite(v):
        raise SetupError(f"{t.source}: [{t.name}] {key} must be a finite number, got {v!r}")
    return float(v)


class _Reader:
    """Parses bodies and element sources; collects notes."""

    def __init__(self, source: str, base_dir: Path) -> None:
        self.source, self.base_dir = source, base_dir
        self.cache = RunCache()
        self.notes: list[str] = []

    def fail(self, where: str, message: str) -> SetupError:
        return SetupError(f"{self.source}: {where}: {message}")

    def sub_table(self, t: TomlTable, key: str) -> TomlTable:
        """``[<chain>_chain.<key>]`` of one body, named after the body in messages."""
        t.used.add(key)
        return TomlTable(self.source, f"{t.name} {key}", t.data.get(key, {}), EXAMPLE)

    def body(self, t: TomlTable, chain: str) -> Body:
        name = t.get("name", str, required=True)
        if not name.isidentifier():
            raise self.fail(f"[{t.name}]", f"name {name!r} must be a plain identifier (letters, digits, _)")
        kind = t.get("type", str, required=True)
        if kind not in ("prismatic", "rotary", "fixed"):
            raise self.fail(f"[{t.name}]", f"type must be prismatic, rotary or fixed, got {kind!r}")
        offset = t.vector("offset_mm", 3, [0.0, 0.0, 0.0])
        if kind == "fixed":
            for key in ("direction", "range", "reference"):
                if key in t.data:
                    raise self.fail(f"[{t.name}]", f"{key}: a fixed body ({name}) does not move")
            return Body(name, kind, chain, offset_mm=offset)  # type: ignore[arg-type]
        try:
            axis, sign = signed_axis(t.get("direction", str, required=True))
        except ValueError as exc:
            raise self.fail(f"[{t.name}]", f"direction: {exc}") from None
        lo, hi = t.vector("range", 2)
        if not lo < hi:
            raise self.fail(f"[{t.name}]", f"range must be [low, high] with low < high, got {[lo, hi]}")
        reference = t.get("reference", float, min(max(0.0, lo), hi))
        if not lo <= reference <= hi:
            raise self.fail(f"[{t.name}]", f"reference {reference:g} lies outside the range {lo:g} … {hi:g}")
        return Body(name, kind, chain, axis, sign, offset, (lo, hi), reference)  # type: ignore[arg-type]

    def body_elements(self, body: Body, t: TomlTable) -> list[Element]:
        out: list[Element] = []
        errors, location, thermal = (self.sub_table(t, key) for key in ("errors", "location", "thermal"))
        t.check_unknown()
        if body.moving:
            for c in COMPONENTS:  # all six error motions of an axis are elements, zero when not given
                if c in errors.data:
                    curve, variable, text = self.source_curve(errors.get(c, (int, float, dict)),
                                                              f"[{t.name}] errors.{c}",
                                                              body, c, thermal=False)
                else:
                    curve, variable, text = Constant(0.0), "constant", "zero (not given)"
                out.append(component_element(body, c, "motion", curve, variable, text))
            errors.used.update(COMPONENTS)
        elif errors.data:
            raise self.fail(f"[{t.name}] errors", f"{body.name} is fixed; it has no error motions (use location)")
        errors.check_unknown()
        if location.data and body.kind == "prismatic":
            raise self.fail(f"[{t.name}] location", f"{body.name} is prismatic: its direction errors are squareness "
                            "terms ([[squareness]]), a constant offset has no effect on its motion")
        for c in COMPONENTS:
            if c in location.data:
                v = _finite(location, c)
                out.append(component_element(body, c, "location", Constant(v), "constant", "scalar"))
        location.check_unknown()
        for c in COMPONENTS:
            if c in thermal.data:
                curve, variable, text = self.source_curve(thermal.get(c, dict), f"[{t.name}] thermal.{c}", body, c,
                                                          thermal=True)
                out.append(component_element(body, c, "thermal", curve, variable, text))
        thermal.check_unknown()
        return out

    def source_curve(self, spec: Any, where: str, body: Body, component: str, *, thermal: bool
                     ) -> tuple[Curve, str, str]:
        """(curve, variable, description) of one element source: a number, a table, a polynomial
        or a run channel (motion errors only); thermal sources name their variable with ``of``."""
        if _number(spec) and not thermal:  # thermal sources are tables (their variable is named)
            return Constant(float(spec)), "constant", "zero" if spec == 0 else "constant"
        if not isinstance(spec, dict):
            raise self.fail(where, f"must be a number or a table {{...}}, got {spec!r}")
        variable = "position"
        if thermal:
            variable = spec.get("of")
            if variable not in THERMAL_VARIABLES:
                raise self.fail(where, f"of must be one of {', '.join(THERMAL_VARIABLES)}, got {variable!r}")
        elif "of" in spec:
            raise self.fail(where, "of: error motions are functions of the axis position (thermal elements go in "
                            "[...thermal])")
        keys = set(spec) - {"of"}
        try:
            if "run" in keys:
                if thermal:
                    raise self.fail(where, "a thermal element cannot come from a run")
                curve, text = self.run_source(spec, where, body, component)
                return curve, variable, text
            if keys == {"positions", "values"}:
                curve: Curve = Table(tuple(map(float, spec["positions"])), tuple(map(float, spec["values"])))
            elif keys in ({"poly"}, {"poly", "origin"}):
                curve = Polynomial(tuple(map(float, spec["poly"])), float(spec.get("origin", 0.0)))
            else:
                raise self.fail(where, f"unknown source keys {sorted(keys)}; give positions + values, poly "
                                "[+ origin] or run + channel")
        except (TypeError, ValueError) as exc:
            raise self.fail(where, str(exc)) from None
        self._check_cover(curve, body, where, variable)
        return curve, variable, curve.describe()

    def run_source(self, spec: dict[str, Any], where: str, body: Body, component: str) -> tuple[Curve, str]:
        unknown = set(spec) - RUN_KEYS
        if unknown:
            raise self.fail(where, f"unknown key {sorted(unknown)[0]!r} for a run source; use "
                            f"{', '.join(sorted(RUN_KEYS))}")
        channel = spec.get("channel")
        if channel not in CHANNELS:
            raise self.fail(where, f"channel must be one of {', '.join(CHANNELS)}, got {channel!r}")
        line = spec.get("line", "least_squares")
        if line not in LINES:
            raise self.fail(where, f"line must be one of {', '.join(LINES)}, got {line!r}")
        start = spec.get("start", 0.0)
        if not _number(start):
            raise self.fail(where, f"start must be a number (the axis position of the run's first station), "
                            f"got {start!r}")
        method = spec.get("method", DEFAULT_METHOD)
        if method not in METHODS:
            raise self.fail(where, f"method must be one of {', '.join(METHODS)}, got {method!r}")
        path = self.base_dir / str(spec["run"])
        travel, up = self._run_frame(spec, where, body)
        rotation, vec = (True, body.direction) if body.kind == "rotary" else channel_vector(channel, travel, up)
        k = COMPONENTS.index(component)
        want = unit_vector(k % 3)
        if rotation != (k >= 3) or abs(float(vec @ want)) != 1.0:
            gives = ("E" + "ABC"[int(np.argmax(np.abs(vec)))]) if rotation else ("E" + AXIS_LETTERS[int(np.argmax(
                np.abs(vec)))])
            raise self.fail(where, f"channel {channel} of this run measures {gives} of axis {body.name} (run frame: "
                            f"travel {_axis_text(travel)}, up {_axis_text(up)}), not {component}; put it under "
                            f"{gives} or correct up/travel")
        try:
            rc = run_curve(self.cache, path, channel, axis_kind=body.kind, where=f"{self.source}: {where}",
                           direction=str(spec.get("direction", "mean")), line=str(line),
                           method=method, start=float(start),
                           travel_sign=float(travel @ body.direction) if body.kind == "prismatic" else 1.0)
        except SetupError:
            raise
        except UserError as exc:  # the run itself is unreadable: say which element wanted it
            raise self.fail(where, str(exc)) from None
        sign = float(vec @ want)
        curve = Table(tuple(rc.positions), tuple(sign * rc.values))
        self._check_cover(curve, body, where, "position")
        return curve, rc.text + ("" if sign > 0 else f", times −1: the run's {channel} axis is −{component[1]}")

    def _run_frame(self, spec: dict[str, Any], where: str, body: Body) -> tuple[np.ndarray, np.ndarray]:
        """The run's travel and up directions in the machine frame (previous body's axes)."""
        if body.kind == "rotary":
            return body.direction, unit_vector(1)
        try:
            travel = unit_vector(*signed_axis(str(spec.get("travel", body.direction_text()))))
        except ValueError as exc:
            raise self.fail(where, f"travel: {exc}") from None
        if abs(float(travel @ body.direction)) != 1.0:
            raise self.fail(where, f"travel {_axis_text(travel)} is not along the axis {body.name} "
                            f"({body.direction_text()})")
        default_up = None if travel[1] != 0 else "+Y"
        if default_up is None and spec.get("channel") == "linear":
            default_up = "+Z"  # the linear channel lies along the travel, whatever the run's up was
        up_text = spec.get("up", default_up)
        if up_text is None:
            raise self.fail(where, f"up: the run travels along {_axis_text(travel)}; say which machine axis the "
                            "run's Y (its 'up') was, e.g. up = \"+X\"")
        try:
            up = unit_vector(*signed_axis(str(up_text)))
        except ValueError as exc:
            raise self.fail(where, f"up: {exc}") from None
        if float(up @ travel) != 0.0:
            raise self.fail(where, f"up {up_text} must be perpendicular to the travel {_axis_text(travel)}")
        return travel, up

    def _check_cover(self, curve: Curve, body: Body, where: str, variable: str) -> None:
        if variable != "position" or curve.domain is None or body.range is None:
            return
        lo, hi = curve.domain
        if lo > body.range[0] + 1e-9 or hi < body.range[1] - 1e-9:
            self.notes.append(f"{where}: data cover {lo:g} … {hi:g} {body.unit} of the range "
                              f"{body.range[0]:g} … {body.range[1]:g}; the end values are held outside")


def _axis_text(v: np.ndarray) -> str:
    k = int(np.argmax(np.abs(v)))
    return f"{'+' if v[k] > 0 else '-'}{AXIS_LETTERS[k]}"
