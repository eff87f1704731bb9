"""The volumetric error over a grid of the workspace, and at one pose, from a machine file.

The grid spans the prismatic axes, ``count`` equidistant positions over each range; rotary axes
(and any axis fixed with ``--set AXIS=VALUE``) stay at one position, their reference unless set
(with every prismatic axis held, the free rotary axes are gridded).
Totals come from the chosen method (first-order or exact); the contributions of elements and of
axes (groups) are first order and add up to the first-order total.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from processing.volumetric.chain import element_values
from processing.volumetric.evaluate import (
    ElementSummary,
    VolumetricError,
    contribution_summary,
    contributions,
    evaluate,
    first_order,
)
from processing.volumetric.model import Element, MachineModel

from ..errors import UserError
from .machine_file import MachineFile

MAX_POSES = 2_000_000  # memory bound of one evaluation (about 1 GB of temporaries)
COMPONENT_COLUMNS = ("dx_um", "dy_um", "dz_um")
ORIENTATION_COLUMNS = ("ex_urad", "ey_urad", "ez_urad")
CONVENTIONS = (
    "Error = actual − nominal pose of the tool point relative to the workpiece (seed 000's ΔE = T37 − T37,i): "
    "position in µm, orientation as R = Rz(εz)·Ry(εy)·Rx(εx) in µrad, in the workpiece frame (or the machine "
    "frame with --frame machine). Element signs and the chain convention: docs/volumetric.md."
)


def group_of(e: Element) -> str:
    """The contribution group of an element: its axis (motion, location), squareness or thermal."""
    return e.body if e.group in ("motion", "location") else e.group


def column_name(axis: Any) -> str:
    return f"{axis.name}_{axis.unit}"


def parse_settings(model: MachineModel, settings: Sequence[str]) -> dict[str, float]:
    """``AXIS=VALUE`` strings (``--set``) → {axis: value}, checked against the axes and their ranges."""
    out: dict[str, float] = {}
    names = {a.name: a for a in model.axes}
    for s in settings:
        name, sep, value = s.partition("=")
        if not sep or name.strip() not in names:
            raise UserError(f"--set {s!r}: use AXIS=VALUE with one of the axes {', '.join(names)}")
        try:
            v = float(value)
        except ValueError:
            raise UserError(f"--set {s!r}: {value!r} is not a number") from None
        out[name.strip()] = _in_range(names[name.strip()], v, f"--set {s}")
    return out


def _in_range(axis: Any, v: float, what: str) -> float:
    lo, hi = axis.range
    if not (math.isfinite(v) and lo - 1e-9 <= v <= hi + 1e-9):
        raise UserError(f"{what}: {v:g} {axis.unit} is outside the range of {axis.name} ({lo:g} … {hi:g} "
                        f"{axis.unit}); the model knows nothing there")
    return v


def grid_positions(model: MachineModel, count: int, fixed: Mapping[str, float]
                   ) -> tuple[list[str], dict[str, np.ndarray]]:
    """(names of the gridded axes, positions of every moving axis): flat arrays for the gridded
    axes — the free prismatic axes, or the free rotary axes when no prismatic axis is free — and 0-d
    arrays for the others (so a fixed rotation is computed once)."""
    if count < 2:
        raise UserError(f"--grid {count}: need at least 2 points per axis")
    free = [a for a in model.axes if a.name not in fixed]
    gridded = [a for a in free if a.kind == "prismatic"] or free  # no prismatic axis free: the rotary ones
    if not gridded:
        raise UserError("every axis is fixed with --set; leave one free, or use --at for one pose")
    if count ** len(gridded) > MAX_POSES:
        raise UserError(f"--grid {count} over {len(gridded)} axes gives {count ** len(gridded)} poses; "
                        f"the limit is {MAX_POSES}, use a smaller --grid")
    axes = np.meshgrid(*(np.linspace(a.range[0], a.range[1], count) for a in gridded), indexing="ij")
    positions = {a.name: g.ravel() for a, g in zip(gridded, axes, strict=True)}
    for a in model.axes:
        if a.name not in positions:
            positions[a.name] = np.asarray(float(fixed.get(a.name, a.reference)))
    return [a.name for a in gridded], positions


def flat_positions(positions: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Every axis's positions as one flat array per pose."""
    n = max((np.size(v) for v in positions.values()), default=1)
    return {k: np.broadcast_to(np.ravel(v), (n,)) if np.size(v) == 1 else np.ravel(v) for k, v in positions.items()}


