"""What the datum block's angles leave in the exact decoupling (docs/conventions.md, "The laser frame").

The exact method works in the laser's frame and needs the datum block's angles
e0 in it.  Taking them as e' instead leaves, at point k (exact identity),

    truth - computed = (dR_k - dR_0) (R(e0) - R(e')) v_k + dR_0 (R(e0) - R(e')) dl_k b,

v_k = Q - P + dl_k b (block frame), whose height part is to second order

    e_y = d_y (a_x v_x + a_z v_z) - v_y (a_x d_x + a_z d_z) + dl (d_z b_x - d_x b_z)

with a the rotation since the datum and d = e0 - e'.  This script prints, for
the demo geometry (P = (50, 110, 0), Q = (150, 0, 40) mm, beam straight down),
the bound |a_x|, |a_z| <= A, |d_x|, |d_y| <= D:

    |e_y| <= A (D (|v_x| + |v_z|) + |v_y| (D + |d_z|))

for the default set-up (pitch estimated from the first step, |d_z| = 2 u of the
estimate, roll and yaw not measured, |d_x|, |d_y| = D) and for the frame
assumption of the method before the laser frame (no datum angles at all, so
|d_z| = the datum pitch S as well), next to the worst case of the exact identity
over all sign combinations of a (yaw too) and d.  Prints the markdown table used
in docs/conventions.md.

    python benchmarks/datum_residual.py
"""

from __future__ import annotations

import itertools
import math
import sys

import numpy as np

P = np.array([50.0, 110.0, 0.0])
Q = np.array([150.0, 0.0, 40.0])
V = Q - P
U_PITCH_URAD = 2 * 1.42  # 2 u of the estimated datum pitch with the default inputs (docs/run-format.md)
DATUM_PITCH_URAD = 80.0  # S: the local slope under the datum block, laser frame


def rot(ex: float, ey: float, ez: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = (math.cos(ex), math.sin(ex), math.cos(ey), math.sin(ey), math.cos(ez),
                              math.sin(ez))
    return (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))


def bound_um(a: float, d: float, dz: float) -> float:
    return a * (d * (abs(V[0]) + abs(V[2])) + abs(V[1]) * (d + dz)) * 1e3


def worst_um(a: float, d: float, s: float, dz: float) -> float:
    """max |truth - computed| over the sign corners: datum (d_x, d_y, s), used (0, 0, s - d_z)."""
    worst = 0.0
    for sa in itertools.product((-1, 1), repeat=3):
        dr = rot(*(np.array(sa) * a)) - np.eye(3)
        for sx, sy, sz in itertools.product((-1, 1), repeat=3):
            r0 = rot(sx * d, sy * d, s)
            used = rot(0.0, 0.0, s - sz * dz)
            worst = max(worst, abs((dr @ (r0 - used) @ V)[1]) * 1e3)
    return worst


def main() -> int:
    s = DATUM_PITCH_URAD * 1e-6
    print("Height residual (um) the datum angles leave; P 110 mm above Q, xQ - xP = 100 mm, zQ - zP = 40 mm,")
    print(f"beam straight down; datum pitch S = {DATUM_PITCH_URAD:g} urad; estimated pitch within "
          f"2u = {U_PITCH_URAD:.2f} urad\n")
    print("| angle change A (mrad) | roll, yaw of the datum D (urad) | pitch estimated: bound | worst case "
          "| no datum angles (before): bound | worst case |")
    print("|---|---|---|---|---|---|")
    for a_mrad in (0.05, 0.1, 0.3, 1.0):
        for d_urad in (10.0, 30.0, 100.0):
            a, d = a_mrad * 1e-3, d_urad * 1e-6
            new_b, new_w = bound_um(a, d, U_PITCH_URAD * 1e-6), worst_um(a, d, s, U_PITCH_URAD * 1e-6)
            old_b, old_w = bound_um(a, d, s), worst_um(a, d, s, s)
            print(f"| {a_mrad:g} | {d_urad:g} | {new_b:.4f} | {new_w:.4f} | {old_b:.4f} | {old_w:.4f} |")
    a = 1e-3
    print(f"\nRoll and yaw measured (D = 0), A = 1 mrad: bound {bound_um(a, 0.0, U_PITCH_URAD * 1e-6):.5f} um, "
          f"worst case {worst_um(a, 0.0, s, U_PITCH_URAD * 1e-6):.5f} um")
    return 0


if __name__ == "__main__":
    sys.exit(main())
