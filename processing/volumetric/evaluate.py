"""Volumetric error of the tool relative to the workpiece: first-order (with the contribution of
every element) and exact, vectorised over poses.

The error at a pose is the actual minus the nominal position of the tool point in the workpiece
frame, P = T_w⁻¹ · T_t · tool_offset (µm), and the rotation from the nominal to the actual tool
orientation, R_rel,actual · R_rel,nominalᵀ = Rz(εz)·Ry(εy)·Rx(εx) (µrad), expressed in the
``workpiece`` frame (seed 000's ΔE = T37 − T37,i) or rotated into the ``machine`` frame (the axes
of the base, for per-axis compensation).  ``positions`` maps every moving axis to its positions
(mm or deg), arrays broadcasting to one shape; ``conditions`` holds ``temperature_c`` and
``time_h`` for the thermal elements.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import components as cp
from .chain import (
    UM,
    URAD,
    ChainWalk,
    body_error_sums,
    element_values,
    tool_point,
    walk_chain,
    walk_exact,
)
from .model import Element, MachineModel
from .rotations import apply, apply_transposed

FRAMES = ("workpiece", "machine")
METHODS = ("first-order", "exact")


@dataclass(frozen=True)
class VolumetricError:
    """Position error (µm) and orientation error (µrad, about X, Y, Z), arrays ``shape + (3,)``."""

    position_um: np.ndarray
    orientation_urad: np.ndarray
    frame: str

    @property
    def distance_um(self) -> np.ndarray:
        return np.linalg.norm(self.position_um, axis=-1)


@dataclass(frozen=True)
class Nominal:
    """The nominal chains at the poses: every body's carrying frame, the tool point, the workpiece frame."""

    workpiece: ChainWalk
    tool: ChainWalk
    tool_point: np.ndarray
    shape: tuple[int, ...]
    positions: dict[str, np.ndarray]

    @property
    def workpiece_rotation(self) -> np.ndarray:
        return self.workpiece.end[0]


def nominal(model: MachineModel, positions: Mapping[str, np.ndarray | float]) -> Nominal:
    """Walk both nominal chains at the positions (kept as given: a constant axis stays 0-d, so its
    rotation is computed once); KeyError names a missing axis."""
    missing = [a.name for a in model.axes if a.name not in positions]
    if missing:
        raise KeyError(f"no position for axis {missing[0]}")
    arrays = {a.name: np.asarray(positions[a.name], dtype=float) for a in model.axes}
    shape = np.broadcast_shapes(*(v.shape for v in arrays.values())) if arrays else ()
    wp = walk_chain(model.workpiece, arrays)
    tl = walk_chain(model.tool, arrays)
    return Nominal(wp, tl, np.broadcast_to(tool_point(tl, model.tool_offset_mm), shape + (3,)), shape, arrays)


def _check_frame(frame: str) -> None:
    if frame not in FRAMES:
        raise ValueError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")


def _rotary_workpiece(model: MachineModel) -> bool:
    return any(b.kind == "rotary" for b in model.workpiece)


def displacement(model: MachineModel, nom: Nominal, e: Element, conditions: Mapping[str, float],
                 levers: dict[str, cp.Vec] | None = None) -> tuple[cp.Vec, cp.Vec]:
    """First-order change of the tool point relative to the workpiece (mm) and of the relative
    orientation (rad) caused by ``e``, in machine-frame axes, component-wise: + for a tool-chain
    element, − for a workpiece-chain one (it moves the workpiece point under the tool).
    ``levers`` caches the tool point's offset from each body's carrying frame."""
    body = model.body(e.body)
    walk = nom.workpiece if body.chain == "workpiece" else nom.tool
    r_f, o_f = walk.carrying[body.name]
    sign = -1.0 if body.chain == "workpiece" else 1.0
    v = element_values(e, nom.positions, conditions) * sign
    vec = np.asarray(e.vector, dtype=float)
    zero: cp.Vec = [0.0, 0.0, 0.0]
    if e.kind == "translation":
        return cp.scaled(apply(r_f, vec), v * UM), zero
    if e.kind == "rotation":
        w = cp.scaled(apply(r_f, vec), v * URAD)
        levers = {} if levers is None else levers
        if body.name not in levers:
            levers[body.name] = cp.split(nom.tool_point - o_f)
        return cp.cross(w, levers[body.name]), w
    # squareness: travel q times the tilt of the motion direction
    return cp.scaled(apply(r_f, np.cross(vec, body.direction)), nom.positions[body.name] * v * URAD), zero


