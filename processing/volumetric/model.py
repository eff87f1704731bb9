"""The multi-body machine model: two chains of bodies from the base and their error elements.

docs/volumetric.md is the reference for every convention used here.  In short:

* The **workpiece chain** and the **tool chain** are ordered lists of bodies from the base
  (frame 0, the machine frame).  A body is a ``prismatic`` or ``rotary`` axis or a ``fixed``
  body (a spindle, a head without a joint).  Its frame sits at ``offset_mm`` in the previous
  body's frame; a prismatic axis moves it by q·u (q in mm), a rotary axis turns it by q
  (deg, right-hand rule) about u, u a signed principal axis of the previous body.
* Every **element** is a small error of one body, in the axes of the previous body at the
  body's reference point (its frame origin after the nominal translation):

  ============  ==========================================  ===========================
  group         what                                        value
  ============  ==========================================  ===========================
  motion        the six error motions EX EY EZ (µm) and     curve of the axis position
                EA EB EC (µrad, about X Y Z) of an axis
  location      constant pose error of a rotary / fixed     scalar
                body's frame, EX0 … EC0 (seed 004)
  squareness    angle between two prismatic axes minus      scalar (µrad), > 0 when the
                90° (seeds 000, 002)                        angle exceeds 90°
  thermal       drift (µm) / tilt (µrad) of a body's frame  curve of temperature or time
                origin (seed 002's 17 thermal elements)
  ============  ==========================================  ===========================
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from .curves import Constant, Curve
from .rotations import AXIS_LETTERS, unit_vector

BODY_KINDS = ("prismatic", "rotary", "fixed")
CHAINS = ("workpiece", "tool")
GROUPS = ("motion", "location", "squareness", "thermal")
COMPONENTS = ("EX", "EY", "EZ", "EA", "EB", "EC")
"""Translation along X, Y, Z (µm) and rotation about X, Y, Z (µrad), in the previous body's axes."""
VARIABLES = ("position", "temperature_c", "time_h", "constant")
ELEMENT_KINDS = ("translation", "rotation", "squareness")


@dataclass(frozen=True)
class Body:
    """One link of a chain; ``axis``/``sign`` give u (prismatic, rotary), ``range`` and ``reference``
    are in mm (prismatic) or deg (rotary)."""

    name: str
    kind: str
    chain: str
    axis: int = 0
    sign: float = 1.0
    offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    range: tuple[float, float] | None = None
    reference: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in BODY_KINDS:
            raise ValueError(f"body {self.name}: type must be one of {', '.join(BODY_KINDS)}, got {self.kind!r}")
        if self.chain not in CHAINS:
            raise ValueError(f"body {self.name}: chain must be workpiece or tool, got {self.chain!r}")
        if self.moving and (self.range is None or not (np.all(np.isfinite(self.range))
                                                        and self.range[0] < self.range[1])):
            raise ValueError(f"axis {self.name}: range must be [low, high] with low < high, got {self.range}")

    @property
    def moving(self) -> bool:
        return self.kind != "fixed"

    @property
    def unit(self) -> str:
        return "deg" if self.kind == "rotary" else "mm"

    @property
    def direction(self) -> np.ndarray:
        """u: the unit motion direction (prismatic) or rotation axis (rotary) in the previous body's axes."""
        return unit_vector(self.axis, self.sign)

    def direction_text(self) -> str:
        return f"{'+' if self.sign > 0 else '-'}{AXIS_LETTERS[self.axis]}" if self.moving else "—"


@dataclass(frozen=True)
class Element:
    """One error element carried by ``body``.

    ``kind`` ``translation``: a displacement ``value · vector`` (µm); ``rotation``: a small rotation
    ``value · vector`` (µrad) about the body's reference point; ``squareness``: the body's
    motion direction u is tilted by the rotation ``value · vector`` (µrad), so at travel q it is
    displaced by q · value · (vector × u).  ``variable`` is what the curve is a function of.
    """

    id: str
    group: str
    body: str
    kind: str
    vector: tuple[float, float, float]
    curve: Curve = field(default_factory=lambda: Constant(0.0))
    variable: str = "constant"
    source: str = ""

    def __post_init__(self) -> None:
        if self.group not in GROUPS:
            raise ValueError(f"element {self.id}: group must be one of {', '.join(GROUPS)}")
        if self.kind not in ELEMENT_KINDS:
            raise ValueError(f"element {self.id}: kind must be one of {', '.join(ELEMENT_KINDS)}")
        if self.variable not in VARIABLES:
            raise ValueError(f"element {self.id}: variable must be one of {', '.join(VARIABLES)}")

    @property
    def unit(self) -> str:
        return "um" if self.kind == "translation" else "urad"


def component_element(body: Body, component: str, group: str, curve: Curve, variable: str,
                      source: str = "") -> Element:
    """The element ``component`` (EX … EC) of ``body`` in ``group``, named as ISO 230-1 does: motion
    ``E<c><axis>`` (EXX, EBZ, ECC), location ``E<c>0<axis>`` (EX0C), thermal ``T<c><body>``."""
    if component not in COMPONENTS:
        raise ValueError(f"unknown component {component!r}; use one of {', '.join(COMPONENTS)}")
    k = COMPONENTS.index(component)
    c = component[1]
    ident = {"motion": f"E{c}{body.name}", "location": f"E{c}0{body.name}", "thermal": f"T{c}{body.name}"}[group]
    return Element(ident, group, body.name, "translation" if k < 3 else "rotation",
                   tuple(unit_vector(k % 3)), curve, variable, source)  # type: ignore[arg-type]


