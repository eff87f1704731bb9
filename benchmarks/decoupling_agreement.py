"""Where the first-order and patent (eq. 17) decouplings part from the exact one.

For a block rotated about one axis (or all three equally) relative to the
datum, on a plane surface y = slope * x, it finds the rotation angle at which
|first-order - exact| and |patent - exact| reach 0.1 um, by root finding on
a forward model written here (block pose, mirror point P, sensor head E, beam
straight down, beam-plane intersection).  The exact method reproduces the
forward model to < 1e-6 um (tests/processing/test_decoupling_methods.py), so
its value is the truth.  Prints the markdown table used in docs/conventions.md.

    python benchmarks/decoupling_agreement.py
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.optimize import brentq

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from processing.decoupling import decouple  # noqa: E402
from processing.geometry import BlockGeometry, DatumAngles  # noqa: E402

LIMIT_UM = 0.1


def rot(ex: float, ey: float, ez: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = (math.cos(ex), math.sin(ex), math.cos(ey), math.sin(ey), math.cos(ez),
                              math.sin(ez))
    return (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))


def errors(angles: tuple[float, float, float], p: np.ndarray, e: np.ndarray, slope: float) -> dict[str, float]:
    """|method - exact| (um) for one station 100 mm from the datum with the given rotation."""
    b = np.array([0.0, -1.0, 0.0])

    def hit(r: np.ndarray, t: np.ndarray) -> tuple[float, np.ndarray]:
        ew, dw = r @ e + t, r @ b
        lam = (slope * ew[0] - ew[1]) / (dw[1] - slope * dw[0])
        return lam, ew + lam * dw

    lam0, _ = hit(np.eye(3), np.zeros(3))
    r, t = rot(*angles), np.array([100.0, slope * 100.0, 0.0])
    lam, _ = hit(r, t)
    d = r @ p + t - p
    rows = [{"station": 0, "x_mm": 0.0, "lin_um": 0.0, "stry_um": 0.0, "strz_um": 0.0, "pitch_urad": 0.0,
             "yaw_urad": 0.0, "roll_urad": 0.0, "sensor_mm": 0.0},
            {"station": 1, "x_mm": 100.0, "lin_um": (d[0] - 100.0) * 1e3, "stry_um": d[1] * 1e3,
             "strz_um": d[2] * 1e3, "pitch_urad": angles[2] * 1e6, "yaw_urad": angles[1] * 1e6,
             "roll_urad": angles[0] * 1e6, "sensor_mm": lam0 - lam}]
    pts = pd.DataFrame(rows)
    # the datum block's frame is the laser's here (identity pose): its angles are known, all 0
    geom = BlockGeometry(tuple(p), tuple(e + lam0 * b), datum_angles_urad=DatumAngles(0.0, 0.0, 0.0))  # type: ignore[arg-type]
    h = {m: decouple(pts, geom, m)["height_um"].iloc[1] for m in ("exact", "first-order", "patent")}
    return {m: abs(h[m] - h["exact"]) for m in ("first-order", "patent")}


def threshold(axis: str, method: str, p: np.ndarray, e: np.ndarray, slope: float) -> float:
    def angles(a: float) -> tuple[float, float, float]:
        return {"roll": (a, 0.0, 0.0), "yaw": (0.0, a, 0.0), "pitch": (0.0, 0.0, a), "all": (a, a, a)}[axis]

    f = lambda a: errors(angles(a), p, e, slope)[method] - LIMIT_UM  # noqa: E731
    hi = 0.05
    if f(hi) < 0:
        return math.inf
    return brentq(f, 1e-7, hi, xtol=1e-9)


def main() -> int:
    axes = ("pitch", "roll", "yaw", "all")
    print(f"Rotation (mrad) about one axis / all three at which |method - exact| reaches {LIMIT_UM} um")
    print("(station 100 mm from the datum; sensor head E = (150, 30, 40) mm, beam straight down;")
    print(" Q = E + 30 mm down, so xQ - xP = 100 mm, zQ - zP = 40 mm; the vertical offset yP - yQ varies)\n")
    print("| yP - yQ (mm) | surface slope (urad) | method | " + " | ".join(axes) + " |")
    print("|---|---|---|" + "---|" * len(axes))
    for yp in (30.0, 110.0, 300.0):
        for slope_urad in (0.0, 500.0) if yp == 110.0 else (0.0,):
            for method in ("first-order", "patent"):
                p = np.array([50.0, yp, 0.0])
                e = np.array([150.0, 30.0, 40.0])
                vals = [threshold(ax, method, p, e, slope_urad * 1e-6) * 1e3 for ax in axes]
                cells = " | ".join("> 50" if math.isinf(v) else f"{v:.2f}" for v in vals)
                print(f"| {yp:.0f} | {slope_urad:.0f} | {method} | {cells} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