def base_displacement(model: MachineModel, nom: Nominal, e: Element, conditions: Mapping[str, float]
                      ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`displacement` as two arrays ``nom.shape + (3,)`` (mm, rad)."""
    d, w = displacement(model, nom, e, conditions)
    return cp.stack(d, nom.shape), cp.stack(w, nom.shape)


def contributions(model: MachineModel, positions: Mapping[str, np.ndarray | float],
                  conditions: Mapping[str, float], frame: str = "workpiece"
                  ) -> Iterator[tuple[Element, np.ndarray, np.ndarray]]:
    """(element, position error µm, orientation error µrad) of every element, to first order.

    The contributions add up to :func:`first_order`."""
    _check_frame(frame)
    nom = nominal(model, positions)
    rotate = frame == "workpiece" and _rotary_workpiece(model)
    full = nom.shape + (3,)
    for e in model.elements:
        d, w = base_displacement(model, nom, e, conditions)
        if rotate:
            d, w = apply_transposed(nom.workpiece_rotation, d), apply_transposed(nom.workpiece_rotation, w)
        yield e, np.broadcast_to(d * 1e3, full), np.broadcast_to(w * 1e6, full)


@dataclass(frozen=True)
class ElementSummary:
    """How much one element contributes over the poses (first order): the largest and RMS length of
    its position contribution (µm) and the largest of its orientation contribution (µrad)."""

    element: Element
    max_position_um: float
    max_orientation_urad: float
    rms_position_um: float


@dataclass(frozen=True)
class ContributionSummary:
    total: VolumetricError        # first order, = the sum of the groups
    groups: dict[str, np.ndarray]  # group -> its position contribution, shape + (3,), µm
    elements: list[ElementSummary]  # in the model's order


def contribution_summary(model: MachineModel, positions: Mapping[str, np.ndarray | float],
                         conditions: Mapping[str, float], group: Callable[[Element], str],
                         frame: str = "workpiece") -> ContributionSummary:
    """The first-order error, the contribution of each group of elements (``group(element)`` names
    it) and each element's size, in one pass without keeping every element's field (lengths do
    not depend on the frame, so only the sums are turned into the workpiece frame)."""
    _check_frame(frame)
    nom = nominal(model, positions)
    groups: dict[str, cp.Vec] = {}
    w_total: cp.Vec = [0.0, 0.0, 0.0]
    levers: dict[str, cp.Vec] = {}
    stats = []
    for e in model.elements:
        d, w = displacement(model, nom, e, conditions, levers)
        acc = groups.setdefault(group(e), [0.0, 0.0, 0.0])
        for k in range(3):
            acc[k] = cp.add(acc[k], d[k])
            w_total[k] = cp.add(w_total[k], w[k])
        dn, wn = np.asarray(cp.norm(d)), np.asarray(cp.norm(w))
        stats.append(ElementSummary(e, float(np.max(dn)) * 1e3, float(np.max(wn)) * 1e6,
                                    math.sqrt(float(np.mean(dn * dn))) * 1e3))  # a constant: its one value
    sums = {g: cp.stack(v, nom.shape) for g, v in groups.items()}
    d_total = sum(sums.values(), np.zeros(nom.shape + (3,)))
    w_sum = cp.stack(w_total, nom.shape)
    if frame == "workpiece" and _rotary_workpiece(model):
        r = nom.workpiece_rotation
        sums = {g: apply_transposed(r, v) for g, v in sums.items()}
        d_total, w_sum = apply_transposed(r, d_total), apply_transposed(r, w_sum)
    return ContributionSummary(VolumetricError(d_total * 1e3, w_sum * 1e6, frame),
                               {g: v * 1e3 for g, v in sums.items()}, stats)


def first_order(model: MachineModel, positions: Mapping[str, np.ndarray | float],
                conditions: Mapping[str, float], frame: str = "workpiece") -> VolumetricError:
    """The volumetric error linear in every element (the sum of the contributions, computed per body:
    its summed translation δ, rotation ε and squareness tilt θ at its carrying frame F give
    R_F δ + (R_F ε) × (x_tool − o_F) + q·R_F (θ × u), with the chain's sign)."""
    _check_frame(frame)
    nom = nominal(model, positions)
    sums = body_error_sums(model.bodies, model.elements, nom.positions, conditions)
    d: cp.Vec = [0.0, 0.0, 0.0]
    w: cp.Vec = [0.0, 0.0, 0.0]
    for b in model.bodies:
        e = sums[b.name]
        r_f, o_f = (nom.workpiece if b.chain == "workpiece" else nom.tool).carrying[b.name]
        sign = -1.0 if b.chain == "workpiece" else 1.0
        wb = cp.rotate(r_f, [cp.add(x, y) for x, y in zip(e["error_r"], e["location_r"], strict=True)])
        db = cp.rotate(r_f, [cp.add(x, y) for x, y in zip(e["error_t"], e["location_t"], strict=True)])
        if any(not isinstance(c, float) or c for c in wb):
            db = [cp.add(x, y) for x, y in zip(db, cp.cross(wb, cp.split(nom.tool_point - o_f)), strict=True)]
        if b.kind == "prismatic":
            tilt = cp.rotate(r_f, cp.cross(e["tilt"], list(b.direction)))
            db = [cp.add(x, cp.mul(y, nom.positions[b.name])) for x, y in zip(db, tilt, strict=True)]
        d = [cp.add(x, cp.mul(sign, y)) for x, y in zip(d, db, strict=True)]
        w = [cp.add(x, cp.mul(sign, y)) for x, y in zip(w, wb, strict=True)]
    dv, wv = cp.stack(d, nom.shape), cp.stack(w, nom.shape)
    if frame == "workpiece" and _rotary_workpiece(model):
        dv, wv = apply_transposed(nom.workpiece_rotation, dv), apply_transposed(nom.workpiece_rotation, wv)
    return VolumetricError(dv * 1e3, wv * 1e6, frame)


def exact(model: MachineModel, positions: Mapping[str, np.ndarray | float], conditions: Mapping[str, float],
          frame: str = "workpiece") -> VolumetricError:
    """The volumetric error from the full product of the error transforms (no small-angle step)."""
    _check_frame(frame)
    arrays = {a.name: np.asarray(positions[a.name], dtype=float) for a in model.axes}
    shape = np.broadcast_shapes(*(v.shape for v in arrays.values())) if arrays else ()
    sums = body_error_sums(model.bodies, model.elements, arrays, conditions)
    tool = list(model.tool_offset_mm)
    relative = []
    for errors in (None, sums):
        rw, ow = walk_exact(model.workpiece, arrays, errors)
        rt, ot = walk_exact(model.tool, arrays, errors)
        p = cp.mat_t_vec(rw, cp.vec_sub(cp.vec_add(ot, cp.mat_vec(rt, tool)), ow))
        rel = [[rw[0][i] * rt[0][k] + rw[1][i] * rt[1][k] + rw[2][i] * rt[2][k] for k in range(3)]
               for i in range(3)]  # R_wᵀ R_t
        relative.append((p, rel, rw))
    (p0, rel0, rw0), (p1, rel1, _) = relative

    def turn(i: int, k: int) -> Any:  # ΔR = (R_rel,actual · R_rel,nominalᵀ)[i][k]
        return rel1[i][0] * rel0[k][0] + rel1[i][1] * rel0[k][1] + rel1[i][2] * rel0[k][2]

    d = cp.vec_sub(p1, p0)
    delta_r: cp.Mat = [[turn(i, k) for k in range(3)] for i in range(3)]
    if frame == "machine":
        # The error rotation is a matrix, not a vector: in the machine frame it is
        # R_W,nom · ΔR · R_W,nomᵀ, whose Z-Y-X angles differ from R_W,nom applied to ΔR's angles
        # at second order (docs/volumetric.md, "Frames").
        d = cp.mat_vec(rw0, d)
        delta_r = cp.mat_mul(cp.mat_mul(rw0, delta_r), [[rw0[k][i] for k in range(3)] for i in range(3)])
    w = [np.arctan2(delta_r[2][1], delta_r[2][2]), -np.arcsin(np.clip(delta_r[2][0], -1.0, 1.0)),
         np.arctan2(delta_r[1][0], delta_r[0][0])]
    return VolumetricError(cp.stack(d, shape) * 1e3, cp.stack(w, shape) * 1e6, frame)


def evaluate(model: MachineModel, positions: Mapping[str, np.ndarray | float], conditions: Mapping[str, float],
             *, method: str = "first-order", frame: str = "workpiece") -> VolumetricError:
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    return (exact if method == "exact" else first_order)(model, positions, conditions, frame)
