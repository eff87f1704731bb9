"""Rotation matrices and rigid transforms, vectorised over poses (docs/volumetric.md).

Angles in rad.  A rotation built from three angles is **R = Rz(εz)·Ry(εy)·Rx(εx)**
(docs/conventions.md); every function takes arrays broadcasting to a common shape ``S`` and
returns ``S + (3, 3)`` matrices or ``S + (3,)`` vectors.  A rigid transform is the pair
(R, t): p ↦ R p + t, the 4×4 homogeneous matrix [[R, t], [0, 1]] without its constant row.
The exact chain product uses the component-wise form of :mod:`.components`.
"""

from __future__ import annotations

import numpy as np

AXIS_LETTERS = "XYZ"


def rotation_zyx(ex: np.ndarray | float, ey: np.ndarray | float, ez: np.ndarray | float) -> np.ndarray:
    """R = Rz(ez) Ry(ey) Rx(ex), shape ``broadcast(ex, ey, ez) + (3, 3)``."""
    ex, ey, ez = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (ex, ey, ez)))
    cx, sx, cy, sy, cz, sz = np.cos(ex), np.sin(ex), np.cos(ey), np.sin(ey), np.cos(ez), np.sin(ez)
    r = np.empty(ex.shape + (3, 3))
    r[..., 0, 0] = cz * cy
    r[..., 0, 1] = cz * sy * sx - sz * cx
    r[..., 0, 2] = cz * sy * cx + sz * sx
    r[..., 1, 0] = sz * cy
    r[..., 1, 1] = sz * sy * sx + cz * cx
    r[..., 1, 2] = sz * sy * cx - cz * sx
    r[..., 2, 0] = -sy
    r[..., 2, 1] = cy * sx
    r[..., 2, 2] = cy * cx
    return r


def principal_rotation(axis: int, angle: np.ndarray | float) -> np.ndarray:
    """Rotation by ``angle`` (right-hand rule) about the principal axis ``axis`` (0 = X, 1 = Y, 2 = Z)."""
    angles = [np.zeros_like(np.asarray(angle, dtype=float))] * 3
    angles[axis] = np.asarray(angle, dtype=float)
    return rotation_zyx(*angles)


def apply(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v over broadcast stacks of matrices and vectors."""
    return np.einsum("...ij,...j->...i", r, v)


def apply_transposed(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rᵀ v over broadcast stacks of matrices and vectors."""
    return np.einsum("...ji,...j->...i", r, v)


def signed_axis(spec: str) -> tuple[int, float]:
    """``"+X"`` … ``"-Z"`` → (axis index, sign); ValueError for anything else."""
    s = spec.strip().upper()
    if len(s) == 2 and s[0] in "+-" and s[1] in AXIS_LETTERS:
        return AXIS_LETTERS.index(s[1]), (1.0 if s[0] == "+" else -1.0)
    raise ValueError(f"{spec!r} is not a signed axis (+X, -X, +Y, -Y, +Z or -Z)")


def unit_vector(axis: int, sign: float = 1.0) -> np.ndarray:
    v = np.zeros(3)
    v[axis] = sign
    return v
