"""Strength tests for processing/decoupling.py (issue 28): every expected value is computed here, from
the rotation matrices written out by hand, the block-stepped-by-its-length geometry and the patent's
eq. 17 as written in docs/conventions.md."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

import processing.decoupling as dec
from processing.decoupling import (
    CHANNEL_COLUMNS,
    Channels,
    Setup,
    _rows,
    datum_angles_of,
    datum_angles_used,
    decouple_run,
    estimate_datum_pitch,
    first_order_arrays,
    first_step_index,
    patent_arrays,
)
from processing.geometry import BlockGeometry, DatumAngles


def rx(a: float) -> np.ndarray:
    return np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])


def ry(a: float) -> np.ndarray:
    return np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])


def rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])


def rot(ex: float, ey: float, ez: float) -> np.ndarray:
    """R = Rz(ez) Ry(ey) Rx(ex) (docs/conventions.md)."""
    return rz(ez) @ ry(ey) @ rx(ex)


# ---------------------------------------------------------------- _rows


@pytest.mark.parametrize("angles", [(0.3, -0.5, 0.7), (-1.1, 0.4, -0.2), (0.9, 1.2, 2.5)])
def test_rows_is_every_element_of_rz_ry_rx(angles: tuple[float, float, float]) -> None:
    expected = rot(*angles)
    rows = _rows(*(np.array([a]) for a in angles))
    for i in range(3):
        for j in range(3):
            np.testing.assert_allclose(rows[i][j], [expected[i, j]], rtol=0, atol=1e-15, err_msg=f"R[{i}][{j}]")


# ---------------------------------------------------------------- first_step_index


def test_first_step_index_hand_made_columns() -> None:
    # a repeated datum capture, so the first step is at index 2; then the return pass
    cols = {"station": np.array([0, 0, 1, 2, 2, 1, 0]), "pass": np.array([0, 0, 0, 0, 1, 1, 1])}
    assert first_step_index(cols) == 2
    assert first_step_index(pd.DataFrame(cols)) == 2
    # the datum need not be station 0
    assert first_step_index({"station": np.array([3, 4, 5]), "pass": np.zeros(3, dtype=int)}) == 1
    # a return-pass point at the next station is not the first step
    back = {"station": np.array([0, 1, 0]), "pass": np.array([0, 1, 1])}
    assert first_step_index(back) is None
    assert first_step_index(pd.DataFrame(back)) is None
    # ... but it is when the first one of the forward pass comes later
    assert first_step_index({"station": np.array([0, 1, 1]), "pass": np.array([0, 1, 0])}) == 2
    # without a pass column every point is forward
    assert first_step_index({"station": np.array([0, 0, 1])}) == 2
    # no next station
    assert first_step_index({"station": np.array([0, 0, 2]), "pass": np.zeros(3, dtype=int)}) is None
    assert first_step_index({"station": np.array([5]), "pass": np.array([0])}) is None


def test_first_step_index_empty() -> None:
    assert first_step_index({}) is None
    assert first_step_index(pd.DataFrame({"station": [], "pass": []})) is None
    assert first_step_index({"station": np.array([], dtype=int), "pass": np.array([], dtype=int)}) is None


def test_first_step_index_compares_station_and_pass_as_numbers() -> None:
    """Columns read as text (a CSV read without conversion) or as floats give the same index."""
    text = {"station": np.array(["0", "0", "1", "1"]), "pass": np.array(["0", "0", "1", "0"])}
    assert first_step_index(text) == 3
    floats = {"station": np.array([0.0, 0.0, 1.0, 1.0]), "pass": np.array([0.0, 0.0, 1.0, 0.0])}
    assert first_step_index(floats) == 3


# ---------------------------------------------------------------- Channels.from_points


def channel_points(n: int, dtype: type = float) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(4)
    cols = {c: (rng.normal(0, 50, n) if c != "x_mm" else 100.0 * np.arange(n)).astype(dtype)
            for c in CHANNEL_COLUMNS}
    cols["station"] = np.arange(n)
    cols["pass"] = np.zeros(n, dtype=int)
    return cols


@pytest.mark.parametrize("dtype", [np.float32, np.int64])
@pytest.mark.parametrize("as_frame", [False, True], ids=["dict", "frame"])
def test_channels_from_points_are_float64(dtype: type, as_frame: bool) -> None:
    cols = channel_points(4, dtype)
    ch = Channels.from_points(pd.DataFrame(cols) if as_frame else cols)
    for c in CHANNEL_COLUMNS:
        arr = getattr(ch, c)
        assert arr.dtype == np.float64, c
        np.testing.assert_array_equal(arr, cols[c].astype(np.float64))
    assert ch.first_step == 1


# ---------------------------------------------------------------- the datum pitch from the first step


P = (50.0, 110.0, 5.0)     # mirror point P, block frame (mm)
Q = (150.0, 0.0, 40.0)     # sensor point Q, block frame (mm)
L = 100.0                  # block length = step (mm)
DATUM = (150e-6, -300e-6, 250e-6)   # roll, yaw, pitch of the zeroing pose R0 in the laser frame (rad)


def stepped_run(datum: tuple[float, float, float] = DATUM) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Channels of a block stepped by its own length, with a repeated datum capture (the first step at
    index 2) and a return pass.  O_k = P_laser + d_k - dR_k R0 P; the first step puts O_1 at
    O_0 + L dR_0 R0 (1, 0, 0).  Returns the points and the x-axis rows' readings."""
    r0 = rot(*datum)
    p = np.array(P)
    # (roll, yaw, pitch) urad and d (mm) of every capture; row 0 the datum, not zero (zeroing noise)
    angles = np.array([[3.0, -2.0, 5.0], [-4.0, 6.0, 1.0], [40.0, -25.0, 60.0], [70.0, 30.0, -45.0],
                       [65.0, 28.0, -40.0], [35.0, -20.0, 55.0], [2.0, 1.0, 4.0]])
    d = np.array([[0.0004, -0.0003, 0.0007], [0.0009, 0.0011, -0.0021], [0.0, 0.0, 0.0],
                  [200.0 + 0.002, 0.004, -0.003], [200.0 + 0.001, 0.0041, -0.0029],
                  [100.0 - 0.001, 0.0015, 0.0022], [0.0003, -0.0002, 0.0006]])
    dr = [rot(*(a * 1e-6)) for a in angles]
    o0 = d[0] - dr[0] @ r0 @ p                      # the datum's origin, minus P_laser
    o1 = o0 + L * (dr[0] @ r0 @ np.array([1.0, 0.0, 0.0]))
    d[2] = o1 + dr[2] @ r0 @ p                      # the first step's displacement of P
    station = np.array([0, 0, 1, 2, 2, 1, 0])
    x_nominal = L * station
    cols = {"station": station, "pass": np.array([0, 0, 0, 0, 1, 1, 1]),
            "x_mm": x_nominal.astype(float), "lin_um": (d[:, 0] - x_nominal) * 1e3,
            "stry_um": d[:, 1] * 1e3, "strz_um": d[:, 2] * 1e3,
            "roll_urad": angles[:, 0], "yaw_urad": angles[:, 1], "pitch_urad": angles[:, 2],
            "sensor_mm": np.array([1.234, 1.236, 1.231, 1.229, 1.2295, 1.2315, 1.2338])}
    return cols, angles


