"""Walking a chain of bodies: nominal frames, and the exact product of the error transforms.

For body j after the pose (R, o) of the previous body (docs/volumetric.md, "The chain"):

    prismatic  T_j = Trans(o_j) · Trans(q·u') · E_j                u' = R(θ_j)·u  (squareness tilt)
    rotary     T_j = Trans(o_j) · L_j · E_j · Rot(u, q)
    fixed      T_j = Trans(o_j) · L_j · E_j

with E_j = Trans(δ_j)·R(ε_j) (the sums of the body's motion and thermal elements) and
L_j = Trans(p_j)·R(s_j) (its location elements); R(·) of an angle vector is Rz·Ry·Rx.  The
frame that carries the errors of body j ("carrying frame") has the previous body's axes and
sits at the body's reference point: after Trans(o_j)·Trans(q·u) (prismatic) or Trans(o_j).
Positions: mm, deg; errors: µm, µrad; poses: mm, rad.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import components as cp
from .model import Body, Element
from .rotations import apply, principal_rotation

Pose = tuple[np.ndarray, np.ndarray]  # (R (..., 3, 3), o (..., 3))
UM, URAD = 1e-3, 1e-6  # to mm, rad


def element_values(e: Element, positions: Mapping[str, np.ndarray], conditions: Mapping[str, float]
                   ) -> np.ndarray:
    """The element's value (µm or µrad), shaped like its variable (a position array, or 0-d)."""
    if e.variable == "position":
        x = positions[e.body]
    elif e.variable == "constant":
        x = np.zeros(())
    else:
        x = np.asarray(conditions[e.variable], dtype=float)
    return e.curve(x)


FIELDS = ("location_t", "location_r", "error_t", "error_r", "tilt")


def body_error_sums(bodies: tuple[Body, ...], elements: tuple[Element, ...], positions: Mapping[str, np.ndarray],
                    conditions: Mapping[str, float]) -> dict[str, dict[str, list[Any]]]:
    """Per body and error term (:data:`FIELDS`), the three summed components (mm or rad): arrays
    over the poses, or plain numbers where no element varies (most element vectors are unit axes)."""
    sums: dict[str, dict[str, list[Any]]] = {b.name: {f: [0.0, 0.0, 0.0] for f in FIELDS} for b in bodies}
    for e in elements:
        if e.body not in sums:
            continue
        if e.kind == "squareness":
            f, scale = "tilt", URAD
        else:
            f = ("location_" if e.group == "location" else "error_") + ("t" if e.kind == "translation" else "r")
            scale = UM if e.kind == "translation" else URAD
        v = element_values(e, positions, conditions) * scale
        acc = sums[e.body][f]
        for k, c in enumerate(e.vector):
            if c:
                acc[k] = acc[k] + c * v
    return sums


@dataclass(frozen=True)
class ChainWalk:
    """Nominal poses broadcast against the positions: a rotation stays one (3, 3) matrix until a rotary
    axis whose angle varies over the poses makes it vary too."""

    carrying: dict[str, Pose]  # per body: the frame that carries its errors
    end: Pose                  # the frame of the chain's last body (identity for an empty chain)


def walk_chain(bodies: tuple[Body, ...], positions: Mapping[str, np.ndarray]) -> ChainWalk:
    """Compose the nominal chain from the base, keeping every body's carrying frame."""
    pose: Pose = (np.eye(3), np.zeros(3))
    carrying: dict[str, Pose] = {}
    for b in bodies:
        pose = (pose[0], pose[1] + apply(pose[0], np.asarray(b.offset_mm, dtype=float)))
        if b.kind == "prismatic":
            q = np.asarray(positions[b.name], dtype=float)[..., None]
            pose = (pose[0], pose[1] + apply(pose[0], q * b.direction))
        carrying[b.name] = pose
        if b.kind == "rotary":
            angle = np.deg2rad(np.asarray(positions[b.name], dtype=float)) * b.sign
            pose = (pose[0] @ principal_rotation(b.axis, angle), pose[1])
    return ChainWalk(carrying, pose)


def _is_zero(v: list[Any]) -> bool:
    return all(isinstance(c, float) and c == 0.0 for c in v)


def walk_exact(bodies: tuple[Body, ...], positions: Mapping[str, np.ndarray],
               sums: Mapping[str, dict[str, list[Any]]] | None = None) -> tuple[cp.Mat, cp.Vec]:
    """The pose (R, o) of the chain's last body, component-wise (:mod:`.components`): the exact
    product of the transforms in the module docstring; ``sums`` (:func:`body_error_sums`) None:
    the nominal chain.  Same result as :func:`walk_chain`, several times faster on many poses."""
    r: cp.Mat = cp.IDENTITY
    o: cp.Vec = [0.0, 0.0, 0.0]

    def then(o: cp.Vec, r: cp.Mat, t: list[Any], a: list[Any]) -> tuple[cp.Vec, cp.Mat]:
        """(r, o) · Trans(t) · R(a)."""
        if not _is_zero(t):
            o = cp.vec_add(o, cp.mat_vec(r, t))
        if not _is_zero(a):
            r = cp.mat_mul(r, cp.mat_zyx(*a))
        return o, r

    for b in bodies:
        o = cp.vec_add(o, cp.mat_vec(r, list(b.offset_mm)))
        e = sums[b.name] if sums is not None else None
        if b.kind == "prismatic":
            u: list[Any] = list(b.direction)
            if e is not None and not _is_zero(e["tilt"]):
                u = cp.mat_vec(cp.mat_zyx(*e["tilt"]), u)
            q = np.asarray(positions[b.name], dtype=float)
            o = cp.vec_add(o, cp.mat_vec(r, [q * c for c in u]))
            if e is not None:
                o, r = then(o, r, e["error_t"], e["error_r"])
            continue
        if e is not None:
            o, r = then(o, r, e["location_t"], e["location_r"])
            o, r = then(o, r, e["error_t"], e["error_r"])
        if b.kind == "rotary":
            angle = np.deg2rad(np.asarray(positions[b.name], dtype=float)) * b.sign
            r = cp.mat_mul(r, cp.mat_principal(b.axis, angle))
    return r, o


def tool_point(walk: ChainWalk, tool_offset_mm: tuple[float, float, float]) -> np.ndarray:
    """The tool point in the machine frame (mm)."""
    r, o = walk.end
    return o + apply(r, np.asarray(tool_offset_mm, dtype=float))
