"""Reference straight lines and straightness values (ISO 230-1 section 2.1 of
standards.md).  Straightness = largest positive + |largest negative| deviation
from the stated reference line.  x in mm, heights in um.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError


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


# Above this many points the hull is found by qhull first (C speed); the chain
# below then runs on its vertices only.
QHULL_ABOVE = 2000


def _chain(x: np.ndarray, z: np.ndarray, upper: bool) -> np.ndarray:
    """Indices of the upper (or lower) convex hull of points with strictly increasing x
    (Andrew's monotone chain; collinear points dropped)."""
    sign = 1.0 if upper else -1.0
    hull: list[int] = []
    xs, zs = x.tolist(), z.tolist()
    for i in range(len(xs)):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            cross = (xs[b] - xs[a]) * (zs[i] - zs[a]) - (zs[b] - zs[a]) * (xs[i] - xs[a])
            if sign * cross >= 0:  # b is not strictly above (below) the chord a-i
                hull.pop()
            else:
                break
        hull.append(i)
    return np.asarray(hull, dtype=np.intp)


def _prefilter(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of the points that can be hull vertices, for strictly increasing x.

    The points maximising (minimising) z - t x for a set of slopes t are upper
    (lower) hull vertices; the upper hull lies on or above the polyline through
    such vertices, so a point strictly below it is no upper-hull vertex (and
    likewise for the lower hull).  Exact; it only saves work.
    """
    span = float(x[-1] - x[0])
    b0 = (z[-1] - z[0]) / span
    r = z - b0 * x  # a shear: same hull vertices
    scale = float(np.ptp(r)) / span
    if scale == 0:
        return np.array([0, len(x) - 1])
    t = scale * np.concatenate([-(2.0 ** np.arange(-2, 6)), [0.0], 2.0 ** np.arange(-2, 6)])
    keep = np.zeros(len(x), dtype=bool)
    tol = 1e-12 * (float(np.max(np.abs(r))) + 1.0)
    buf = np.empty_like(r)  # r - t x, one buffer: a large temporary per slope costs page faults, not arithmetic
    for sign in (1.0, -1.0):
        sup = {0, len(x) - 1}
        for ti in t:
            np.multiply(x, -ti, out=buf)
            buf += r
            sup.add(int(np.argmax(buf) if sign > 0 else np.argmin(buf)))
        s = np.array(sorted(sup))
        keep |= sign * (r - np.interp(x, x[s], r[s])) >= -tol
    return np.flatnonzero(keep)


def _candidates(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of a subset of points that contains every hull vertex (for strictly increasing x)."""
    if len(x) <= QHULL_ABOVE:
        return np.arange(len(x))
    sub = _prefilter(x, z)
    if len(sub) <= QHULL_ABOVE:
        return sub
    return sub[_qhull_candidates(x[sub], z[sub])]


def _qhull_candidates(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """qhull's hull vertices (sorted indices), all points if they are (numerically) collinear."""
    span_x, span_z = np.ptp(x), np.ptp(z)
    if span_z == 0:
        return np.array([0, len(x) - 1])
    pts = np.column_stack([(x - x[0]) / span_x, (z - z.min()) / span_z])  # affine: same hull
    try:
        return np.sort(ConvexHull(pts).vertices)  # type: ignore[no-any-return]
    except QhullError:  # all points (numerically) on one line
        return np.arange(len(x))


def hulls(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(upper, lower) hull vertex indices into x, z, each in increasing x.

    Points sharing an x contribute their highest value to the upper hull and
    their lowest to the lower hull (vertical edges have no slope).
    """
    if np.all(np.diff(x) > 0):  # the usual case: one candidate set serves both hulls
        sub = _candidates(x, z)
        return sub[_chain(x[sub], z[sub], True)], sub[_chain(x[sub], z[sub], False)]
    order = np.lexsort((z, x))
    xs = x[order]
    last = np.r_[xs[1:] != xs[:-1], True]   # highest z of each x
    first = np.r_[True, xs[1:] != xs[:-1]]  # lowest z of each x
    out = []
    for keep, upper in ((last, True), (first, False)):
        idx = order[keep]
        sub = _candidates(x[idx], z[idx])
        idx = idx[sub]
        out.append(idx[_chain(x[idx], z[idx], upper)])
    return out[0], out[1]


def minimum_zone_line(x: np.ndarray, h: np.ndarray) -> LineFit:
    """Minimum-zone line (standards.md 2.2): two parallel lines enclosing every point
    with the least vertical separation; returns the zone's centre line, so the
    straightness (max - min deviation) equals the zone width.

    Exact: the width w(b) = max(h - b x) - min(h - b x) is convex and piecewise
    linear in the slope b with breakpoints at hull edge slopes, so its minimum is
    at one of them.  For each upper and lower hull edge slope the supporting
    vertex on the opposite hull is found by binary search over that hull's
    monotone edge slopes (rotating calipers, vectorised); O(N log N).
    """
    x, h = _check(x, h, 2)
    if np.all(x == x[0]):
        raise ValueError("all points have the same x")
    up, lo = hulls(x, h)
    xu, hu, xl, hl = x[up], h[up], x[lo], h[lo]
    su = np.diff(hu) / np.diff(xu)   # decreasing along the upper hull
    sl = np.diff(hl) / np.diff(xl)   # increasing along the lower hull
    slopes = np.concatenate([su, sl])
    if len(slopes) == 0:  # a single distinct x cannot happen here; two points give one edge
        raise ValueError("cannot fit a line")
    iu = np.searchsorted(-su, -slopes, side="left")  # vertex maximising h - b x on the upper hull
    il = np.searchsorted(sl, slopes, side="left")    # vertex minimising h - b x on the lower hull
    top = hu[iu] - slopes * xu[iu]
    bottom = hl[il] - slopes * xl[il]
    k = int(np.argmin(top - bottom))
    b = float(slopes[k])
    r = h - b * x
    return _fit("minimum_zone", x, h, b, (float(r.max()) + float(r.min())) / 2)


def minimum_zone_many(x: np.ndarray, h_rows: np.ndarray, pair_limit: int = 40) -> np.ndarray:
    """Minimum-zone straightness of every row of ``h_rows`` (shape (m, n)) at the same x.

    For n <= ``pair_limit`` points it evaluates the zone width at every
    point-pair slope at once (the breakpoints of the convex, piecewise-linear
    width function include its minimum: exact, vectorised over rows); above
    that, :func:`minimum_zone_line` row by row.
    """
    x = np.asarray(x, dtype=float)
    h_rows = np.atleast_2d(np.asarray(h_rows, dtype=float))
    n = len(x)
    if n > pair_limit:
        return np.array([minimum_zone_line(x, row).straightness_um for row in h_rows])
    i, j = np.triu_indices(n, 1)
    keep = x[j] != x[i]
    i, j = i[keep], j[keep]
    out = np.empty(len(h_rows))
    step = max(1, 4_000_000 // max(1, len(i) * n))
    for s in range(0, len(h_rows), step):
        h = h_rows[s:s + step]
        b = (h[:, j] - h[:, i]) / (x[j] - x[i])                 # (m, pairs)
        r = h[:, None, :] - b[:, :, None] * x[None, None, :]   # (m, pairs, n)
        out[s:s + step] = np.min(r.max(axis=2) - r.min(axis=2), axis=1)
    return out
