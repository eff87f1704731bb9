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


# Above this many points the hull is found by qhull first (C speed); the chain
# below then runs on its vertices only.
QHULL_ABOVE = 2000


def _chain(x: np.ndarray, z: np.ndarray, upper: bool) -> np.ndarray:
    """Indices of the upper (or lower) convex hull of points with strictly increasing x
    (Andrew's monotone chain; collinear points dropped)."""
    sign = 1.0 if upper else -1.0  # pragma: no mutate (equivalent: only the sign of sign * cross counts)
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
    return np.asarray(hull, dtype=np.intp)  # pragma: no mutate (equivalent: int list)


def _prefilter(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of the points that can be hull vertices, for strictly increasing x.

    The points maximising (minimising) z - t x for a set of slopes t are upper
    (lower) hull vertices; the upper hull lies on or above the polyline through
    such vertices, so a point strictly below it is no upper-hull vertex (and
    likewise for the lower hull).  Exact; it only saves work.

    It stays exact whatever the shear, the slopes t or the support points chosen, as long as
    they are points of the set and include both ends (the ``no mutate`` lines below): a point
    dropped by the upper pass lies strictly below a chord of two points, so it is no upper
    vertex, and the lower pass, whose polyline never lies above the upper one, keeps it if it
    is a lower vertex; an end left out of the starting support is compared by both passes with
    the same next point (unless a pass picked the end itself), so one of them keeps it.  Only
    the tolerance and the collinear shortcut can change the result.
    """
    span = float(x[-1] - x[0])  # pragma: no mutate (equivalent: any shear)
    b0 = (z[-1] - z[0]) / span  # pragma: no mutate (equivalent: any shear)
    r = z - b0 * x  # pragma: no mutate (equivalent: any shear); a shear: same hull vertices
    scale = float(np.ptp(r)) / span  # pragma: no mutate (equivalent: any slope set)
    if scale == 0:
        return np.array([0, len(x) - 1])
    ladder = 2.0 ** np.arange(-2, 6)  # pragma: no mutate (equivalent: any slope set)
    t = scale * np.concatenate([-ladder, [0.0], ladder])  # pragma: no mutate (equivalent: any slope set)
    keep = np.zeros(len(x), dtype=bool)
    tol = 1e-12 * (float(np.max(np.abs(r))) + 1.0)  # pragma: no mutate (equivalent: larger keeps more)
    buf = np.empty_like(r)  # r - t x, one buffer: a large temporary per slope costs page faults, not arithmetic
    for sign in (1.0, -1.0):
        sup = {0, len(x) - 1}  # pragma: no mutate (equivalent: the other pass keeps the end)
        for ti in t:
            np.multiply(x, -ti, out=buf)  # pragma: no mutate (equivalent: any support set)
            buf += r  # pragma: no mutate (equivalent: any support set)
            sup.add(int(np.argmax(buf) if sign > 0 else np.argmin(buf)))  # pragma: no mutate (equivalent)
        s = np.array(sorted(sup))
        keep |= sign * (r - np.interp(x, x[s], r[s])) >= -tol
    return np.flatnonzero(keep)


def _candidates(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of a subset of points that contains every hull vertex (for strictly increasing x)."""
    if len(x) <= QHULL_ABOVE:  # pragma: no mutate (equivalent: both paths exact)
        return np.arange(len(x))
    sub = _prefilter(x, z)
    if len(sub) <= QHULL_ABOVE:  # pragma: no mutate (equivalent: both paths exact)
        return sub
    return sub[_qhull_candidates(x[sub], z[sub])]


def _qhull_candidates(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """qhull's hull vertices (sorted indices), all points if they are (numerically) collinear."""
    span_x, span_z = np.ptp(x), np.ptp(z)
    if span_z == 0:
        return np.array([0, len(x) - 1])
    from scipy.spatial import ConvexHull, QhullError  # here: scipy.spatial takes ~0.1 s to import, rarely needed

    # affine: same hull
    pts = np.column_stack([(x - x[0]) / span_x, (z - z.min()) / span_z])  # pragma: no mutate (equivalent: affine)
    try:
        return np.sort(ConvexHull(pts).vertices)  # type: ignore[no-any-return]
    except QhullError:  # all points (numerically) on one line
        return np.arange(len(x))


def hulls(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(upper, lower) hull vertex indices into x, z, each in increasing x.

    Points sharing an x contribute their highest value to the upper hull and
    their lowest to the lower hull (vertical edges have no slope).
    """
    # the usual case: one candidate set serves both hulls (the general path below gives the same)
    if np.all(np.diff(x) > 0):  # pragma: no mutate (equivalent: the general path is exact too)
        sub = _candidates(x, z)
        upper = _chain(x[sub], z[sub], True)
        return sub[upper], sub[_chain(x[sub], z[sub], False)]  # pragma: no mutate (equivalent: None is falsy)
    order = np.lexsort((z, x))
    xs = x[order]
    # highest z of each x (pragma: a lower repeat kept by mistake would be popped by the upper chain)
    last = np.r_[xs[1:] != xs[:-1], True]  # pragma: no mutate (equivalent)
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
    if np.all(x == x[0]):  # pragma: no mutate (equivalent: x == x[1] everywhere iff x == x[0])
        raise ValueError("all points have the same x")
    up, lo = hulls(x, h)
    xu, hu, xl, hl = x[up], h[up], x[lo], h[lo]
    su = np.diff(hu) / np.diff(xu)   # decreasing along the upper hull
    sl = np.diff(hl) / np.diff(xl)   # increasing along the lower hull
    slopes = np.concatenate([su, sl])
    # a single distinct x is refused above; two points give one edge per hull
    if len(slopes) == 0:  # pragma: no mutate (unreachable)
        raise ValueError("cannot fit a line")  # pragma: no mutate (unreachable)
    # the vertices maximising h - b x on the upper hull and minimising it on the lower hull
    iu = np.searchsorted(-su, -slopes, side="left")  # pragma: no mutate (equivalent: left is the default)
    il = np.searchsorted(sl, slopes, side="left")  # pragma: no mutate (equivalent: left is the default)
    top = hu[iu] - slopes * xu[iu]
    bottom = hl[il] - slopes * xl[il]
    k = int(np.argmin(top - bottom))
    b = float(slopes[k])
    r = h - b * x
    return _fit("minimum_zone", x, h, b, (float(r.max()) + float(r.min())) / 2)


def _hull_rows(x: np.ndarray, z: np.ndarray, upper: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Upper (or lower) convex hull of every row of ``z`` (shape (m, n)) at the strictly increasing ``x``,
    in array form: (x, z, count) with each row's hull vertices left-aligned in increasing x (the
    entries at and after its count are padding).

    Rounds of elimination, vectorised over rows: a point on or below (above) the chord of its two
    surviving neighbours is no strict hull vertex (the chord joins two points of the set), so all
    such points of every row go at once; the survivors are packed to the left and the next round
    runs on them.  When a round removes nothing every interior point is strictly convex: the
    survivors are the hull, collinear points dropped (the vertex set :func:`_chain` returns).  The
    turn test is _chain's cross product on the same three points.
    """
    m, n = z.shape
    sign = 1.0 if upper else -1.0  # pragma: no mutate (equivalent: only the sign of sign * cross counts)
    keep = _record_points(x, sign * z)
    count = keep.sum(axis=1)
    xs, zs = _pack(np.broadcast_to(x, (m, n)), z, keep, count)
    while xs.shape[1] > 2:  # pragma: no mutate (equivalent: >= 2 ends on width 2)
        xa, xb, xi = xs[:, :-2], xs[:, 1:-1], xs[:, 2:]
        za, zb, zi = zs[:, :-2], zs[:, 1:-1], zs[:, 2:]
        cross = (xb - xa) * (zi - za) - (zb - za) * (xi - xa)
        k = np.arange(1, xs.shape[1] - 1)
        drop = (sign * cross >= 0) & (k[None, :] <= count[:, None] - 2)
        if not drop.any():
            break
        keep = np.ones(xs.shape, dtype=bool)
        keep[:, 1:-1] = ~drop
        keep &= np.arange(xs.shape[1])[None, :] < count[:, None]
        count = keep.sum(axis=1)
        xs, zs = _pack(xs, zs, keep, count)
    return xs, zs, count


def _pack(xs: np.ndarray, zs: np.ndarray, keep: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The kept entries of each row moved to the left, in order; each row padded with its last kept point
    (the callers mask everything at and after a row's count, so the padding is never read)."""
    m = len(xs)
    width = int(count.max())
    pos = np.cumsum(keep, axis=1) - 1
    last = np.arange(m), count - 1  # pragma: no mutate (equivalent: padding is never read)
    r, c = np.nonzero(keep)
    nx = np.zeros((m, width))
    nz = np.zeros((m, width))
    nx[r, pos[r, c]] = xs[r, c]
    nz[r, pos[r, c]] = zs[r, c]
    pad = np.arange(width)[None, :] >= count[:, None]  # pragma: no mutate (equivalent: padding is never read)
    nx = np.where(pad, nx[last][:, None], nx)  # pragma: no mutate (equivalent: padding is never read)
    nz = np.where(pad, nz[last][:, None], nz)  # pragma: no mutate (equivalent: padding is never read)
    return nx, nz


def _record_points(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Mask of the points of each row of ``r`` (shape (m, n), strictly increasing shared ``x``) that can
    be upper-hull vertices: exact, it only saves work.

    A point lower than some point on its left and some point on its right lies below the chord of
    those two, so it is no hull vertex.  A shear r - t x keeps the hull's vertices; with t the
    end-point slope a tilted profile keeps few such running maxima (from the left or from the
    right).  The tolerance keeps a vertex whose sheared value rounds below a record.
    """
    span = float(x[-1] - x[0])  # pragma: no mutate (equivalent: any shear)
    rt = np.ascontiguousarray(r.T)  # (n, m): the running maxima then run along contiguous rows of trials
    rc = rt - ((rt[-1] - rt[0]) / span)[None, :] * x[:, None]  # pragma: no mutate (equivalent: any shear)
    left = np.maximum.accumulate(rc, axis=0)  # pragma: no mutate (equivalent: axis 0 is the default)
    right = np.maximum.accumulate(rc[::-1], axis=0)[::-1]  # pragma: no mutate (equivalent: axis 0 is the default)
    # the tolerance
    rc += 1e-12 * (np.max(np.abs(rc), axis=0) + 1.0)  # pragma: no mutate (equivalent: larger keeps more)
    keep = ((rc >= left) | (rc >= right)).T  # pragma: no mutate (equivalent: > differs only at the tolerance edge)
    return keep


def _count_below(sorted_rows: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per row, how many entries of the row of ``sorted_rows`` (increasing, shape (m, e)) are < each
    entry of that row of ``q`` (shape (m, k)): np.searchsorted(row, q_row, side="left"), vectorised
    over rows by a binary search run in step on all of them."""
    m, e = sorted_rows.shape
    lo = np.zeros(q.shape, dtype=np.intp)
    hi = np.full(q.shape, e, dtype=np.intp)  # pragma: no mutate (equivalent: int fill)
    rows = np.arange(m)[:, None]
    while True:
        active = lo < hi
        if not active.any():
            return lo
        mid = (lo + hi) // 2
        # (<= instead of <: at a tie both vertices lie on the same line, the same width)
        below = sorted_rows[rows, np.minimum(mid, e - 1)] < q  # pragma: no mutate (equivalent)
        lo = np.where(active & below, mid + 1, lo)
        hi = np.where(active & ~below, mid, hi)


# Rows x points handled at once by minimum_zone_many (its temporaries are a few dozen of this size).
MANY_BLOCK_ELEMENTS = 500_000


def minimum_zone_many(x: np.ndarray, h_rows: np.ndarray) -> np.ndarray:
    """Minimum-zone straightness of every row of ``h_rows`` (shape (m, n)) at the same x, exact and
    equal to ``minimum_zone_line(x, row).straightness_um`` row by row (same hull, same candidate slopes
    in the same order, the same arithmetic), vectorised over rows.

    The hulls of all rows are found at once (:func:`_hull_rows`); then, as in
    :func:`minimum_zone_line`, each hull edge slope is a candidate, its supporting vertex on either
    hull comes from a binary search over that hull's monotone edge slopes (:func:`_count_below`) and
    the candidate of least width gives the zone.
    """
    x = np.asarray(x, dtype=float)  # unsigned integers would wrap in np.diff
    # every use of h_rows converts it to float (the reduceat max/min do no arithmetic)
    h_rows = np.atleast_2d(np.asarray(h_rows, dtype=float))  # pragma: no mutate (equivalent)
    if h_rows.ndim != 2 or x.ndim != 1 or h_rows.shape[1] != len(x):
        raise ValueError("h_rows must have one column per x")
    _check(x, x, 2)
    if not np.all(np.isfinite(h_rows)):
        raise ValueError("x and h must be finite")
    if np.all(x == x[0]):  # pragma: no mutate (equivalent: x == x[1] everywhere iff x == x[0])
        raise ValueError("all points have the same x")
    out = np.empty(len(h_rows))
    # rows are independent: any block size, or overlapping blocks, give the same values
    step = max(1, MANY_BLOCK_ELEMENTS // len(x))  # pragma: no mutate (equivalent)
    for s in range(0, len(h_rows), step):  # pragma: no mutate (equivalent)
        out[s:s + step] = _zone_block(x, h_rows[s:s + step])
    return out


def _zone_block(x: np.ndarray, h: np.ndarray) -> np.ndarray:
    if np.all(np.diff(x) > 0):  # pragma: no mutate (equivalent: the general path is exact too)
        xu_in = xl_in = x
        hu_in = hl_in = h
    else:  # as hulls(): the highest value of each x for the upper hull, the lowest for the lower
        order = np.argsort(x, kind="stable")  # pragma: no mutate (equivalent: max/min of a group ignore order)
        xs = x[order]
        starts = np.flatnonzero(np.r_[True, xs[1:] != xs[:-1]])
        hs = h[:, order]
        xu_in = xl_in = xs[starts]
        hu_in = np.maximum.reduceat(hs, starts, axis=1)
        hl_in = np.minimum.reduceat(hs, starts, axis=1)
    xu, hu, cu = _hull_rows(xu_in, hu_in, True)
    xl, hl, cl = _hull_rows(xl_in, hl_in, False)  # pragma: no mutate (equivalent: None is falsy)
    # padding: 0/0, masked below
    with np.errstate(invalid="ignore", divide="ignore"):  # pragma: no mutate (equivalent: never x/0)
        # decreasing along each upper hull
        su = np.diff(hu, axis=1) / np.diff(xu, axis=1)  # pragma: no mutate (equivalent: the last axis is the default)
        # increasing along each lower hull
        sl = np.diff(hl, axis=1) / np.diff(xl, axis=1)  # pragma: no mutate (equivalent: the last axis is the default)
    eu = np.arange(su.shape[1])[None, :] < (cu - 1)[:, None]
    el = np.arange(sl.shape[1])[None, :] < (cl - 1)[:, None]
    su = np.where(eu, su, -np.inf)
    sl = np.where(el, sl, np.inf)
    slopes = np.concatenate([su, sl], axis=1)
    valid = np.concatenate([eu, el], axis=1)
    q = np.where(valid, slopes, 0.0)  # pragma: no mutate (equivalent: invalid entries are masked)
    rows = np.arange(len(h))[:, None]
    iu = _count_below(-su, -q)
    il = _count_below(sl, q)
    top = hu[rows, iu] - q * xu[rows, iu]
    bottom = hl[rows, il] - q * xl[rows, il]
    k = np.argmin(np.where(valid, top - bottom, np.inf), axis=1)
    b = q[rows[:, 0], k][:, None]
    r = h - b * x  # as minimum_zone_line: the centre line, then the spread of the deviations from it
    dev = h - ((r.max(axis=1) + r.min(axis=1))[:, None] / 2 + b * x)
    return dev.max(axis=1) - dev.min(axis=1)  # type: ignore[no-any-return]
