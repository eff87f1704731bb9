"""Test-side reference of the volumetric model, written from docs/volumetric.md: a machine file
(as parsed TOML) evaluated one pose at a time with explicit 4×4 homogeneous matrices.  It shares
no code with ``processing`` or ``acquisition``; element sources are numbers, polynomials and
tables (runs are resolved by the tests themselves)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

AXES = "XYZ"
KEYS = ("EX", "EY", "EZ", "EA", "EB", "EC")


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def rot(ex: float, ey: float, ez: float) -> np.ndarray:
    """R = Rz(ez) Ry(ey) Rx(ex) as a 4×4 matrix."""
    return rot_z(ez) @ rot_y(ey) @ rot_x(ex)


def trans(v: Any) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = v
    return t


def signed(text: str) -> np.ndarray:
    v = np.zeros(3)
    v[AXES.index(text[1])] = 1.0 if text[0] == "+" else -1.0
    return v


def value(spec: Any, x: float) -> float:
    """A source's value at ``x``: number, {poly, origin}, {positions, values}."""
    if isinstance(spec, int | float):
        return float(spec)
    if "poly" in spec:
        u = x - spec.get("origin", 0.0)
        return float(sum(c * u ** k for k, c in enumerate(spec["poly"])))
    return float(np.interp(x, spec["positions"], spec["values"]))


def euler_zyx(r: np.ndarray) -> np.ndarray:
    return np.array([math.atan2(r[2, 1], r[2, 2]), -math.asin(r[2, 0]), math.atan2(r[1, 0], r[0, 0])])


class Reference:
    """``error(pose)``: (position error µm, orientation error µrad) in the workpiece frame."""

    def __init__(self, machine: dict[str, Any]) -> None:
        self.m = machine
        self.bodies = {b["name"]: b for c in ("workpiece_chain", "tool_chain") for b in machine.get(c, [])}

    def tilts(self, scale: float) -> dict[str, np.ndarray]:
        """Squareness: the tilted axis Q of a pair turns by S·(u_P × u_Q) (docs/volumetric.md)."""
        frame = self.m.get("frame", {})
        p, s = frame.get("primary"), frame.get("secondary")
        out: dict[str, np.ndarray] = {}
        for sq in self.m.get("squareness", []):
            a, b = sq["axes"]
            if {a, b} == {p, s}:
                ref, tilted = p, s
            else:
                ref = a if a in (p, s) else b
                tilted = b if ref == a else a
            u_p, u_q = signed(self.bodies[ref]["direction"]), signed(self.bodies[tilted]["direction"])
            out[tilted] = out.get(tilted, np.zeros(3)) + scale * sq["value_urad"] * 1e-6 * np.cross(u_p, u_q)
        return out

    def body_matrix(self, b: dict[str, Any], pose: dict[str, float], cond: dict[str, float], scale: float,
                    tilt: np.ndarray | None) -> np.ndarray:
        q = pose.get(b["name"], 0.0)
        delta, eps = np.zeros(3), np.zeros(3)
        for k, key in enumerate(KEYS):
            if key in b.get("errors", {}):
                v = scale * value(b["errors"][key], q)
                if k < 3:
                    delta[k] += v * 1e-3
                else:
                    eps[k - 3] += v * 1e-6
            if key in b.get("thermal", {}):
                spec = b["thermal"][key]
                v = scale * value(spec, cond[spec["of"]])
                if k < 3:
                    delta[k] += v * 1e-3
                else:
                    eps[k - 3] += v * 1e-6
        loc_t = np.array([scale * b.get("location", {}).get(k, 0.0) * 1e-3 for k in KEYS[:3]])
        loc_r = np.array([scale * b.get("location", {}).get(k, 0.0) * 1e-6 for k in KEYS[3:]])
        error = trans(delta) @ rot(*eps)
        offset = trans(b.get("offset_mm", [0.0, 0.0, 0.0]))
        if b["type"] == "prismatic":
            u = signed(b["direction"])
            if tilt is not None:
                u = rot(*tilt)[:3, :3] @ u
            return offset @ trans(q * u) @ error
        location = trans(loc_t) @ rot(*loc_r)
        if b["type"] == "fixed":
            return offset @ location @ error
        u = signed(b["direction"])
        k = int(np.argmax(np.abs(u)))
        angle = math.radians(q) * u[k]
        turn = (rot_x, rot_y, rot_z)[k](angle)
        return offset @ location @ error @ turn

    def chains(self, pose: dict[str, float], cond: dict[str, float], scale: float) -> tuple[np.ndarray, np.ndarray]:
        tilts = self.tilts(scale)
        mats = []
        for chain in ("workpiece_chain", "tool_chain"):
            t = np.eye(4)
            for b in self.m.get(chain, []):
                t = t @ self.body_matrix(b, pose, cond, scale, tilts.get(b["name"]))
            mats.append(t)
        return mats[0], mats[1]

    def error(self, pose: dict[str, float], cond: dict[str, float] | None = None, scale: float = 1.0,
              frame: str = "workpiece") -> tuple[np.ndarray, np.ndarray]:
        """In the ``machine`` frame the position error is turned by the nominal workpiece rotation R_W
        and the error rotation ΔR = R1·R0ᵀ becomes the matrix R_W·ΔR·R_Wᵀ, whose Z-Y-X angles are given."""
        cond = {"temperature_c": 20.0, "time_h": 0.0, **self.m.get("conditions", {}), **(cond or {})}
        tool = np.array([*self.m.get("tool", {}).get("offset_mm", [0.0, 0.0, 0.0]), 1.0])
        w0, t0 = self.chains(pose, cond, 0.0)
        w1, t1 = self.chains(pose, cond, scale)
        p0 = np.linalg.inv(w0) @ t0 @ tool
        p1 = np.linalg.inv(w1) @ t1 @ tool
        r0 = (np.linalg.inv(w0) @ t0)[:3, :3]
        r1 = (np.linalg.inv(w1) @ t1)[:3, :3]
        d, turn = (p1 - p0)[:3], r1 @ r0.T
        if frame == "machine":
            rw = w0[:3, :3]
            d, turn = rw @ d, rw @ turn @ rw.T
        return d * 1e3, euler_zyx(turn) * 1e6
