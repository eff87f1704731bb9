"""3×3 rotations and 3-vectors held component-wise, for the exact chain product over many poses.

A :data:`Mat` is three rows of three entries and a :data:`Vec` three entries; each entry is an
array over the poses or a plain number (a constant).  Products then run on whole contiguous
arrays (and on numbers where a factor is constant), several times faster than stacks of (3, 3)
matrices.  Angles in rad; R(a) = Rz(a_z)·Ry(a_y)·Rx(a_x) as everywhere (docs/conventions.md).
"""

from __future__ import annotations

from typing import Any

import numpy as np

Entry = Any  # np.ndarray or float
Mat = list[list[Entry]]
Vec = list[Entry]

IDENTITY: Mat = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def mat_zyx(ex: Entry, ey: Entry, ez: Entry) -> Mat:
    """Rz(ez) Ry(ey) Rx(ex)."""
    cx, sx, cy, sy, cz, sz = np.cos(ex), np.sin(ex), np.cos(ey), np.sin(ey), np.cos(ez), np.sin(ez)
    return [[cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
            [-sy, cy * sx, cy * cx]]


def mat_principal(axis: int, angle: Entry) -> Mat:
    """Rotation by ``angle`` about the principal axis ``axis`` (0 = X, 1 = Y, 2 = Z)."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3  # cyclic: the rotation turns i towards j
    m: Mat = [[0.0] * 3 for _ in range(3)]
    m[axis][axis] = 1.0
    m[i][i], m[i][j], m[j][i], m[j][j] = c, -s, s, c
    return m


def _dot(a: Vec, b: Vec) -> Entry:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def mat_mul(a: Mat, b: Mat) -> Mat:
    cols = [[b[0][k], b[1][k], b[2][k]] for k in range(3)]
    return [[_dot(row, col) for col in cols] for row in a]


def mat_vec(a: Mat, v: Vec) -> Vec:
    return [_dot(row, v) for row in a]


def mat_t_vec(a: Mat, v: Vec) -> Vec:
    """aᵀ v."""
    return [a[0][k] * v[0] + a[1][k] * v[1] + a[2][k] * v[2] for k in range(3)]


def vec_add(a: Vec, b: Vec) -> Vec:
    return [a[k] + b[k] for k in range(3)]


def vec_sub(a: Vec, b: Vec) -> Vec:
    return [a[k] - b[k] for k in range(3)]


def _zero(x: Entry) -> bool:
    return isinstance(x, float) and x == 0.0


def mul(a: Entry, b: Entry) -> Entry:
    """a·b; a literal 0.0 factor gives 0.0 without touching the other (unit axes are mostly zeros)."""
    return 0.0 if _zero(a) or _zero(b) else a * b


def add(a: Entry, b: Entry) -> Entry:
    return b if _zero(a) else a if _zero(b) else a + b


def sub(a: Entry, b: Entry) -> Entry:
    return -b if _zero(a) else a if _zero(b) else a - b


def cross(a: Vec, b: Vec) -> Vec:
    return [sub(mul(a[1], b[2]), mul(a[2], b[1])), sub(mul(a[2], b[0]), mul(a[0], b[2])),
            sub(mul(a[0], b[1]), mul(a[1], b[0]))]


def norm(v: Vec) -> Entry:
    return np.sqrt(add(add(mul(v[0], v[0]), mul(v[1], v[1])), mul(v[2], v[2])))


def scaled(direction: np.ndarray, v: Entry) -> Vec:
    """direction·v for a direction ``(3,)`` (zero components stay 0.0) or ``(..., 3)``."""
    if direction.ndim == 1:
        return [mul(float(c), v) for c in direction]
    return [mul(direction[..., k], v) for k in range(3)]


def rotate(r: np.ndarray, v: Vec) -> Vec:
    """R v for a matrix ``(3, 3)`` (constant entries: zero terms are skipped) or ``(..., 3, 3)``."""
    if r.ndim == 2:
        return [add(add(mul(float(r[i, 0]), v[0]), mul(float(r[i, 1]), v[1])), mul(float(r[i, 2]), v[2]))
                for i in range(3)]
    return [r[..., i, 0] * v[0] + r[..., i, 1] * v[1] + r[..., i, 2] * v[2] for i in range(3)]


def split(v: np.ndarray) -> Vec:
    """An array ``(..., 3)`` as a Vec (views, no copy)."""
    return [v[..., 0], v[..., 1], v[..., 2]]


def stack(v: Vec, shape: tuple[int, ...]) -> np.ndarray:
    """A Vec as one array ``shape + (3,)``."""
    return np.stack([np.broadcast_to(np.asarray(c, dtype=float), shape) for c in v], axis=-1)
