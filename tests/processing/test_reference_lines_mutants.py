"""Reference lines: cases that reach every branch of processing/reference_lines.py (issue 28, mutation
survivors).  Expected values are independent of the code under test: least squares from the normal
equations in exact rational arithmetic, end-point lines by hand, hull vertices from their definition
(a point strictly above every chord of two other points around it), minimum zones by brute force over
every line through two points or from a profile built with a known zone (Chebyshev alternation: two
contacts with one line and one between them with the parallel line make the zone minimal).
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest

from processing import reference_lines
from processing.reference_lines import endpoint_line, hulls, least_squares_line, minimum_zone_line, minimum_zone_many


def brute_zone(x: np.ndarray, h: np.ndarray) -> float:
    """Smallest vertical width over every line through two points of distinct x (plain loops)."""
    best = float("inf")
    for i, j in itertools.combinations(range(len(x)), 2):
        if x[i] == x[j]:
            continue
        b = (h[j] - h[i]) / (x[j] - x[i])
        res = [h[k] - b * x[k] for k in range(len(x))]
        best = min(best, max(res) - min(res))
    return best


def strict_vertices(x: list[float], z: list[float], upper: bool) -> list[int]:
    """Indices of the strict upper (lower) hull vertices by definition, sorted by x: the highest (lowest)
    point of its x, strictly above (below) the chord of every two other points on either side of it in x;
    the end x's highest (lowest) points always count.  Exact (Fractions)."""
    s = 1 if upper else -1
    fx = [Fraction(v) for v in x]
    fz = [Fraction(v) * s for v in z]
    best: dict[Fraction, int] = {}
    for i in range(len(x)):
        if fx[i] not in best or fz[i] > fz[best[fx[i]]]:
            best[fx[i]] = i
    cand = [best[k] for k in sorted(best)]
    out = []
    for i in cand:
        ok = True
        for a in cand:
            for b in cand:
                if fx[a] < fx[i] < fx[b]:
                    chord = fz[a] + (fz[b] - fz[a]) * (fx[i] - fx[a]) / (fx[b] - fx[a])
                    if fz[i] <= chord:
                        ok = False
        if ok:
            out.append(i)
    return out


def exact_hull(x: np.ndarray, z: np.ndarray, upper: bool) -> list[int]:
    """Strict upper (lower) hull vertices of points with strictly increasing x, in exact rational
    arithmetic (monotone chain on Fractions: no rounding, so no tolerance)."""
    s = 1 if upper else -1
    fx = [Fraction(v) for v in x]
    fz = [Fraction(v) for v in z]
    hull: list[int] = []
    for i in range(len(fx)):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            if s * ((fx[b] - fx[a]) * (fz[i] - fz[a]) - (fz[b] - fz[a]) * (fx[i] - fx[a])) >= 0:
                hull.pop()
            else:
                break
        hull.append(i)
    return hull


# --- end-point and least-squares lines -------------------------------------------------------------


def test_two_points_are_enough_for_every_line() -> None:
    """Two points: the line through them (by hand: slope (8 - 2)/(3 - 1) = 3, intercept 2 - 3*1 = -1)."""
    x, h = np.array([1.0, 3.0]), np.array([2.0, 8.0])
    for fit, method in ((endpoint_line(x, h), "endpoint"), (least_squares_line(x, h), "least_squares"),
                        (minimum_zone_line(x, h), "minimum_zone")):
        assert fit.method == method
        assert fit.slope_um_per_mm == pytest.approx(3.0, abs=1e-12)
        assert fit.intercept_um == pytest.approx(-1.0, abs=1e-12)
        assert fit.straightness_um == pytest.approx(0.0, abs=1e-12)


