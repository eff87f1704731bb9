"""Value curves of the error elements: a constant, a table or a polynomial of one variable.

The variable is the position of the element's axis (mm, rotary axes deg) or, for thermal
elements, the temperature (°C) or the time (h); the value is in the element's unit (µm or
µrad).  Every curve evaluates element-wise on arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Constant:
    value: float

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        return np.full(np.shape(x), float(self.value))

    @property
    def domain(self) -> tuple[float, float] | None:
        return None

    def describe(self) -> str:
        return "zero" if self.value == 0 else f"constant {self.value:g}"


@dataclass(frozen=True)
class Table:
    """Values at strictly increasing positions, linear in between; outside, the end values are held
    (as every compensation table does, docs/compensation.md): nothing is extrapolated."""

    positions: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        p, v = np.asarray(self.positions, dtype=float), np.asarray(self.values, dtype=float)
        if p.ndim != 1 or p.shape != v.shape or len(p) < 1:
            raise ValueError("a table needs as many values as positions (at least one)")
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
            raise ValueError("table positions and values must be finite numbers")
        if np.any(np.diff(p) <= 0):
            raise ValueError("table positions must be strictly increasing")

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        return np.interp(np.asarray(x, dtype=float), self.positions, self.values)

    @property
    def domain(self) -> tuple[float, float] | None:
        return float(self.positions[0]), float(self.positions[-1])

    def describe(self) -> str:
        return f"table of {len(self.positions)} points, {self.positions[0]:g} … {self.positions[-1]:g}"


@dataclass(frozen=True)
class Polynomial:
    """Σ c_k (x − origin)^k, coefficients from the constant term up."""

    coefficients: tuple[float, ...]
    origin: float = 0.0

    def __post_init__(self) -> None:
        if not self.coefficients or not all(np.isfinite(c) for c in self.coefficients):
            raise ValueError("a polynomial needs at least one finite coefficient")

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        u = np.asarray(x, dtype=float) - self.origin
        out = np.zeros(u.shape)
        for c in reversed(self.coefficients):  # Horner
            out = out * u + c
        return out

    @property
    def domain(self) -> tuple[float, float] | None:
        return None

    def describe(self) -> str:
        terms = " + ".join(f"{c:g}·u^{k}" if k else f"{c:g}" for k, c in enumerate(self.coefficients))
        return f"polynomial {terms}, u = x − {self.origin:g}"


Curve = Constant | Table | Polynomial
