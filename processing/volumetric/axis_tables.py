"""Per-axis compensation tables from the volumetric model, and the cross terms they cannot hold.

A per-axis table (LinuxCNC ``COMP_FILE``, docs/compensation.md) corrects axis j by a function of
q_j alone.  From the model it holds e_j(q_j) = s_j · (Δ · u_j) with every other axis at its
reference position: Δ the tool-relative-to-workpiece error in the machine frame, u_j the axis
direction in the machine frame, s_j = +1 for a tool-chain axis and −1 for a workpiece-chain one
(moving a table by +q moves the tool by −q relative to the workpiece).  So e_j is the axis's
own error in the ISO 230-2 sense at the tool point (actual − commanded along the axis; a rotary
axis: angle, arcsec), e.g. e_X = EXX + r_z·EBX − r_y·ECX for an X axis in either chain: its
positioning error plus the Abbe terms of its angles, r the tool point's offset from the carriage.

What such a table cannot hold, per element (first order): the part of its contribution along u_j
that depends on the other axes (straightness of Z read along X, Abbe terms z·εy, squareness
x·S …), its position error along directions no prismatic axis compensates, and its orientation
error about directions no rotary axis compensates.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .evaluate import Nominal, base_displacement, evaluate, nominal
from .model import Body, MachineModel
from .rotations import apply

URAD_PER_ARCSEC = np.pi / 180.0 / 3600.0 * 1e6  # 4.8481… µrad


@dataclass(frozen=True)
class AxisTable:
    """e = actual − commanded of one axis at table positions; µm (prismatic) or arcsec (rotary)."""

    axis: str
    kind: str
    position: np.ndarray
    error: np.ndarray

    @property
    def position_unit(self) -> str:
        return "deg" if self.kind == "rotary" else "mm"

    @property
    def error_unit(self) -> str:
        return "arcsec" if self.kind == "rotary" else "um"


def _chain_sign(body: Body) -> float:
    return -1.0 if body.chain == "workpiece" else 1.0


def machine_direction(nom: Nominal, body: Body) -> np.ndarray:
    """u of ``body`` in machine-frame axes at the nominal poses (shape ``nom.shape + (3,)``)."""
    walk = nom.workpiece if body.chain == "workpiece" else nom.tool
    return np.broadcast_to(apply(walk.carrying[body.name][0], body.direction), nom.shape + (3,))


def measured_span(model: MachineModel, axis: str) -> tuple[float, float]:
    """The part of the axis's range its tabulated error curves (tables, runs) cover: a table never
    reaches outside it (docs/compensation.md); polynomials and constants cover everything."""
    body = model.body(axis)
    if body.range is None:
        raise ValueError(f"{axis} is not a moving axis")
    lo, hi = body.range
    for e in model.elements:
        if e.body == axis and e.variable == "position" and e.curve.domain is not None:
            lo, hi = max(lo, e.curve.domain[0]), min(hi, e.curve.domain[1])
    return (lo, hi) if lo < hi else body.range


def axis_table(model: MachineModel, axis: str, count: int, reference: Mapping[str, float],
               conditions: Mapping[str, float], method: str = "first-order") -> AxisTable:
    """The table of ``axis`` at ``count`` equidistant positions over its :func:`measured_span`, the
    other axes at ``reference``."""
    body = model.body(axis)
    if not body.moving or body.range is None:
        raise ValueError(f"{axis} is not a moving axis")
    q = np.linspace(*measured_span(model, axis), count)
    positions: dict[str, np.ndarray | float] = {a.name: float(reference[a.name]) for a in model.axes}
    positions[axis] = q
    err = evaluate(model, positions, conditions, method=method, frame="machine")
    u = machine_direction(nominal(model, positions), body)
    if body.kind == "rotary":
        e = _chain_sign(body) * np.einsum("...i,...i->...", err.orientation_urad, u) / URAD_PER_ARCSEC
    else:
        e = _chain_sign(body) * np.einsum("...i,...i->...", err.position_um, u)
    return AxisTable(axis, body.kind, q, e)


@dataclass(frozen=True)
class CrossTerm:
    """Largest part of one element's contribution a per-axis table cannot hold.

    ``target``: the axis whose table would need it (a position in µm along a prismatic axis, an
    angle in µrad about a rotary one), ``"position"`` (µm along no compensated direction) or
    ``"orientation"`` (µrad about no rotary axis).  ``index``: the flat grid index of the maximum."""

    element: str
    target: str
    max_abs: float
    unit: str
    index: int


def _along(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", v, u)


def cross_terms(model: MachineModel, grid: Mapping[str, np.ndarray | float], reference: Mapping[str, float],
                conditions: Mapping[str, float]) -> list[CrossTerm]:
    """Every element's cross terms over ``grid`` (positions of every moving axis), largest first."""
    nom = nominal(model, grid)
    axes = model.axes
    dirs = {a.name: machine_direction(nom, a) for a in axes}
    held: dict[str, Nominal] = {}
    for a in axes:  # the grid with every other axis at its reference: what a's table sees
        proj = {b.name: (nom.positions[b.name] if b.name == a.name else float(reference[b.name])) for b in axes}
        held[a.name] = nominal(model, proj)
    out: list[CrossTerm] = []
    for e in model.elements:
        full = nom.shape + (3,)
        d, w = (np.broadcast_to(v, full) for v in base_displacement(model, nom, e, conditions))
        d_rest, w_rest = d.copy(), w.copy()
        for a in axes:
            vec, rest = (d, d_rest) if a.kind == "prismatic" else (w, w_rest)
            comp = _along(vec, dirs[a.name])
            rest -= comp[..., None] * dirs[a.name]
            hd, hw = base_displacement(model, held[a.name], e, conditions)
            part = comp - np.broadcast_to(_along(hd if a.kind == "prismatic" else hw, dirs[a.name]), comp.shape)
            out.append(_term(e.id, a.name, part * (1e3 if a.kind == "prismatic" else 1e6),
                             "um" if a.kind == "prismatic" else "urad"))
        out.append(_term(e.id, "position", np.linalg.norm(d_rest, axis=-1) * 1e3, "um"))
        out.append(_term(e.id, "orientation", np.linalg.norm(w_rest, axis=-1) * 1e6, "urad"))
    return sorted((t for t in out if t.max_abs > 0), key=lambda t: -t.max_abs)


def _term(element: str, target: str, values: np.ndarray, unit: str) -> CrossTerm:
    flat = np.abs(np.ravel(values))
    i = int(np.argmax(flat)) if flat.size else 0
    return CrossTerm(element, target, float(flat[i]) if flat.size else 0.0, unit, i)