def test_least_squares_with_big_offsets_matches_the_exact_normal_equations() -> None:
    """x near 1e6 mm and h near 1e6 um: the slope from the normal equations in exact arithmetic,
    n Sxh - Sx Sh over n Sxx - Sx^2 (centring with +mean instead of -mean is exact algebra but
    not in floating point at this offset)."""
    x = 1e6 + np.array([0.0, 0.1, 0.3, 0.7, 1.1, 1.3, 1.7, 1.9, 2.3])
    h = 1e6 + np.array([0.3, -0.2, 0.5, 0.1, -0.7, 0.9, 0.2, -0.1, 0.4])
    fx, fh = [Fraction(v) for v in x], [Fraction(v) for v in h]
    n = len(fx)
    sx, sh = sum(fx), sum(fh)
    sxx = sum(v * v for v in fx)
    sxh = sum(a * b for a, b in zip(fx, fh, strict=True))
    slope = (n * sxh - sx * sh) / (n * sxx - sx * sx)
    intercept = (sh - slope * sx) / n
    fit = least_squares_line(x, h)
    assert fit.method == "least_squares"
    assert fit.slope_um_per_mm == pytest.approx(float(slope), rel=1e-9)
    # the deviations (the intercept itself is ~1e6 * 1e6 and carries no useful digits to compare)
    dev = [float(b - (intercept + slope * a)) for a, b in zip(fx, fh, strict=True)]
    assert fit.deviations_um == pytest.approx(dev, abs=1e-6)


@pytest.mark.parametrize("line", [endpoint_line, least_squares_line, minimum_zone_line])
def test_refusals_name_the_problem(line) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=r"^a reference line needs at least 2 points, got 1$"):
        line(np.array([1.0]), np.array([1.0]))
    with pytest.raises(ValueError, match="^x and h must be finite$"):
        line(np.array([0.0, 1.0, 2.0]), np.array([0.0, np.nan, 1.0]))
    for x, h in ((np.arange(3.0), np.arange(4.0)), (np.zeros((2, 2)), np.zeros((2, 2)))):
        with pytest.raises(ValueError, match="^x and h must be 1-D arrays of the same length$"):
            line(x, h)
    same = "end points have the same x" if line is endpoint_line else "all points have the same x"
    with pytest.raises(ValueError, match=f"^{same}$"):
        line(np.array([2.0, 2.0, 2.0]), np.array([0.0, 1.0, 2.0]))