def setup_of(datum_urad: tuple = (None, None, None)) -> Setup:
    return Setup(P, Q, (0.0, -1.0, 0.0), "height", datum_urad)


@pytest.mark.parametrize("as_frame", [False, True], ids=["dict", "frame"])
def test_datum_pitch_from_a_block_stepped_by_its_length(as_frame: bool) -> None:
    cols, _ = stepped_run()
    ch = Channels.from_points(pd.DataFrame(cols) if as_frame else cols)
    assert ch.first_step == 2
    ez0 = estimate_datum_pitch(ch, setup_of(), DATUM[0], DATUM[1])
    np.testing.assert_allclose(ez0, [DATUM[2]], rtol=1e-9)
    # the rows' own readings matter: without the roll and yaw of R0 the estimate is off
    off = estimate_datum_pitch(ch, setup_of(), 0.0, 0.0)
    assert abs(float(off[0]) - DATUM[2]) > 1e-9


def test_datum_pitch_computed_in_float64_from_float32_channels() -> None:
    cols, _ = stepped_run()
    ch64 = Channels.from_points(cols)
    ch32 = Channels(**{c: getattr(ch64, c).astype(np.float32) for c in CHANNEL_COLUMNS}, first_step=2)
    expected = estimate_datum_pitch(Channels(**{c: getattr(ch32, c).astype(np.float64) for c in CHANNEL_COLUMNS},
                                             first_step=2), setup_of(), DATUM[0], DATUM[1])
    got = estimate_datum_pitch(ch32, setup_of(), DATUM[0], DATUM[1])
    assert np.asarray(got).dtype == np.float64
    np.testing.assert_allclose(got, expected, rtol=1e-12)


