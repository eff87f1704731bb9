"""The Monte Carlo in chunks: the same numbers whatever the chunk size, the same numbers as all
trials drawn and evaluated at once (written out here), and a working set bounded at any run size."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pandas as pd
import pytest

from processing.decoupling import DECOUPLERS, Channels, Setup
from processing.geometry import BlockGeometry
from processing.passes import station_groups
from processing.reference_lines import endpoint_line, least_squares_line, minimum_zone_line
from processing.uncertainty import UncertaintyInputs, _lines_vectorised, monte_carlo, profile_slope

GEOM = BlockGeometry((50.0, 110.0, 0.0), (150.0, 0.0, 40.0))
U = UncertaintyInputs(sensor_noise_um=0.05, sensor_resolution_um=0.02, straightness_um=0.1, angle_urad=0.3,
                      position_um=0.5, offset_mm=0.8, step_mm=0.05)
LINES = ("endpoint", "least_squares", "minimum_zone")


def points(n: int, passes: tuple[int, ...] = (0,), seed: int = 1) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    for p in passes:
        for k in (range(n) if p == 0 else reversed(range(n))):
            rows.append({"station": k, "x_mm": 100.0 * k, "time_s": 10.0 * len(rows), "lin_um": rng.normal(0, 2),
                         "stry_um": rng.normal(0, 3), "strz_um": rng.normal(0, 1), "pitch_urad": rng.normal(0, 40),
                         "yaw_urad": rng.normal(0, 10), "roll_urad": rng.normal(0, 40),
                         "sensor_mm": 0.2 + rng.normal(0, 2e-3), "pass": p})
    return pd.DataFrame(rows)


def run_mc(pts: pd.DataFrame, method: str, trials: int, seed: int, **kw: int):  # noqa: ANN201
    groups = station_groups(pts)
    x = groups.average(pts["x_mm"].to_numpy(dtype=float))
    h = groups.average(pts["stry_um"].to_numpy(dtype=float))
    slope = profile_slope(x, h)
    return monte_carlo(pts, GEOM, method, U, groups, x, slope, trials=trials, seed=seed, lines=LINES, **kw), x, slope


@pytest.mark.parametrize("method", ["exact", "first-order", "patent"])
@pytest.mark.parametrize("passes", [(0,), (0, 1)], ids=["forward", "round-trip"])
def test_chunk_size_does_not_change_a_digit(method: str, passes: tuple[int, ...]) -> None:
    pts = points(9, passes)
    n = len(pts)
    ref, _, _ = run_mc(pts, method, 230, 11, chunk_elements=10**9)  # every trial at once
    for chunk in (1, n, 3 * n + 1, 64 * n):  # one trial per chunk (also below one), 3, 64
        got, _, _ = run_mc(pts, method, 230, 11, chunk_elements=chunk)
        assert np.array_equal(got.per_station_std_um, ref.per_station_std_um)
        for name in LINES:
            assert np.array_equal(got.straightness_um[name], ref.straightness_um[name]), (chunk, name)
        assert got.summary() == ref.summary()


@pytest.mark.parametrize("method", ["exact", "first-order"])
def test_chunked_equals_all_trials_at_once_written_here(method: str) -> None:
    """The documented draw: SeedSequence(seed).spawn(9) streams, in the order sensor noise, sensor
    resolution, stry, strz, pitch, yaw, roll, offset (6 per trial: P x y z, Q x y z), x; every trial
    drawn at once, decoupled, averaged per station; std per station by numpy's two-pass std."""
    pts = points(50, (0, 1))  # 50 stations: the minimum zone goes through the exact hull per trial
    trials, seed = 120, 4
    got, x, slope = run_mc(pts, method, trials, seed)  # the default chunk (2500 trials of 100 points)
    got_small, _, _ = run_mc(pts, method, trials, seed, chunk_elements=7 * len(pts))  # 7 trials at a time
    n = len(pts)
    g = [np.random.default_rng(c) for c in np.random.SeedSequence(seed).spawn(9)]
    ch = Channels.from_points(pts)
    sensor = ch.sensor_mm + g[0].normal(0.0, U.sensor_noise_um, (trials, n)) * 1e-3
    sensor = sensor + g[1].uniform(-0.5, 0.5, (trials, n)) * U.sensor_resolution_um * 1e-3
    noisy = [a + g[i].normal(0.0, s, (trials, n)) for i, a, s in
             ((2, ch.stry_um, U.straightness_um), (3, ch.strz_um, U.straightness_um), (4, ch.pitch_urad, U.angle_urad),
              (5, ch.yaw_urad, U.angle_urad), (6, ch.roll_urad, U.angle_urad))]
    chp = Channels(ch.x_mm, ch.lin_um, noisy[0], noisy[1], noisy[2], noisy[3], noisy[4], sensor, ch.first_step)
    off = g[7].normal(0.0, U.offset_mm, (trials, 6))
    p = [v + off[:, i:i + 1] for i, v in enumerate((*GEOM.mirror_mm, *GEOM.sensor_mm))]
    setup = Setup.from_geometry(GEOM)
    _, h = DECOUPLERS[method](chp, Setup(tuple(p[:3]), tuple(p[3:]), setup.beam, setup.sign, setup.datum_urad))
    u_x_mm = (U.position_um if method == "exact" else U.step_mm * 1e3) * 1e-3
    dx = g[8].normal(0.0, u_x_mm, (trials, n))
    dx -= dx[:, :1]
    groups = station_groups(pts)
    # row-major, as the trials follow one another (numpy sums a strided axis in sequence)
    h_all = np.ascontiguousarray(groups.average(h) + slope * groups.average(dx))
    # straightness of each trial: to the last digit as all rows at once, and against the single-profile fits
    want = _lines_vectorised(x, h_all, LINES)
    for name in LINES:
        assert np.array_equal(got.straightness_um[name], want[name]), name
        assert np.array_equal(got_small.straightness_um[name], want[name]), name
    single = {"endpoint": endpoint_line, "least_squares": least_squares_line, "minimum_zone": minimum_zone_line}
    for name, fit in single.items():
        np.testing.assert_allclose(got.straightness_um[name], [fit(x, row).straightness_um for row in h_all],
                                   rtol=1e-9)
    # per-station std: the shifted sums over the whole array to the last digit, numpy's std to rounding
    d = h_all - h_all[0]
    s1, s2 = d.sum(axis=0), (d * d).sum(axis=0)
    shifted = np.sqrt(np.maximum((s2 - s1 * s1 / trials) / (trials - 1), 0.0))
    assert np.array_equal(got.per_station_std_um, shifted)
    assert np.array_equal(got_small.per_station_std_um, shifted)
    np.testing.assert_allclose(got.per_station_std_um, h_all.std(axis=0, ddof=1), rtol=1e-10, atol=1e-13)


