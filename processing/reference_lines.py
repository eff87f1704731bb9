"""Reference straight lines and straightness values (ISO 230-1 section 2.1 of
standards.md).  Straightness = largest positive + |largest negative| deviation
from the stated reference line.  x in mm, heights in um.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LineFit:
    """A reference line h = intercept_um + slope_um_per_mm * x and the deviations from it."""

    method: str
    slope_um_per_mm: float
    intercept_um: float
    deviations_um: np.ndarray

    @property
    def straightness_um(self) -> float:
        return float(np.max(self.deviations_um) - np.min(self.deviations_um))


def _fit(method: str, x: np.ndarray, h: np.ndarray, slope: float, intercept: float) -> LineFit:
    return LineFit(method, float(slope), float(intercept), h - (intercept + slope * x))


def _check(x: np.ndarray, h: np.ndarray, need: int) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float)
    h = np.asarray(h, dtype=float)
    if x.shape != h.shape or x.ndim != 1:
        raise ValueError("x and h must be 1-D arrays of the same length")
    if len(x) < need:
        raise ValueError(f"a reference line needs at least {need} points, got {len(x)}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(h))):
        raise ValueError("x and h must be finite")
    return x, h


def endpoint_line(x: np.ndarray, h: np.ndarray) -> LineFit:
    """Line through the first and the last point."""
    x, h = _check(x, h, 2)
    if x[-1] == x[0]:
        raise ValueError("end points have the same x")
    slope = (h[-1] - h[0]) / (x[-1] - x[0])
    return _fit("endpoint", x, h, slope, h[0] - slope * x[0])


def least_squares_line(x: np.ndarray, h: np.ndarray) -> LineFit:
    """Ordinary least-squares line of h on x."""
    x, h = _check(x, h, 2)
    xm, hm = x.mean(), h.mean()
    sxx = float(np.sum((x - xm) ** 2))
    if sxx == 0:
        raise ValueError("all points have the same x")
    slope = float(np.sum((x - xm) * (h - hm))) / sxx
    return _fit("least_squares", x, h, slope, hm - slope * xm)