def test_many_refuses_x_that_is_not_one_dimensional() -> None:
    with pytest.raises(ValueError, match="^h_rows must have one column per x$"):
        minimum_zone_many(np.zeros((3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^h_rows must have one column per x$"):
        minimum_zone_many(np.arange(3.0), np.zeros((2, 4)))


def test_many_equals_the_single_line_to_the_last_bit_at_big_offsets() -> None:
    """minimum_zone_many promises minimum_zone_line's value row by row with the same arithmetic: at
    x ~ 1e5 mm and h ~ 1e6 um (tilt 10 um/mm) every rounding must match, so the values are equal."""
    rng = np.random.default_rng(3)
    x = 1e5 + 0.37 * np.arange(12)
    rows = -1e6 + 10.0 * x + rng.normal(0.0, 1.0, (50, 12))
    single = np.array([minimum_zone_line(x, row).straightness_um for row in rows])
    assert np.array_equal(minimum_zone_many(x, rows), single)

def test_unsigned_integer_input_does_not_wrap() -> None:
    """uint16 x running backwards and uint16 heights (raw counts): differences must not wrap around.
    x = 10, 0, 5 and h = 2, 5, 9: end-point slope (9 - 2) / (5 - 10) = -1.4; minimum zone of three
    points = vertical distance of the middle x point (5, 9) from the chord (0, 5)-(10, 2): 9 - 3.5 = 5.5
    (the other two edges leave 11)."""
    x = np.array([10, 0, 5], dtype=np.uint16)
    h = np.array([2, 5, 9], dtype=np.uint16)
    assert endpoint_line(x, h).slope_um_per_mm == pytest.approx(-1.4, abs=1e-12)
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(5.5, abs=1e-12)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(5.5, abs=1e-12)
    xf, hf = x.astype(float), h.astype(float)
    assert least_squares_line(x, h).slope_um_per_mm == pytest.approx(least_squares_line(xf, hf).slope_um_per_mm)


def test_many_refusals_name_the_problem() -> None:
    with pytest.raises(ValueError, match="^x and h must be finite$"):
        minimum_zone_many(np.arange(3.0), np.array([[0.0, np.inf, 1.0]]))
    with pytest.raises(ValueError, match="^all points have the same x$"):
        minimum_zone_many(np.full(3, 4.0), np.zeros((1, 3)))

# --- hulls ------------------------------------------------------------------------------------------


def test_hulls_drop_collinear_points() -> None:
    """(1, 1) lies on the chord (0, 0)-(2, 2): no upper vertex; the lower hull is the base line."""
    up, lo = hulls(np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.0, 1.0, 2.0, 0.0]))
    assert up.tolist() == [0, 2, 3]
    assert lo.tolist() == [0, 3]


@pytest.mark.parametrize("seed", range(6))
def test_hulls_against_the_definition_on_small_integer_grids(seed: int) -> None:
    """Integer points (many collinear triples, repeated and unsorted x, negative x)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    x = rng.integers(-4, 5, n).astype(float)
    z = rng.integers(-3, 4, n).astype(float)
    if seed % 2 == 0:
        x = np.unique(x)  # strictly increasing: the fast path
        z = z[: len(x)]
    if len(np.unique(x)) < 2:
        x[0] = x.max() + 1
    pts = set()
    for i in range(len(x)):  # no exactly repeated point (which of two equal points is returned is arbitrary)
        while (x[i], z[i]) in pts:
            z[i] += 7
        pts.add((x[i], z[i]))
    up, lo = hulls(x, z)
    assert up.tolist() == strict_vertices(x.tolist(), z.tolist(), True)
    assert lo.tolist() == strict_vertices(x.tolist(), z.tolist(), False)


@pytest.mark.parametrize("offset", [5.0, 0.0])
def test_hulls_of_many_collinear_points_are_the_two_ends(offset: float) -> None:
    """3000 points on h = 2 x + offset (exact in floating point): each hull is the first and last point."""
    x = np.arange(3000.0)
    up, lo = hulls(x, 2.0 * x + offset)
    assert up.tolist() == [0, 2999]
    assert lo.tolist() == [0, 2999]


def test_hulls_of_many_points_with_one_spike() -> None:
    """3000 points on a base line and one spike of height 2999 (spread / length exactly 1)."""
    x = np.arange(3000.0)
    z = np.zeros(3000)
    z[1000] = 2999.0
    up, lo = hulls(x, z)
    assert up.tolist() == [0, 1000, 2999]
    assert lo.tolist() == [0, 2999]


def test_hulls_of_a_large_tent_drop_the_points_on_its_edges() -> None:
    """h = -2 |x| on 3001 integer x: the upper hull is the two ends and the apex (every other point lies
    exactly on an edge), the lower hull the two ends; the zone is that of the triangle of the three vertices
    (brute force): 3000 um, the base and the apex."""
    x = np.arange(-1500.0, 1501.0)
    h = -2.0 * np.abs(x)
    up, lo = hulls(x, h)
    assert up.tolist() == [0, 1500, 3000]
    assert lo.tolist() == [0, 3000]
    want = brute_zone(x[[0, 1500, 3000]], h[[0, 1500, 3000]])
    assert want == 3000.0
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(want, abs=1e-9)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(want, abs=1e-9)


@pytest.mark.parametrize("a", [3e-15, 1e-13])
def test_prefilter_keeps_every_vertex_of_a_shallow_tilted_parabola(a: float) -> None:
    """Adversarial for the prefilter's tolerance: x = 1e5 mm + 0..2499, h = -1e6 + 10 x + a (x - xm)^2 um,
    a curvature so small that hundreds of hull vertices lie within a few ulp of their chords.  Every
    vertex of the exact (rational) hulls must survive the prefilter."""
    x = 1e5 + np.arange(2500.0)
    z = -1e6 + 10.0 * x + a * (x - x.mean()) ** 2
    want = set(exact_hull(x, z, True)) | set(exact_hull(x, z, False))
    assert len(want) > 200
    assert want <= set(reference_lines._prefilter(x, z).tolist())

def test_record_points_keep_every_vertex_of_a_shallow_tilted_parabola() -> None:
    """The same for minimum_zone_many's record filter: x = -2e5 mm + 0.7 mm steps, h = 1e6 + 3.1 x +
    1e-11 (x - xm)^2 um; every vertex of the exact upper and lower hulls must be kept."""
    x = -2e5 + 0.7 * np.arange(600)
    z = 1e6 + 3.1 * x + 1e-11 * (x - x.mean()) ** 2
    for sign, upper in ((1.0, True), (-1.0, False)):
        want = set(exact_hull(x, z, upper))
        kept = set(np.flatnonzero(reference_lines._record_points(x, sign * z[None, :])[0]).tolist())
        assert want <= kept

def test_qhull_candidates_of_a_flat_set_are_its_ends() -> None:
    assert reference_lines._qhull_candidates(np.arange(10.0), np.full(10, 3.0)).tolist() == [0, 9]


def test_hull_rows_drop_collinear_points() -> None:
    x = np.array([0.0, 1.0, 2.0, 3.0])
    xs, zs, count = reference_lines._hull_rows(x, np.array([[0.0, 1.0, 2.0, 0.0]]), True)
    assert count.tolist() == [3]
    assert xs[0, :3].tolist() == [0.0, 2.0, 3.0]
    xs, zs, count = reference_lines._hull_rows(x, np.array([[0.0, -1.0, -2.0, 0.0]]), False)
    assert count.tolist() == [3]
    assert zs[0, :3].tolist() == [0.0, -2.0, 0.0]


# --- minimum zone -----------------------------------------------------------------------------------


def test_many_three_points_inside_the_record_tolerance() -> None:
    """A middle point 1e-13 below the chord of the ends: the zone is 1e-13 wide (slope 0)."""
    x = np.array([0.0, 1.0, 2.0])
    h = np.array([0.0, -1e-13, 0.0])
    want = brute_zone(x, h)
    assert want == pytest.approx(1e-13, abs=1e-20)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(want, abs=1e-20)
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(want, abs=1e-20)


@pytest.mark.parametrize("seed", range(4))
def test_small_profiles_against_brute_force(seed: int) -> None:
    """n = 3..9, unsorted, repeated and negative x, offsets of 1e6 um, near-collinear hull vertices."""
    rng = np.random.default_rng(100 + seed)
    n = 3 + 2 * seed
    x = rng.permutation(np.arange(n) - 3.0)
    if seed >= 2:
        x[1] = x[0]
    h = 1e6 + 0.05 * x + rng.integers(-3, 4, n) * 0.25
    want = brute_zone(x, h)
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(want, abs=1e-8)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(want, abs=1e-8)


def test_large_symmetric_parabola_on_the_qhull_path() -> None:
    """x = -1500..1500 mm (negative, symmetric about 0), h = 1e6 + 0.5 x + a x^2: every point is a
    lower hull vertex, so the qhull path runs.  Best line: slope 0.5 (the tilt), the zone touches the
    ends and the vertex: width a L^2 (Chebyshev: x^2 on [-L, L] is best approximated by L^2 / 2)."""
    x = np.arange(-1500.0, 1501.0)
    a = 1e-4
    h = 1e6 + 0.5 * x + a * x**2
    fit = minimum_zone_line(x, h)
    assert fit.straightness_um == pytest.approx(a * 1500.0**2, rel=1e-9)
    assert minimum_zone_many(x, np.vstack([h, -h]))[:] == pytest.approx([a * 1500.0**2] * 2, rel=1e-9)
    assert fit.slope_um_per_mm == pytest.approx(0.5, abs=1e-9)
    up, lo = hulls(x, h)
    assert up.tolist() == [0, 3000]
    assert len(lo) == 3001


@pytest.mark.parametrize("repeat", [False, True])
def test_large_profile_with_a_known_zone(repeat: bool) -> None:
    """3000 points in a band of width 2 um about a tilted line, touching its top at two x and its bottom
    at one x between them: the zone is that band.  With repeat, every x appears twice (shuffled)."""
    rng = np.random.default_rng(7)
    n = 1500 if repeat else 3000
    x = 250.0 + 0.5 * np.arange(n)
    u = rng.uniform(0.1, 1.9, n)
    u[[100, 700, 1300]] = [2.0, 0.0, 2.0]
    h = -1e6 + 0.01 * x + u
    if repeat:
        x = np.concatenate([x, x])
        h = np.concatenate([h, h - np.minimum(u, rng.uniform(0.0, 0.05, n))])  # still inside the band
        order = rng.permutation(2 * n)
        x, h = x[order], h[order]
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(2.0, abs=1e-8)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(2.0, abs=1e-8)


def test_large_nearly_collinear_profile_has_no_width() -> None:
    """3000 points on h = 0.3 x up to 1e-14 um: the prefilter keeps them all (within its tolerance) and
    qhull finds them flat (its error path: every point stays a candidate); width 0 up to rounding."""
    x = np.arange(3000) * 0.1
    h = 0.3 * x + 1e-14 * np.random.default_rng(1).uniform(-1.0, 1.0, 3000)
    assert minimum_zone_line(x, h).straightness_um == pytest.approx(0.0, abs=1e-12)
    assert minimum_zone_many(x, h[None, :])[0] == pytest.approx(0.0, abs=1e-12)
    up, lo = hulls(x, h)
    assert up[0] == lo[0] == 0
    assert up[-1] == lo[-1] == 2999