def test_datum_pitch_without_a_first_step_is_zero() -> None:
    cols, _ = stepped_run()
    ch = Channels.from_points(cols)
    assert estimate_datum_pitch(replace_first_step(ch, None), setup_of(), DATUM[0], DATUM[1]) == 0.0


def replace_first_step(ch: Channels, i: int | None) -> Channels:
    return Channels(**{c: getattr(ch, c) for c in CHANNEL_COLUMNS}, first_step=i)


# ---------------------------------------------------------------- datum angles used and their sources


@pytest.mark.parametrize("as_frame", [False, True], ids=["dict", "frame"])
def test_datum_angles_sources(as_frame: bool) -> None:
    cols, _ = stepped_run()
    pts = pd.DataFrame(cols) if as_frame else cols
    measured = DatumAngles(roll_urad=DATUM[0] * 1e6, yaw_urad=DATUM[1] * 1e6)
    used = datum_angles_used(pts, BlockGeometry(P, Q, datum_angles_urad=measured))
    assert used.source == {"roll": "measured", "yaw": "measured", "pitch": "estimated"}
    assert used.roll_urad == pytest.approx(150.0, abs=1e-12)
    assert used.yaw_urad == pytest.approx(-300.0, abs=1e-12)
    assert used.pitch_urad == pytest.approx(250.0, rel=1e-9)
    assert used.to_dict() == {"roll": used.roll_urad, "yaw": used.yaw_urad, "pitch": used.pitch_urad,
                              "source": used.source}
    # all three measured: taken as given, whatever the first step says
    given = datum_angles_used(pts, BlockGeometry(P, Q, datum_angles_urad=DatumAngles(12.0, -7.0, 33.0)))
    assert (given.roll_urad, given.yaw_urad, given.pitch_urad) == (12.0, -7.0, 33.0)
    assert given.source == {"roll": "measured", "yaw": "measured", "pitch": "measured"}
    # nothing measured: roll and yaw assumed 0, the pitch estimated with R0's roll and yaw taken as 0
    none = datum_angles_used(pts, BlockGeometry(P, Q))
    assert none.source == {"roll": "assumed", "yaw": "assumed", "pitch": "estimated"}
    assert (none.roll_urad, none.yaw_urad) == (0.0, 0.0)
    ch = Channels.from_points(cols)
    assert none.pitch_urad == pytest.approx(float(estimate_datum_pitch(ch, setup_of(), 0.0, 0.0)[0]) * 1e6,
                                            rel=1e-12)
    assert abs(none.pitch_urad - 250.0) < 1.0  # the roll and yaw of R0 are second order


def test_datum_angles_without_a_first_step_are_assumed() -> None:
    cols = {k: v[:2] for k, v in stepped_run()[0].items()}     # only the datum captures
    used = datum_angles_used(cols, BlockGeometry(P, Q, datum_angles_urad=DatumAngles(roll_urad=5.0)))
    assert used.source == {"roll": "measured", "yaw": "assumed", "pitch": "assumed"}
    assert (used.roll_urad, used.yaw_urad, used.pitch_urad) == (5.0, 0.0, 0.0)
    # datum_angles_of directly, with per-axis values in the order roll, yaw, pitch
    ch = Channels.from_points(stepped_run()[0])
    got = datum_angles_of(ch, setup_of((None, -300.0, None)))
    assert got.source == {"roll": "assumed", "yaw": "measured", "pitch": "estimated"}
    assert got.yaw_urad == -300.0 and got.roll_urad == 0.0


