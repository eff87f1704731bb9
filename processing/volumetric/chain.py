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

from .model import Body, Element
from .rotations import apply, compose, principal_rotation, rotation_zyx

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


@dataclass
class BodyErrors:
    """The exact error terms of one body (arrays ``(..., 3)`` broadcasting to the poses): location
    translation (mm) and rotation (rad), error-motion translation (mm) and rotation (rad),
    squareness tilt (rad)."""

    location_t: np.ndarray
    location_r: np.ndarray
    error_t: np.ndarray
    error_r: np.ndarray
    tilt: np.ndarray

    @staticmethod
    def zero() -> BodyErrors:
        return BodyErrors(*(np.zeros(3) for _ in range(5)))


def body_errors(bodies: tuple[Body, ...], elements: tuple[Element, ...], positions: Mapping[str, np.ndarray],
                conditions: Mapping[str, float]) -> dict[str, BodyErrors]:
    """Sum the elements of every body into its exact error terms."""
    fields = ("location_t", "location_r", "error_t", "error_r", "tilt")
    # per body and field, three scalar components (most element vectors are unit axes)
    sums: dict[str, dict[str, list[Any]]] = {b.name: {f: [0.0, 0.0, 0.0] for f in fields} for b in bodies}
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
    return {name: BodyErrors(*(_stack(sums[name][f]) for f in fields)) for name in sums}


def _stack(parts: list[Any]) -> np.ndarray:
    arrays = np.broadcast_arrays(*(np.asarray(p, dtype=float) for p in parts))
    return np.stack(arrays, axis=-1)


@dataclass(frozen=True)
class ChainWalk:
    """Poses broadcast against the positions: a rotation stays one (3, 3) matrix until a rotary axis
    or an angular error that varies over the poses makes it vary too."""

    carrying: dict[str, Pose]  # per body: the frame that carries its errors
    end: Pose                  # the frame of the chain's last body (identity for an empty chain)


def _rt(e_r: np.ndarray, e_t: np.ndarray) -> Pose:
    return rotation_zyx(e_r[..., 0], e_r[..., 1], e_r[..., 2]), e_t


def walk_chain(bodies: tuple[Body, ...], positions: Mapping[str, np.ndarray],
               errors: Mapping[str, BodyErrors] | None = None) -> ChainWalk:
    """Compose the chain from the base; ``errors`` None: the nominal chain."""
    pose: Pose = (np.eye(3), np.zeros(3))
    carrying: dict[str, Pose] = {}
    for b in bodies:
        pose = (pose[0], pose[1] + apply(pose[0], np.asarray(b.offset_mm, dtype=float)))
        err = errors[b.name] if errors is not None else None
        if b.kind == "prismatic":
            u = b.direction
            if err is not None:
                u = apply(rotation_zyx(err.tilt[..., 0], err.tilt[..., 1], err.tilt[..., 2]), u)
            q = np.asarray(positions[b.name], dtype=float)[..., None]
            pose = (pose[0], pose[1] + apply(pose[0], q * u))
            carrying[b.name] = pose
            if err is not None:
                pose = compose(pose, _rt(err.error_r, err.error_t))
            continue
        carrying[b.name] = pose
        if err is not None:
            pose = compose(compose(pose, _rt(err.location_r, err.location_t)), _rt(err.error_r, err.error_t))
        if b.kind == "rotary":
            angle = np.deg2rad(np.asarray(positions[b.name], dtype=float)) * b.sign
            pose = (pose[0] @ principal_rotation(b.axis, angle), pose[1])
    return ChainWalk(carrying, pose)


def tool_point(walk: ChainWalk, tool_offset_mm: tuple[float, float, float]) -> np.ndarray:
    """The tool point in the machine frame (mm)."""
    r, o = walk.end
    return o + apply(r, np.asarray(tool_offset_mm, dtype=float))