@dataclass(frozen=True)
class MachineModel:
    workpiece: tuple[Body, ...]
    tool: tuple[Body, ...]
    elements: tuple[Element, ...]
    tool_offset_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""
    primary: str | None = None
    secondary: str | None = None

    def __post_init__(self) -> None:
        names = [b.name for b in self.bodies]
        dup = [n for n, c in Counter(names).items() if c > 1]
        if dup:
            raise ValueError(f"body name {dup[0]!r} is used twice; every body needs its own name")
        for chain, bodies in (("workpiece", self.workpiece), ("tool", self.tool)):
            if any(b.chain != chain for b in bodies):
                raise ValueError(f"a body of the {chain} chain says it belongs to the other chain")
        ids = [e.id for e in self.elements]
        dup = [n for n, c in Counter(ids).items() if c > 1]
        if dup:
            raise ValueError(f"element {dup[0]} is given twice")
        for e in self.elements:
            b = self.body(e.body)
            if e.group == "motion" and not b.moving:
                raise ValueError(f"{e.id}: {b.name} is a fixed body; it has no error motions (use location)")
            if e.group in ("location",) and b.kind == "prismatic":
                raise ValueError(f"{e.id}: a prismatic axis has no location errors; its direction errors "
                                 "are squareness terms")
            if e.kind == "squareness" and b.kind != "prismatic":
                raise ValueError(f"{e.id}: squareness tilts a prismatic axis, {b.name} is {b.kind}")
            if e.variable == "position" and not b.moving:
                raise ValueError(f"{e.id}: {b.name} is fixed; its elements cannot depend on a position")
            if e.kind == "squareness" and any(u.kind == "rotary" for u in self.upstream(b.name)):
                raise ValueError(f"{e.id}: {b.name} is carried by a rotary axis; squareness is defined only "
                                 "between prismatic axes whose frames are parallel to the machine frame")
        for role, name in (("primary", self.primary), ("secondary", self.secondary)):
            if name is None:
                continue
            if name not in names or self.body(name).kind != "prismatic":
                raise ValueError(f"frame {role} {name!r} is not a prismatic axis of the machine")
            if any(u.kind == "rotary" for u in self.upstream(name)):
                raise ValueError(f"frame {role} {name} is carried by a rotary axis; the reference axes must "
                                 "move parallel to the machine frame")
        if self.primary is not None and self.primary == self.secondary:
            raise ValueError("the frame's primary and secondary axes must differ")

    @property
    def bodies(self) -> tuple[Body, ...]:
        return self.workpiece + self.tool

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def axes(self) -> tuple[Body, ...]:
        """The moving axes in command order: prismatic by name, then rotary by name (``--at X Y Z B C``)."""
        moving = [b for b in self.bodies if b.moving]
        return tuple(sorted(moving, key=lambda b: (b.kind != "prismatic", b.name)))

    def upstream(self, name: str) -> tuple[Body, ...]:
        """The bodies between the base and ``name`` (exclusive) in its chain."""
        b = self.body(name)
        chain = self.workpiece if b.chain == "workpiece" else self.tool
        return chain[: chain.index(b)]

    def counts(self) -> dict[str, int]:
        """Elements per group and in total (zero-valued motion errors count: every axis has six)."""
        c = Counter(e.group for e in self.elements)
        out = {g: c.get(g, 0) for g in GROUPS}
        out["geometric"] = out["motion"] + out["location"] + out["squareness"]
        out["total"] = len(self.elements)
        return out


def squareness_element(model_bodies: tuple[Body, ...], pair: tuple[str, str], value_urad: float,
                       primary: str, secondary: str, source: str = "") -> Element:
    """The squareness of two prismatic axes as a tilt of the later one (seed 002's reference frame).

    ``primary``'s direction is exact; ``secondary`` lies in the plane of the two; every other
    prismatic axis is tilted against both.  A pair must contain the primary or the secondary; the
    other axis of the pair is the one tilted, except for (primary, secondary) where the secondary
    is.  ``value_urad`` is the angle between the two positive directions minus 90° (> 0: obtuse,
    seeds 000 and 002): the tilted axis Q gains −S·u_P per unit of travel, so cos∠(u_P, u_Q) = −S.
    """
    bodies = {b.name: b for b in model_bodies}
    for n in pair:
        if n not in bodies:
            raise ValueError(f"squareness {pair[0]}-{pair[1]}: no axis named {n!r}")
        if bodies[n].kind != "prismatic":
            raise ValueError(f"squareness {pair[0]}-{pair[1]}: {n} is not a prismatic axis")
    if pair[0] == pair[1]:
        raise ValueError(f"squareness {pair[0]}-{pair[1]}: needs two different axes")
    refs = [n for n in pair if n in (primary, secondary)]
    if not refs:
        raise ValueError(f"squareness {pair[0]}-{pair[1]}: one axis must be the frame's primary ({primary}) "
                         f"or secondary ({secondary}); squareness is taken against them")
    if set(pair) == {primary, secondary}:
        ref, tilted = primary, secondary
    else:
        ref = refs[0]
        tilted = pair[1] if pair[0] == ref else pair[0]
    u_p, u_q = bodies[ref].direction, bodies[tilted].direction
    if abs(float(u_p @ u_q)) > 1e-12:
        raise ValueError(f"squareness {pair[0]}-{pair[1]}: the two axes are not perpendicular")
    w = -np.cross(u_q, u_p)  # tilt axis: w × u_Q = −u_P
    return Element(f"S{pair[0]}{pair[1]}", "squareness", tilted, "squareness", tuple(w),  # type: ignore[arg-type]
                   Constant(value_urad), "constant", source or f"angle({ref}, {tilted}) − 90° (scalar)")