# ---------------------------------------------------------------- decouple_run


def test_decouple_run_estimates_the_datum_pitch_once(monkeypatch: pytest.MonkeyPatch) -> None:
    cols, _ = stepped_run()
    calls = []
    real = dec.estimate_datum_pitch

    def counting(*args: object) -> object:
        calls.append(1)
        return real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(dec, "estimate_datum_pitch", counting)
    res = decouple_run(cols, BlockGeometry(P, Q), "exact")
    assert len(calls) == 1
    assert res.datum is not None and res.datum.source["pitch"] == "estimated"


@pytest.mark.parametrize("method", ["exact", "first-order", "patent"])
@pytest.mark.parametrize("as_frame", [False, True], ids=["dict", "frame"])
def test_decouple_run_station_column(method: str, as_frame: bool) -> None:
    cols, _ = stepped_run()
    cols = {**cols, "station": cols["station"].astype(float)}   # e.g. read back as floats
    res = decouple_run(pd.DataFrame(cols) if as_frame else cols, BlockGeometry(P, Q), method)
    assert list(res.columns) == ["station", "x_mm", "height_um"]
    assert res.columns["station"].dtype.kind == "i"
    np.testing.assert_array_equal(res.columns["station"], [0, 0, 1, 2, 2, 1, 0])
    assert list(res.profile.columns) == ["station", "x_mm", "height_um"]
    assert (res.datum is not None) == (method == "exact")


@pytest.mark.parametrize("method", ["exact", "first-order", "patent"])
def test_decouple_run_refuses_no_points(method: str) -> None:
    empty = {c: np.array([]) for c in ("station", "pass", *CHANNEL_COLUMNS)}
    with pytest.raises(ValueError) as err:
        decouple_run(empty, BlockGeometry(P, Q), method)
    assert str(err.value) == "no points to process"
    with pytest.raises(ValueError, match=r"unknown decoupling method 'nope'; choose one of exact, first-order, patent"):
        decouple_run(stepped_run()[0], BlockGeometry(P, Q), "nope")


# ---------------------------------------------------------------- patent eq. 17 and the nominal x


@pytest.mark.parametrize("sign", ["height", "gap"])
def test_patent_eq17_as_written_from_float32_channels(sign: str) -> None:
    """dygx = ylx - ylx0 - dysx + (xp0 - xq0) sin ezx + (zq0 - zp0) sin exx, h = -dygx; the channels as
    recorded (not re-referenced to the datum), ylx in the gap sense; computed in float64."""
    cols, _ = stepped_run()
    ch = Channels(**{c: np.asarray(cols[c], dtype=np.float32) for c in CHANNEL_COLUMNS}, first_step=2)
    f = {c: np.asarray(getattr(ch, c), dtype=np.float64) for c in CHANNEL_COLUMNS}
    reading_um = (f["sensor_mm"] - f["sensor_mm"][0]) * 1000.0
    ylx = reading_um if sign == "gap" else -reading_um   # gap sense: grows as the surface moves away
    dygx = (ylx - f["stry_um"] + (P[0] - Q[0]) * 1e3 * np.sin(f["pitch_urad"] * 1e-6)
            + (Q[2] - P[2]) * 1e3 * np.sin(f["roll_urad"] * 1e-6))
    x, h = patent_arrays(ch, Setup(P, Q, (0.0, -1.0, 0.0), sign))
    np.testing.assert_allclose(h, -dygx, rtol=0, atol=1e-9)
    np.testing.assert_allclose(x, f["x_mm"] - f["x_mm"][0], rtol=0, atol=0)
    assert h[0] != 0.0   # the datum's own channels are not subtracted