def test_working_set_is_bounded_on_a_long_run() -> None:
    """100 000 points, 10 trials: all trials at once would hold ~20 arrays of 1e6 values (8 MB
    each) for the exact decoupling; in chunks the traced peak stays far below."""
    n = 100_000
    rng = np.random.default_rng(2)
    pts = pd.DataFrame({"station": np.arange(n), "x_mm": np.arange(n) * 100.0, "time_s": np.arange(n) * 1.0,
                        "lin_um": rng.normal(0, 1, n), "stry_um": rng.normal(0, 1, n),
                        "strz_um": rng.normal(0, 1, n), "pitch_urad": rng.normal(0, 5, n),
                        "yaw_urad": rng.normal(0, 5, n), "roll_urad": rng.normal(0, 5, n),
                        "sensor_mm": 0.2 + rng.normal(0, 1e-3, n)})
    groups = station_groups(pts)
    x = pts["x_mm"].to_numpy()
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before = tracemalloc.get_traced_memory()[0]
        mc = monte_carlo(pts, GEOM, "exact", U, groups, x, np.zeros(n), trials=10, lines=("endpoint",))
        peak_mb = (tracemalloc.get_traced_memory()[1] - before) / 1e6
    finally:
        tracemalloc.stop()
    assert mc.per_station_std_um.shape == (n,) and np.all(np.isfinite(mc.per_station_std_um))
    assert peak_mb < 100.0, f"Monte Carlo peak {peak_mb:.0f} MB"
