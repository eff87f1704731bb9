"""Models of an axis error curve e(x) from per-target mean deviations.

Units: positions ``x`` in the axis unit (mm, or deg for a rotary axis); errors ``e`` in the
deviation unit (um, or arcsec), e = actual − commanded (ISO 230-2 x̄_i, standards.md §4.0).
Every model evaluates at arbitrary positions; outside the measured range it holds the value at
the nearest end (as CNC compensation tables do), it never extrapolates.

Models (standards.md §5, seeds 003 and 004):

* ``linear``     – straight lines between the measured means;
* ``spline``     – natural cubic spline with adaptive knots (seed 003, :func:`fit_adaptive_spline`);
* ``segments``   – piecewise least-squares line segments, threshold max|e|/20 (seed 004,
  :func:`fit_segments`);
* ``polynomial`` – least-squares polynomial of a given degree, lowered to n − 2 (at least 1)
  when there are only n < degree + 2 points (:func:`polynomial_degree`).

Forward (↑) and reverse (↓) curves are modelled separately by fitting each on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.linalg import get_lapack_funcs

MODEL_NAMES = ("linear", "spline", "segments", "polynomial")
DEFAULT_POLYNOMIAL_DEGREE = 6  # seed 003 compares against a 6th-order polynomial
THRESHOLD_FRACTION = 1.0 / 20.0  # seed 004: threshold = 1/20 of the largest measured |e|


def _check_xy(x: np.ndarray, e: np.ndarray, need: int = 2) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float)
    e = np.asarray(e, dtype=float)
    if x.ndim != 1 or x.shape != e.shape:
        raise ValueError("positions and errors must be 1-D arrays of the same length")
    if len(x) < need:
        raise ValueError(f"need at least {need} measured points to model an error curve, got {len(x)}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(e))):
        raise ValueError("positions and errors must be finite (drop unmeasured targets first)")
    if np.any(np.diff(x) <= 0):
        raise ValueError("positions must be strictly increasing")
    return x, e


def default_threshold(e: np.ndarray) -> float:
    """Seed 004's threshold: max|e| / 20 (same unit as ``e``)."""
    return float(np.max(np.abs(np.asarray(e, dtype=float)))) * THRESHOLD_FRACTION