def test_nominal_x_broadcasts_to_the_channels_shape() -> None:
    """Monte Carlo varies channels per trial: x (trials, n) with 1-D stry, and the other way round."""
    cols, _ = stepped_run()
    base = {c: np.asarray(cols[c], dtype=float) for c in CHANNEL_COLUMNS}
    x2 = np.stack([base["x_mm"], base["x_mm"] + 5.0 * np.arange(7)])
    ch = Channels(**{**base, "x_mm": x2})
    for fn in (first_order_arrays, patent_arrays):
        x, _ = fn(ch, setup_of())
        assert x.shape == (2, 7)
        np.testing.assert_array_equal(x, x2 - x2[:, :1])
    stry2 = np.stack([base["stry_um"], base["stry_um"] + 1.0])
    ch = Channels(**{**base, "stry_um": stry2})
    for fn in (first_order_arrays, patent_arrays):
        x, h = fn(ch, setup_of())
        assert x.shape == (2, 7) and h.shape == (2, 7)
        np.testing.assert_array_equal(x, np.broadcast_to(L * cols["station"], (2, 7)))


def test_datum_pitch_at_large_angles_with_p_at_the_block_origin() -> None:
    """With P at the block origin the chord O1 - O0 is d1 - d0 and the estimate needs no iteration:
    exact at 20-50 mrad, where every element of dR0 weighs."""
    datum = (0.02, -0.03, 0.05)
    r0 = rot(*datum)
    a0, a1 = np.array([0.01, 0.025, -0.04]), np.array([-0.03, 0.015, 0.035])
    d0 = np.array([0.01, -0.02, 0.03])
    d1 = d0 + L * (rot(*a0) @ r0 @ np.array([1.0, 0.0, 0.0]))
    ch = Channels(x_mm=np.array([0.0, L]), lin_um=np.array([d0[0], d1[0] - L]) * 1e3,
                  stry_um=np.array([d0[1], d1[1]]) * 1e3, strz_um=np.array([d0[2], d1[2]]) * 1e3,
                  roll_urad=np.array([a0[0], a1[0]]) * 1e6, yaw_urad=np.array([a0[1], a1[1]]) * 1e6,
                  pitch_urad=np.array([a0[2], a1[2]]) * 1e6, sensor_mm=np.zeros(2), first_step=1)
    setup = Setup((0.0, 0.0, 0.0), Q, (0.0, -1.0, 0.0), "height")
    np.testing.assert_allclose(estimate_datum_pitch(ch, setup, datum[0], datum[1]), [datum[2]], rtol=1e-12)


def test_datum_pitch_iterates_from_zero() -> None:
    """Three fixed-point iterations from 0 leave < 1e-15 rad at guideway angles."""
    cols, _ = stepped_run()
    ez0 = estimate_datum_pitch(Channels.from_points(cols), setup_of(), DATUM[0], DATUM[1])
    np.testing.assert_allclose(ez0, [DATUM[2]], rtol=1e-11)


def test_exact_and_helpers_compute_in_float64_from_float32_channels() -> None:
    cols, _ = stepped_run()
    ch32 = Channels(**{c: np.asarray(cols[c], dtype=np.float32) for c in CHANNEL_COLUMNS}, first_step=2)
    ch64 = Channels(**{c: getattr(ch32, c).astype(np.float64) for c in CHANNEL_COLUMNS}, first_step=2)
    setup = setup_of((150.0, -300.0, 250.0))
    for got, want in zip(dec.exact_arrays(ch32, setup), dec.exact_arrays(ch64, setup), strict=True):
        assert got.dtype == np.float64
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    s32 = ch32.sensor_mm
    for sign, k in (("height", 1000.0), ("gap", -1000.0)):
        h = dec.sensor_height_um(s32, sign)
        assert h.dtype == np.float64
        np.testing.assert_allclose(h, (s32.astype(np.float64) - float(s32[0])) * k, rtol=0, atol=1e-12)
    r = dec.relative_to_first(ch32.stry_um)
    assert r.dtype == np.float64
    np.testing.assert_array_equal(r, ch64.stry_um - ch64.stry_um[0])
