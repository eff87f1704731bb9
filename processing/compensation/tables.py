"""Compensation tables from per-target mean deviations.

An :class:`ErrorTable` holds the *modelled error* e = actual − commanded at table positions, per
direction (it is not yet a correction: each controller's writer converts it with that
controller's documented sign, standards.md §4.0).  Positions in the axis unit (mm or deg),
errors in the deviation unit (um or arcsec).

Two ways to represent direction dependence:

* ``bidirectional`` – separate ↑ and ↓ curves, each modelled on its own (seed 003);
* ``backlash`` – one curve, the mean ē = (x̄↑ + x̄↓)/2, plus the mean reversal value
  B̄ = mean(x̄_i↑ − x̄_i↓) (ISO 230-2 B̄) for the controller's backlash parameter.  Seen as
  directional curves this is e↑ = ē + B̄/2, e↓ = ē − B̄/2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .models import ErrorModel, fit_model

MODES = ("bidirectional", "backlash")


@dataclass(frozen=True)
class DirectionalData:
    """Measured per-target means of one axis, unmeasured values dropped per direction."""

    x_up: np.ndarray
    e_up: np.ndarray
    x_down: np.ndarray
    e_down: np.ndarray


def split_directions(target: np.ndarray, mean_up: np.ndarray, mean_down: np.ndarray) -> DirectionalData:
    """Drop NaN means per direction; a direction with no measured point takes the other one
    (unidirectional run: the same curve for both travel directions)."""
    target = np.asarray(target, dtype=float)
    up = np.asarray(mean_up, dtype=float)
    dn = np.asarray(mean_down, dtype=float)
    if not (target.shape == up.shape == dn.shape) or target.ndim != 1:
        raise ValueError("target, mean_up and mean_down must be 1-D arrays of the same length")
    if not np.all(np.isfinite(target)):
        raise ValueError("every target position must be a finite number")
    order = np.argsort(target, kind="stable")
    target, up, dn = target[order], up[order], dn[order]
    if np.any(np.diff(target) <= 0):
        raise ValueError("targets must be distinct")
    mu, md = np.isfinite(up), np.isfinite(dn)
    if not mu.any() and not md.any():
        raise ValueError("no measured mean deviation in either direction")
    if not mu.any():
        mu, up = md, dn
    if not md.any():
        md, dn = mu, up
    return DirectionalData(target[mu], up[mu], target[md], dn[md])


@dataclass(frozen=True)
class ErrorTable:
    """Modelled error at table positions.

    ``position`` is in mm (deg); ``error_up`` / ``error_down`` are e = actual − commanded for
    + and − travel in the unit of the measured means (um, or arcsec for a rotary axis).  In
    ``backlash`` mode both hold the mean curve ē and ``backlash`` holds B̄ (same unit); use
    :meth:`directional` for the per-direction curves a controller without a separate
    backlash parameter needs.
    """

    position: np.ndarray
    error_up: np.ndarray
    error_down: np.ndarray
    mode: str
    model: str
    backlash: float = 0.0

    def directional(self) -> tuple[np.ndarray, np.ndarray]:
        """(e↑, e↓) with the backlash folded in (identity in bidirectional mode)."""
        if self.mode == "backlash":
            half = self.backlash / 2.0
            return self.error_up + half, self.error_down - half
        return self.error_up, self.error_down

    def __len__(self) -> int:
        return len(self.position)


@dataclass(frozen=True)
class FittedCurves:
    """The fitted model(s): ``up``/``down`` in bidirectional mode, ``mean`` (both fields) in
    backlash mode."""

    up: ErrorModel
    down: ErrorModel
    mode: str
    backlash: float

    def nodes(self) -> np.ndarray:
        return np.union1d(self.up.nodes, self.down.nodes)


def fit_curves(
    target: np.ndarray,
    mean_up: np.ndarray,
    mean_down: np.ndarray,
    *,
    model: str = "linear",
    mode: str = "bidirectional",
    hint: FittedCurves | None = None,
    **model_options: object,
) -> FittedCurves:
    """Fit ``model`` to the measured means (target in mm/deg, means in um/arcsec).  ``hint``:
    the same fit with one target more (leave-one-out; see :func:`~.models.fit_model`)."""
    if mode not in MODES:
        raise ValueError(f"unknown table mode {mode!r}; choose one of {', '.join(MODES)}")
    d = split_directions(target, mean_up, mean_down)
    hint_up, hint_down = (hint.up, hint.down) if hint is not None else (None, None)
    if mode == "bidirectional":
        up = fit_model(model, d.x_up, d.e_up, hint=hint_up, **model_options)  # type: ignore[arg-type]
        down = fit_model(model, d.x_down, d.e_down, hint=hint_down, **model_options)  # type: ignore[arg-type]
        return FittedCurves(up, down, mode, 0.0)
    both = np.intersect1d(d.x_up, d.x_down)
    if len(both) < 2:
        raise ValueError("backlash mode needs at least 2 targets measured in both directions")
    e_up = d.e_up[np.isin(d.x_up, both)]
    e_dn = d.e_down[np.isin(d.x_down, both)]
    mean = fit_model(model, both, (e_up + e_dn) / 2.0, hint=hint_up, **model_options)  # type: ignore[arg-type]
    return FittedCurves(mean, mean, mode, float(np.mean(e_up - e_dn)))


def equidistant_grid(start: float, stop: float, step: float, *, anchor: float | None = None,
                     inside: bool = False) -> np.ndarray:
    """Equidistant positions ``anchor + k·step`` (``anchor`` defaults to ``start``):

    * covering [start, stop]: the first point at or below ``start``, the last at or above ``stop``;
    * ``inside``: only the points within [start, stop] (to 1e-9 of the range), so a table on the
      grid never reaches outside the measured range (``anchor`` need not lie inside)."""
    if not (step > 0 and np.isfinite(step)):
        raise ValueError("grid step must be a positive number")
    if stop < start:
        raise ValueError("grid stop must not be below its start")
    a = start if anchor is None else anchor
    eps = 1e-9 * max(1.0, abs(start), abs(stop), abs(a)) / step
    lo, hi = (start - a) / step, (stop - a) / step
    if inside:
        k0, k1 = int(np.ceil(lo - eps)), int(np.floor(hi + eps))
    else:
        k0, k1 = int(np.floor(lo + eps)), int(np.ceil(hi - eps))
    return a + step * np.arange(k0, k1 + 1, dtype=float)


def floor_to(value: float, resolution: float) -> float:
    """The largest whole multiple of ``resolution`` not above ``value`` (to 1e-9 of a
    resolution step, so 0.3 / 0.001 is 300 steps, not 299)."""
    if not resolution > 0:
        raise ValueError("resolution must be positive")
    return round(float(np.floor(value / resolution + 1e-9)) * resolution, 12)


def tabulate(curves: FittedCurves, positions: np.ndarray | None = None) -> ErrorTable:
    """Evaluate the fitted curves at ``positions`` (default: the models' own nodes - measured
    targets, or breakpoints for the segment model)."""
    pos = curves.nodes() if positions is None else np.asarray(positions, dtype=float)
    if pos.ndim != 1 or len(pos) < 1 or np.any(np.diff(pos) <= 0):
        raise ValueError("table positions must be strictly increasing")
    return ErrorTable(
        position=pos,
        error_up=np.asarray(curves.up(pos), dtype=float),
        error_down=np.asarray(curves.down(pos), dtype=float),
        mode=curves.mode,
        model=curves.up.name,
        backlash=curves.backlash,
    )


def build_table(
    target: np.ndarray,
    mean_up: np.ndarray,
    mean_down: np.ndarray,
    *,
    model: str = "linear",
    mode: str = "bidirectional",
    positions: np.ndarray | None = None,
    **model_options: object,
) -> ErrorTable:
    """Fit and tabulate in one call (see :func:`fit_curves`, :func:`tabulate`)."""
    curves = fit_curves(target, mean_up, mean_down, model=model, mode=mode, **model_options)
    return tabulate(curves, positions)