@dataclass(frozen=True)
class ErrorModel:
    """A fitted error curve.

    ``nodes`` are the positions a non-equidistant table needs to reproduce the model with
    linear interpolation as exactly as the model allows: the measured targets (linear), the
    breakpoints (segments), the measured targets again for the smooth models (a table samples
    them; resample on a finer grid for a closer match).
    """

    name: str
    x: np.ndarray  # measured positions the model was fitted to
    e: np.ndarray  # measured errors
    nodes: np.ndarray

    def _eval(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        xq = np.clip(np.asarray(x, dtype=float), self.x[0], self.x[-1])
        return self._eval(xq)

    @property
    def residual(self) -> np.ndarray:
        """Measured minus modelled error at the measured positions."""
        return self.e - self(self.x)


@dataclass(frozen=True)
class LinearModel(ErrorModel):
    def _eval(self, x: np.ndarray) -> np.ndarray:
        return np.interp(x, self.x, self.e)


def fit_linear(x: np.ndarray, e: np.ndarray) -> LinearModel:
    x, e = _check_xy(x, e)
    return LinearModel("linear", x, e, x.copy())


@dataclass(frozen=True)
class SplineModel(ErrorModel):
    knots: np.ndarray  # indices into x of the interpolation knots, ascending
    tolerance: float
    iterations: int
    spline: CubicSpline

    def _eval(self, x: np.ndarray) -> np.ndarray:
        return self.spline(x)


def curvature(u: np.ndarray, e: np.ndarray) -> np.ndarray:
    """κ_i = |e''| / (1 + e'²)^(3/2), derivatives by finite differences over the parameter ``u``
    (standards.md §5.1)."""
    d1 = np.gradient(e, u)
    d2 = np.gradient(d1, u)
    return np.abs(d2) / (1.0 + d1**2) ** 1.5


def curvature_maxima(e: np.ndarray) -> np.ndarray:
    """Indices of the interior local curvature maxima (κ_i > κ_{i−1} and κ_i > κ_{i+1}),
    largest curvature first (ties: lower index first).

    The curvature is taken over the uniform parameter u_i = i (seed 003 parameterises the
    measured points uniformly), so the knot choice does not depend on the position unit.
    """
    e = np.asarray(e, dtype=float)
    k = curvature(np.arange(len(e), dtype=float), e)
    idx = np.flatnonzero((k[1:-1] > k[:-2]) & (k[1:-1] > k[2:])) + 1
    order = np.lexsort((idx, -k[idx]))
    return idx[order]


_GTSV = get_lapack_funcs("gtsv", (np.zeros(1),))


def _natural_spline(x: np.ndarray, e: np.ndarray, knots: np.ndarray) -> CubicSpline:
    """The natural cubic spline through (x, e) at ``knots`` (indices, ascending), as
    ``CubicSpline(x[knots], e[knots], bc_type="natural")``.

    For three knots or more the spline is built without CubicSpline's input checks and
    dispatch (x is already checked by the caller; this is most of the time of a fit, which
    cross-validation repeats hundreds of times): the same tridiagonal system for the knot
    slopes, the same LAPACK solver (gtsv) and the same Hermite coefficients, term for term,
    so the result is identical to the bit (tests/processing/test_compensation_models.py)."""
    if len(knots) == 2:  # a natural spline through two points is their straight line
        return CubicSpline(x[knots], e[knots], bc_type="not-a-knot")
    xk, yk = x[knots], e[knots]
    dx = np.diff(xk)
    slope = np.diff(yk) / dx
    # rows 1 .. n-2: dx[i] s[i-1] + 2 (dx[i-1] + dx[i]) s[i] + dx[i-1] s[i+1] = 3 (dx[i] g[i-1] + dx[i-1] g[i]);
    # natural ends (S'' = 0): 2 dx[0] s[0] + dx[0] s[1] = 3 (y[1] - y[0]), likewise at the end
    diag = np.empty(len(xk))
    diag[1:-1] = 2 * (dx[:-1] + dx[1:])
    diag[0], diag[-1] = 2 * dx[0], 2 * dx[-1]
    upper = np.concatenate((dx[:1], dx[:-1]))
    lower = np.concatenate((dx[1:], dx[-1:]))
    rhs = np.empty(len(xk))
    rhs[1:-1] = 3 * (dx[1:] * slope[:-1] + dx[:-1] * slope[1:])
    rhs[0], rhs[-1] = 3 * (yk[1] - yk[0]), 3 * (yk[-1] - yk[-2])
    _, _, _, s, info = _GTSV(lower, diag, upper, rhs, True, True, True, True)
    if info != 0:  # pragma: no cover - the system is diagonally dominant for increasing knots
        return CubicSpline(xk, yk, bc_type="natural")
    t = (s[:-1] + s[1:] - 2 * slope) / dx
    c = np.stack((t / dx, (slope - s[:-1]) / dx - t, s[:-1], yk[:-1]))
    return CubicSpline.construct_fast(c, xk, extrapolate=True)


def fit_adaptive_spline(
    x: np.ndarray,
    e: np.ndarray,
    *,
    tolerance: float | None = None,
    initial_maxima: int | None = None,
) -> SplineModel:
    """Natural cubic spline with adaptively chosen knots (seed 003, standards.md §5.1).

    1. Initial knots: both end points plus the ``initial_maxima`` largest local curvature
       maxima (all of them when ``None``; curvature over the uniform parameter, see
       :func:`curvature_maxima`).
    2. Interpolate the knots with a natural cubic spline of e over x (S'' = 0 at both end
       knots).
    3. Every measured point whose |residual| exceeds ``tolerance`` becomes a knot (batch
       insertion, as in seed 003: "the error data points whose residual exceeds the allowed
       residual are added as new knots"); repeat from 2 until all |residual| ≤ ``tolerance``
       at the points that are not knots (a knot's residual is zero but for rounding).

    ``tolerance`` is in the unit of ``e`` (default max|e|/20).  Terminates: each pass adds at
    least one knot, and with every point a knot none is left to add (``tolerance = 0``: the
    spline through every point).
    """
    x, e = _check_xy(x, e)
    tol = default_threshold(e) if tolerance is None else float(tolerance)
    if tol < 0:
        raise ValueError("spline tolerance must be >= 0")
    maxima = curvature_maxima(e) if len(x) >= 3 else np.array([], dtype=int)
    if initial_maxima is not None:
        if initial_maxima < 0:
            raise ValueError("number of initial curvature maxima must be >= 0")
        maxima = maxima[:initial_maxima]
    is_knot = np.zeros(len(x), dtype=bool)
    is_knot[[0, len(x) - 1]] = True
    is_knot[maxima] = True
    knots = np.flatnonzero(is_knot)
    iterations = 0
    while True:
        iterations += 1
        spline = _natural_spline(x, e, knots)
        r = np.abs(e - spline(x))
        over = np.flatnonzero((r > tol) & ~is_knot)  # a knot's rounding residual would add nothing, forever
        if over.size == 0:
            break
        is_knot[over] = True
        knots = np.flatnonzero(is_knot)
    return SplineModel("spline", x, e, x.copy(), knots, tol, iterations, spline)


@dataclass(frozen=True)
class SegmentModel(ErrorModel):
    breakpoints: np.ndarray  # indices into x; segment s spans breakpoints[s] .. breakpoints[s+1]
    threshold: float
    node_values: np.ndarray  # polyline values at the breakpoints

    def _eval(self, x: np.ndarray) -> np.ndarray:
        return np.interp(x, self.nodes, self.node_values)

    @property
    def segments(self) -> list[tuple[int, int]]:
        """(first, last) index of each segment; adjacent segments share their end point."""
        b = self.breakpoints
        return [(int(b[i]), int(b[i + 1])) for i in range(len(b) - 1)]


def _ls_line_max_residual(x: np.ndarray, e: np.ndarray) -> float:
    if len(x) <= 2:
        return 0.0
    xm = x.mean()
    sxx = float(np.sum((x - xm) ** 2))
    slope = float(np.sum((x - xm) * (e - e.mean()))) / sxx
    return float(np.max(np.abs(e - (e.mean() + slope * (x - xm)))))


def segment_breakpoints(x: np.ndarray, e: np.ndarray, threshold: float) -> np.ndarray:
    """Greedy sliding-window segmentation (seed 004, standards.md §5.2).

    A segment starts at point i and grows to j while the least-squares line through points
    i … j keeps every |residual| ≤ ``threshold``; when point j+1 would break the bound the
    segment closes at j and the next one starts at j (shared breakpoint).  Returns the
    breakpoint indices, first and last point included.
    """
    n = len(x)
    bps = [0]
    start = 0
    while start < n - 1:
        end = _segment_end(x, e, start, threshold)
        bps.append(end)
        start = end
    return np.asarray(bps, dtype=int)


def _segment_end(x: np.ndarray, e: np.ndarray, start: int, threshold: float) -> int:
    """The last point of the segment that starts at ``start``: the windows start … t are tested
    for t = start + 2, start + 3, … (two points always lie on their line); the segment ends
    before the first window whose least-squares line misses a point by more than
    ``threshold``.  The windows are tested a chunk at a time (one row per window, the same
    centred formulas as :func:`_ls_line_max_residual`), which keeps long axes fast."""
    n = len(x)
    lo, chunk = start + 2, 16
    while lo < n:
        hi = min(n, lo + chunk)
        xs, es = x[start:hi], e[start:hi]
        last = np.arange(lo, hi) - start  # last index of each window, local
        mask = np.arange(hi - start)[None, :] <= last[:, None]
        count = last + 1.0
        dx = np.where(mask, xs[None, :] - (np.where(mask, xs, 0.0).sum(axis=1) / count)[:, None], 0.0)
        de = np.where(mask, es[None, :] - (np.where(mask, es, 0.0).sum(axis=1) / count)[:, None], 0.0)
        slope = (dx * de).sum(axis=1) / (dx * dx).sum(axis=1)
        worst = np.max(np.abs(de - slope[:, None] * dx), axis=1)
        fail = np.flatnonzero(worst > threshold)
        if fail.size:
            return int(lo + fail[0] - 1)
        lo, chunk = hi, chunk * 2
    return n - 1


def _one_point_less(hint: SegmentModel, x: np.ndarray, e: np.ndarray) -> int | None:
    """The index i such that (x, e) is ``hint``'s data without point i, or None."""
    if len(x) != len(hint.x) - 1:
        return None
    differ = np.flatnonzero(x != hint.x[:-1])
    i = int(differ[0]) if differ.size else len(x)
    same = np.array_equal(x, np.delete(hint.x, i)) and np.array_equal(e, np.delete(hint.e, i))
    return i if same else None


def _breakpoints_without(hint: SegmentModel, x: np.ndarray, e: np.ndarray, i: int, tau: float) -> np.ndarray:
    """:func:`segment_breakpoints` of ``hint``'s data without point i, computed again only where
    it can differ.  A segment of the full data that ends at b ≤ i − 2 was closed by a window
    (its start … b + 1) that does not contain point i, so every breakpoint up to the last such b
    stays; the greedy search restarts there and stops as soon as it closes a segment at a
    breakpoint the full data has after point i (from there on both see the same points)."""
    full = [int(b) for b in hint.breakpoints]
    kept = [b for b in full if b <= i - 2] or [0]
    later = {b - 1 for b in full if b > i}  # full-data breakpoints after i, in the shorter data's indices
    bps, start, n = list(kept), kept[-1], len(x)
    while start < n - 1:
        start = _segment_end(x, e, start, tau)
        bps.append(start)
        if start >= i and start in later:
            bps += [b - 1 for b in full if b - 1 > start]
            break
    return np.asarray(bps, dtype=int)


def fit_segments(x: np.ndarray, e: np.ndarray, *, threshold: float | None = None,
                 hint: SegmentModel | None = None) -> SegmentModel:
    """Piecewise least-squares line segments (seed 004), ``threshold`` in the unit of ``e``
    (default max|e|/20).

    The table stores one value per breakpoint.  The values are those of the continuous
    least-squares polyline with these breakpoints (a linear LSQ spline), so the modelled curve
    is continuous and as close as a polyline on these nodes can be in the least-squares sense.

    ``hint``: a model fitted to these data plus one more point (leave-one-out refits); the
    breakpoints far from the missing point are taken from it (the result is the same as
    without the hint, only faster).
    """
    x, e = _check_xy(x, e)
    tau = default_threshold(e) if threshold is None else float(threshold)
    if tau < 0:
        raise ValueError("segment threshold must be >= 0")
    i = _one_point_less(hint, x, e) if hint is not None and hint.threshold == tau else None
    bps = segment_breakpoints(x, e, tau) if i is None else _breakpoints_without(hint, x, e, i, tau)  # type: ignore[arg-type]
    nodes = x[bps]
    return SegmentModel("segments", x, e, nodes, bps, tau, _lsq_polyline(x, e, nodes))


def _lsq_polyline(x: np.ndarray, e: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Values at ``nodes`` (ascending data positions, the first and the last of ``x`` among
    them) of the continuous polyline closest to (x, e) in the least-squares sense: the linear
    least-squares spline on the hat functions B_j of the nodes.

    A point in [t_s, t_s+1] has B_s = 1 − w, B_s+1 = w (w its fraction of the interval), so the
    normal equations are tridiagonal: Σ B_s², Σ B_s B_s+1 and Σ B_s e summed per interval.  A
    point at every node keeps them well conditioned (each diagonal term ≥ 1).  The same values
    as scipy's make_lsq_spline(k=1) to rounding, in a fraction of its time (cross-validation
    refits this hundreds of times; tests/processing/test_compensation_models.py)."""
    n = len(nodes)
    s = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, n - 2)
    w = (x - nodes[s]) / (nodes[s + 1] - nodes[s])
    v = 1.0 - w
    diag = np.bincount(s, v * v, n) + np.bincount(s + 1, w * w, n)
    off = np.bincount(s, v * w, n - 1)
    rhs = np.bincount(s, v * e, n) + np.bincount(s + 1, w * e, n)
    _, _, _, values, info = _GTSV(off, diag, off.copy(), rhs, False, True, False, True)
    if info != 0:  # pragma: no cover - a hat with a point at its node has a positive diagonal
        raise ValueError("the segment nodes do not determine a least-squares polyline")
    return values


@dataclass(frozen=True)
class PolynomialModel(ErrorModel):
    degree: int
    polynomial: np.polynomial.Polynomial

    def _eval(self, x: np.ndarray) -> np.ndarray:
        return self.polynomial(x)


def fit_polynomial(x: np.ndarray, e: np.ndarray, *, degree: int = DEFAULT_POLYNOMIAL_DEGREE) -> PolynomialModel:
    """Least-squares polynomial of ``degree`` (domain scaled to [−1, 1] for conditioning)."""
    if degree < 0:
        raise ValueError("polynomial degree must be >= 0")
    x, e = _check_xy(x, e, need=degree + 1)
    poly = np.polynomial.Polynomial.fit(x, e, degree)
    return PolynomialModel("polynomial", x, e, x.copy(), degree, poly)


def polynomial_degree(requested: int, n_points: int) -> int:
    """The degree actually fitted: min(requested, n_points − 2), at least 1 (never above the
    request).  n − 2 keeps one degree of freedom for the least-squares fit, so a 5-target run
    with the default degree 6 gets degree 3 instead of no model at all."""
    if requested < 0:
        raise ValueError("polynomial degree must be >= 0")
    return min(requested, max(n_points - 2, 1))


def fit_model(
    name: str,
    x: np.ndarray,
    e: np.ndarray,
    *,
    tolerance: float | None = None,
    initial_maxima: int | None = None,
    degree: int = DEFAULT_POLYNOMIAL_DEGREE,
    hint: ErrorModel | None = None,
) -> ErrorModel:
    """Fit the model called ``name`` (one of :data:`MODEL_NAMES`).  ``tolerance`` is the spline
    tolerance or the segment threshold (unit of ``e``, default max|e|/20).  The polynomial's
    degree is reduced to :func:`polynomial_degree` when there are too few points for it.
    ``hint``: the same model fitted to these data plus one point (speeds up leave-one-out
    refits of the segment model; the result does not depend on it)."""
    if name == "linear":
        return fit_linear(x, e)
    if name == "spline":
        return fit_adaptive_spline(x, e, tolerance=tolerance, initial_maxima=initial_maxima)
    if name == "segments":
        return fit_segments(x, e, threshold=tolerance, hint=hint if isinstance(hint, SegmentModel) else None)
    if name == "polynomial":
        return fit_polynomial(x, e, degree=polynomial_degree(degree, len(np.atleast_1d(x))))
    raise ValueError(f"unknown model {name!r}; choose one of {', '.join(MODEL_NAMES)}")