@dataclass
class FieldResult:
    """The error over a set of poses with its first-order breakdown."""

    machine: MachineFile
    method: str
    frame: str
    positions: dict[str, np.ndarray]
    error: VolumetricError
    groups: dict[str, np.ndarray]                 # group -> position contribution (n, 3) µm
    elements: list[ElementSummary]                # largest contribution first
    first_order_gap_um: float | None = None       # max |exact − first-order| (exact only)
    gridded: list[str] = field(default_factory=list)
    count: int = 0

    @property
    def model(self) -> MachineModel:
        return self.machine.model

    def pose(self, i: int) -> dict[str, float]:
        flat = flat_positions(self.positions)
        return {a.name: float(flat[a.name][i]) for a in self.model.axes}

    def table(self) -> pd.DataFrame:
        """One row per pose: positions, the error components, |d| and the orientation error."""
        flat = flat_positions(self.positions)
        cols: dict[str, np.ndarray] = {column_name(a): flat[a.name] for a in self.model.axes}
        for i, c in enumerate(COMPONENT_COLUMNS):
            cols[c] = self.error.position_um[:, i]
        cols["d_um"] = self.error.distance_um
        for i, c in enumerate(ORIENTATION_COLUMNS):
            cols[c] = self.error.orientation_urad[:, i]
        return pd.DataFrame(cols)

    def contribution_table(self) -> pd.DataFrame:
        flat = flat_positions(self.positions)
        cols: dict[str, np.ndarray] = {column_name(a): flat[a.name] for a in self.model.axes}
        for g, d in self.groups.items():
            for i, c in enumerate(COMPONENT_COLUMNS):
                cols[f"{g}_{c}"] = d[:, i]
        return pd.DataFrame(cols)


def evaluate_field(machine: MachineFile, positions: dict[str, np.ndarray], *, method: str = "first-order",
                   frame: str = "workpiece", gridded: Sequence[str] = (), count: int = 0) -> FieldResult:
    """Totals by ``method`` and the first-order contributions at the poses ``positions`` (flat arrays;
    ``gridded`` and ``count`` describe the grid they came from, :func:`grid_positions`)."""
    model = machine.model
    summary = contribution_summary(model, positions, machine.conditions, group_of, frame)
    gap = None
    total = summary.total
    if method == "exact":
        total = evaluate(model, positions, machine.conditions, method="exact", frame=frame)
        gap = float(np.max(np.linalg.norm(total.position_um - summary.total.position_um, axis=-1), initial=0.0))
    stats = sorted(summary.elements, key=lambda s: (-s.max_position_um, -s.max_orientation_urad))
    return FieldResult(machine, method, frame, positions, total, summary.groups, stats, gap, list(gridded), count)


def _extreme(values: np.ndarray, result: FieldResult) -> dict[str, Any]:
    lo, hi = int(np.argmin(values)), int(np.argmax(values))
    return {"min": float(values[lo]), "min_pose": result.pose(lo), "max": float(values[hi]),
            "max_pose": result.pose(hi)}


def field_summary(result: FieldResult) -> dict[str, Any]:
    """The summary.json object of a grid (docs/volumetric.md, "Output")."""
    m = result.machine
    err = result.error
    dist = err.distance_um
    comps = {c: _extreme(err.position_um[:, i], result) for i, c in enumerate(COMPONENT_COLUMNS)}
    comps.update({c: _extreme(err.orientation_urad[:, i], result) for i, c in enumerate(ORIENTATION_COLUMNS)})
    far = int(np.argmax(dist))
    return {
        "kind": "volumetric",
        "machine": m.model.name,
        "file": str(m.path),
        "method": result.method,
        "frame": result.frame,
        "conditions": m.conditions,
        "grid": {"points_per_axis": result.count, "gridded_axes": result.gridded, "poses": len(dist),
                 "fixed": {a.name: float(np.ravel(result.positions[a.name])[0]) for a in m.model.axes
                           if a.name not in result.gridded}},
        "elements": m.model.counts(),
        "max_distance_um": {"value": float(dist[far]), "pose": result.pose(far),
                            "error_um": [float(v) for v in err.position_um[far]]},
        "rms_distance_um": float(np.sqrt(np.mean(dist ** 2))),
        "components": comps,
        "contributions_um": {g: {"max": float(np.max(np.linalg.norm(d, axis=-1))),
                                 "rms": float(np.sqrt(np.mean(np.sum(d ** 2, axis=-1))))}
                             for g, d in result.groups.items()},
        "element_ranking": [element_row(s) for s in result.elements],
        "exact_minus_first_order_um": result.first_order_gap_um,
        "notes": list(m.notes),
        "conventions": CONVENTIONS,
    }


