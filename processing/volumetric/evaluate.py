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

import numpy as np

from .chain import UM, URAD, ChainWalk, body_errors, element_values, tool_point, walk_chain
from .model import Element, MachineModel
from .rotations import apply, apply_transposed, euler_zyx

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


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over broadcast stacks of 3-vectors (np.cross is several times slower on long stacks)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def base_displacement(model: MachineModel, nom: Nominal, e: Element, conditions: Mapping[str, float]
                      ) -> tuple[np.ndarray, np.ndarray]:
    """First-order change of the tool point relative to the workpiece (mm) and of the relative
    orientation (rad) caused by ``e``, in machine-frame axes: + for a tool-chain element, − for a
    workpiece-chain one (it moves the workpiece point under the tool).  Arrays broadcast to
    ``nom.shape + (3,)`` (a constant element may return one vector)."""
    body = model.body(e.body)
    walk = nom.workpiece if body.chain == "workpiece" else nom.tool
    r_f, o_f = walk.carrying[body.name]
    sign = -1.0 if body.chain == "workpiece" else 1.0
    v = element_values(e, nom.positions, conditions)[..., None] * sign
    vec = np.asarray(e.vector, dtype=float)
    if e.kind == "translation":
        return apply(r_f, vec) * (v * UM), np.zeros(3)
    if e.kind == "rotation":
        w = apply(r_f, vec) * (v * URAD)
        return _cross(w, nom.tool_point - o_f), w
    # squareness: travel q times the tilt of the motion direction
    q = nom.positions[body.name][..., None]
    return apply(r_f, np.cross(vec, body.direction)) * (q * v * URAD), np.zeros(3)


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


def _row_norm(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def contribution_summary(model: MachineModel, positions: Mapping[str, np.ndarray | float],
                         conditions: Mapping[str, float], group: Callable[[Element], str],
                         frame: str = "workpiece") -> ContributionSummary:
    """The first-order error, the contribution of each group of elements (``group(element)`` names
    it) and each element's size, in one pass without keeping every element's field (lengths do
    not depend on the frame, so only the sums are turned into the workpiece frame)."""
    _check_frame(frame)
    nom = nominal(model, positions)
    full = nom.shape + (3,)
    groups: dict[str, np.ndarray] = {}
    w_total = np.zeros(full)
    stats = []
    for e in model.elements:
        d, w = base_displacement(model, nom, e, conditions)
        g = group(e)
        if g not in groups:
            groups[g] = np.zeros(full)
        groups[g] += d
        w_total += w
        dn, wn = _row_norm(d), _row_norm(w)
        stats.append(ElementSummary(e, float(np.max(dn, initial=0.0)) * 1e3, float(np.max(wn, initial=0.0)) * 1e6,
                                    math.sqrt(float(np.mean(dn * dn))) * 1e3))  # a constant: its one value
    d_total = sum(groups.values(), np.zeros(full))
    if frame == "workpiece" and _rotary_workpiece(model):
        r = nom.workpiece_rotation
        groups = {g: apply_transposed(r, v) for g, v in groups.items()}
        d_total, w_total = apply_transposed(r, d_total), apply_transposed(r, w_total)
    groups = {g: v * 1e3 for g, v in groups.items()}
    return ContributionSummary(VolumetricError(d_total * 1e3, w_total * 1e6, frame), groups, stats)


def first_order(model: MachineModel, positions: Mapping[str, np.ndarray | float],
                conditions: Mapping[str, float], frame: str = "workpiece") -> VolumetricError:
    """The volumetric error linear in every element (the sum of the contributions, computed per body:
    its summed translation δ, rotation ε and squareness tilt θ at its carrying frame F give
    R_F δ + (R_F ε) × (x_tool − o_F) + q·R_F (θ × u), with the chain's sign)."""
    _check_frame(frame)
    nom = nominal(model, positions)
    errs = body_errors(model.bodies, model.elements, nom.positions, conditions)
    d = np.zeros(nom.shape + (3,))
    w = np.zeros(nom.shape + (3,))
    for b in model.bodies:
        be = errs[b.name]
        r_f, o_f = (nom.workpiece if b.chain == "workpiece" else nom.tool).carrying[b.name]
        sign = -1.0 if b.chain == "workpiece" else 1.0
        wb = apply(r_f, be.error_r + be.location_r)
        db = apply(r_f, be.error_t + be.location_t) + _cross(wb, nom.tool_point - o_f)
        if b.kind == "prismatic":
            db = db + apply(r_f, _cross(be.tilt, b.direction)) * nom.positions[b.name][..., None]
        d += sign * db
        w += sign * wb
    if frame == "workpiece" and _rotary_workpiece(model):
        d, w = apply_transposed(nom.workpiece_rotation, d), apply_transposed(nom.workpiece_rotation, w)
    return VolumetricError(d * 1e3, w * 1e6, frame)


def exact(model: MachineModel, positions: Mapping[str, np.ndarray | float], conditions: Mapping[str, float],
          frame: str = "workpiece") -> VolumetricError:
    """The volumetric error from the full product of the error transforms (no small-angle step)."""
    _check_frame(frame)
    nom = nominal(model, positions)
    errs = body_errors(model.bodies, model.elements, nom.positions, conditions)
    wp = walk_chain(model.workpiece, nom.positions, errs)
    tl = walk_chain(model.tool, nom.positions, errs)
    xt = tool_point(tl, model.tool_offset_mm)
    rw0, ow0 = nom.workpiece.end
    rw, ow = wp.end
    p_nominal = apply_transposed(rw0, nom.tool_point - ow0)
    p_actual = apply_transposed(rw, xt - ow)
    rel_nominal = np.swapaxes(rw0, -1, -2) @ nom.tool.end[0]
    rel_actual = np.swapaxes(rw, -1, -2) @ tl.end[0]
    d = p_actual - p_nominal
    w = euler_zyx(rel_actual @ np.swapaxes(rel_nominal, -1, -2))
    if frame == "machine":
        d, w = apply(rw0, d), apply(rw0, w)
    full = nom.shape + (3,)
    return VolumetricError(np.broadcast_to(d * 1e3, full).copy(), np.broadcast_to(w * 1e6, full).copy(), frame)


def evaluate(model: MachineModel, positions: Mapping[str, np.ndarray | float], conditions: Mapping[str, float],
             *, method: str = "first-order", frame: str = "workpiece") -> VolumetricError:
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    return (exact if method == "exact" else first_order)(model, positions, conditions, frame)