def element_row(s: ElementSummary) -> dict[str, Any]:
    e = s.element
    return {"element": e.id, "group": e.group, "body": e.body, "unit": e.unit, "source": e.source,
            "max_position_um": s.max_position_um, "max_orientation_urad": s.max_orientation_urad,
            "rms_position_um": s.rms_position_um}


def pose_positions(model: MachineModel, values: Sequence[str]) -> dict[str, float]:
    """``--at`` values: numbers in axis order (``model.axes``) or ``AXIS=VALUE``; others at their reference."""
    axes = model.axes
    names = [a.name for a in axes]
    out = {a.name: a.reference for a in axes}
    plain = [v for v in values if "=" not in v]
    if plain and len(plain) != len(values):
        raise UserError("--at: give either numbers in axis order or AXIS=VALUE pairs, not both")
    if len(plain) > len(axes):
        raise UserError(f"--at: {len(plain)} values for {len(axes)} axes ({' '.join(names)})")
    if plain:
        pairs = [(n, v) for n, v in zip(names, plain, strict=False)]
    else:
        pairs = [tuple(v.split("=", 1)) for v in values]  # type: ignore[misc]
    by_name = dict(zip(names, axes, strict=True))
    given = [name for name, _ in pairs]
    twice = [n for n in names if given.count(n) > 1]
    if twice:
        raise UserError(f"--at: axis {twice[0]} is given twice; give each axis once")
    for name, text in pairs:
        if name not in by_name:
            raise UserError(f"--at {name}={text}: no axis {name!r}; the axes are {' '.join(names)}")
        try:
            v = float(text)
        except ValueError:
            raise UserError(f"--at: {text!r} is not a number (axis {name})") from None
        out[name] = _in_range(by_name[name], v, f"--at {name}")
    return out


def at_pose(machine: MachineFile, values: Sequence[str], *, method: str = "first-order",
            frame: str = "workpiece") -> dict[str, Any]:
    """The error at one pose with every element's contribution, largest first (the ``--at --json`` object)."""
    model = machine.model
    pose = pose_positions(model, values)
    err = evaluate(model, pose, machine.conditions, method=method, frame=frame)
    fo = first_order(model, pose, machine.conditions, frame)
    rows = []
    for e, d, w in contributions(model, pose, machine.conditions, frame):
        value = float(np.ravel(_value_at(e, pose, machine.conditions))[0])
        rows.append({"element": e.id, "group": e.group, "body": e.body, "value": value, "unit": e.unit,
                     "source": e.source, **_vector(d, w)})
    rows.sort(key=lambda r: (-r["d_um"], -r["e_urad"]))
    out = {"kind": "volumetric-pose", "machine": model.name, "file": str(machine.path), "pose": pose,
           "units": {a.name: a.unit for a in model.axes}, "method": method, "frame": frame,
           "conditions": machine.conditions, "error": _vector(err.position_um, err.orientation_urad),
           "contributions": rows, "dominant": [r["element"] for r in rows[:5] if r["d_um"] > 0 or r["e_urad"] > 0],
           "notes": list(machine.notes), "conventions": CONVENTIONS}
    if method == "exact":
        out["first_order"] = _vector(fo.position_um, fo.orientation_urad)
    return out


def _value_at(e: Element, pose: Mapping[str, float], conditions: Mapping[str, float]) -> np.ndarray:
    return element_values(e, {k: np.asarray(v) for k, v in pose.items()}, conditions)


def _vector(d: np.ndarray, w: np.ndarray) -> dict[str, float]:
    d, w = np.ravel(d), np.ravel(w)
    return {"dx_um": float(d[0]), "dy_um": float(d[1]), "dz_um": float(d[2]), "d_um": float(np.linalg.norm(d)),
            "ex_urad": float(w[0]), "ey_urad": float(w[1]), "ez_urad": float(w[2]),
            "e_urad": float(np.linalg.norm(w))}
