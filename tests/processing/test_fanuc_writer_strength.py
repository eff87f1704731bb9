"""Strength tests of processing/compensation/fanuc.py (issue 28): every function called directly, pure unit
tests.  The expected numbers are worked out by hand in the comments from the Fanuc pitch-error rules of
standards.md §4.4: point N sits at x_ref + (N − 3620)·3624; 3621 = 3620 − (negative stroke / interval) + 1;
3622 = 3620 + (positive stroke / interval); one count = detection unit × 3623; the absolute correction
c_k = round(−(e_k − e_ref) / count), halves away from zero, is rounded and the increments v_N = c_N − c_{N−1}
are written; bidirectional (3605#0 = 1): the − table starts at 3626, 3627 is the absolute correction at the
reference approached against the reference-return direction.  Listing layout: docs/compensation.md."""

from __future__ import annotations

import re

import numpy as np
import pytest

from processing.compensation.fanuc import (
    FanucPitchTable,
    absolute_from_incremental,
    fanuc_pitch_table,
    fanuc_text,
    incremental_from_absolute,
    round_half_away,
)

# standards.md §4.4, 0i-PB manual example: interval 50 mm, reference = point 40 at 0 mm
MANUAL_INCREMENTS = [+2, +1, +1, -2, 0, -1, 0, -1, +2, +1, 0, -1, -1, -2, 0, +1, +2]  # points 33 … 49
MANUAL_ABSOLUTE = [0, 2, 3, 4, 2, 2, 1, 1, 0, 2, 3, 3, 2, 1, -1, -1, 0, 2]  # points 32 … 49, x = −400 … 450 mm


# ------------------------------------------------------------------------------------------ rounding


def test_round_half_away_rounds_halves_away_from_zero_to_integer_counts() -> None:
    r = round_half_away(np.array([-2.5, -1.5, -1.2, -0.5, -0.4, 0.0, 0.4, 0.5, 1.2, 1.5, 2.5, 2.6]))
    assert r.dtype == np.int64
    assert r.tolist() == [-3, -2, -1, -1, 0, 0, 0, 1, 1, 2, 3, 3]
    s = round_half_away(-7.5)
    assert s.dtype == np.int64 and int(s) == -8


def test_round_half_away_just_below_a_half_and_large_odd_integers() -> None:
    # 0.5 − 2⁻⁵⁴ is the largest double below 0.5: its nearest integer is 0 (floor(x + 0.5) gives 1,
    # because x + 0.5 rounds up to 1.0 in binary floating point)
    below_half = 0.5 - 2.0**-54
    assert below_half < 0.5
    assert round_half_away(np.array([below_half, -below_half])).tolist() == [0, 0]
    # odd integers above 2⁵² are exact doubles and are already integers (x + 0.5 is not representable there)
    big = 2**52 + 1
    assert round_half_away(np.array([float(big), -float(big)])).tolist() == [big, -big]


# ----------------------------------------------------------------------- absolute <-> incremental


def test_incremental_from_absolute_is_a_signed_difference_of_neighbours() -> None:
    # absolute counts 3, 1, 4 → increments 1 − 3 = −2 and 4 − 1 = +3 (not 254 from unsigned wrap-around)
    v = incremental_from_absolute(np.array([3, 1, 4], dtype=np.uint8))
    assert v.dtype == np.int64 and v.tolist() == [-2, 3]
    w = incremental_from_absolute(np.array([0.0, 2.0, -1.0]))
    assert w.dtype == np.int64 and w.tolist() == [2, -3]
    assert incremental_from_absolute(np.array(MANUAL_ABSOLUTE)).tolist() == MANUAL_INCREMENTS


def test_absolute_from_incremental_anchors_the_reference_point() -> None:
    # the manual profile with the reference moved to point 36 (x = −200 mm, absolute 2 there): all 2 lower
    r = absolute_from_incremental(np.array(MANUAL_INCREMENTS), 33, 36)
    assert r.dtype == np.int64
    assert r.tolist() == [c - 2 for c in MANUAL_ABSOLUTE]
    # an anchor value of 5 at the manual reference point 40 (where the profile is 0): all 5 higher
    assert absolute_from_incremental(np.array(MANUAL_INCREMENTS), 33, 40, 5).tolist() == [c + 5 for c in
                                                                                          MANUAL_ABSOLUTE]
    f = absolute_from_incremental(np.array([2.0, -1.0]), 1, 0)
    assert f.dtype == np.int64 and f.tolist() == [0, 2, 1]


def test_absolute_from_incremental_reference_at_either_end_or_outside() -> None:
    # points 1, 2 with increments 1, 2; positions of points 0, 1, 2
    assert absolute_from_incremental(np.array([1, 2]), 1, 0).tolist() == [0, 1, 3]  # 3620 = 3621 − 1
    assert absolute_from_incremental(np.array([1, 2]), 1, 2).tolist() == [-3, -2, 0]
    for ref in (-1, 3):
        with pytest.raises(ValueError, match="^the reference point lies outside the table$"):
            absolute_from_incremental(np.array([1, 2]), 1, ref)


# ---------------------------------------------------------------------------------- pitch table


def test_table_inside_reference_default_numbering_and_listing() -> None:
    # grid 0 … 40 mm step 10, reference at 20 mm: 2 intervals on each side.  First point 0 (default):
    # 3621 = 0, 3620 = 3621 + 2 − 1 = 1, 3622 = 3620 + 2 = 3.  One count = 0.5 um × 1.
    # e = 1, −2, 3, 5, 0 um, e_ref = 3: c = −(e − 3)/0.5 = 4, 10, 0, −4, 6 → v = 6, −10, −4, 10
    t = fanuc_pitch_table(np.array([1.0, -2.0, 3.0, 5.0, 0.0]), None, grid_mm=np.arange(0.0, 41.0, 10.0),
                          reference_position_mm=20.0, detection_unit_um=0.5)
    assert (t.reference_number, t.negative_end, t.positive_end) == (1, 0, 3)
    assert t.interval_mm == 10.0 and t.magnification == 1 and not t.bidirectional
    assert t.values.tolist() == [6, -10, -4, 10]
    # points −1 … 3 at 20 + (N − 1)·10 mm
    assert t.positions_mm().tolist() == [0.0, 10.0, 20.0, 30.0, 40.0]
    up, down = t.absolute_counts()
    assert up.tolist() == [4, 10, 0, -4, 6] and down is None
    assert fanuc_text(t) == (
        "(GUIDEWAY PITCH ERROR COMPENSATION AXIS X)\n"
        "(ONE COUNT = 0.5 UM X MAGNIFICATION 1; VALUES ARE INCREMENTAL CORRECTIONS)\n"
        "(REFERENCE POSITION 20 MM = POINT 1)\n"
        "PARAM 3605#0=0\n"
        "PARAM 3620=1\n"
        "PARAM 3621=0\n"
        "PARAM 3622=3\n"
        "PARAM 3623=1\n"
        "(3624 IN MM; SERIES THAT TAKE DETECTION UNITS: 20000)\n"  # 10 mm / 0.5 um
        "PARAM 3624=10.000\n"
        "(BOTH DIRECTIONS)\n"
        "PITCH 0=6\n"
        "PITCH 1=-10\n"
        "PITCH 2=-4\n"
        "PITCH 3=10\n"
    )


def test_bidirectional_reference_return_minus_listing_and_counts() -> None:
    # grid 0 … 30 step 10, reference 10 mm (1 interval below, 2 above), 3620 = 5 → 3621 = 5, 3622 = 7.
    # One count = 1 um × 2.  Reference return in −: the − curve is zero at the reference, e_ref = e↓(10) = 8.
    # c↑ = −(2 − 8, 4 − 8, −4 − 8, 9 − 8)/2 = 3, 2, 6, −0.5 → 3, 2, 6, −1 → v↑ = −1, 4, −7
    # c↓ = −(0 − 8, 8 − 8, 1 − 8, −6 − 8)/2 = 4, 0, 3.5, 7 → 4, 0, 4, 7 → v↓ = −4, 4, 3
    # 3626 = 3622 + 1 = 8; 3627 = c↑ at the reference (approached in +, against the return) = 2
    t = fanuc_pitch_table(np.array([2.0, 4.0, -4.0, 9.0]), np.array([0.0, 8.0, 1.0, -6.0]),
                          grid_mm=np.array([0.0, 10.0, 20.0, 30.0]), reference_position_mm=10.0, magnification=2,
                          reference_number=5, reference_direction=-1)
    assert (t.reference_number, t.negative_end, t.positive_end) == (5, 5, 7)
    assert t.bidirectional and t.negative_table_start == 8 and t.reference_offset == 2
    assert t.values.tolist() == [-1, 4, -7]
    assert t.values_negative is not None and t.values_negative.tolist() == [-4, 4, 3]
    up, down = t.absolute_counts()  # what the control adds up: + table 3627 at the reference, − table 0
    assert up.tolist() == [3, 2, 6, -1]
    assert down is not None and down.tolist() == [4, 0, 4, 7]
    assert t.positions_mm().tolist() == [0.0, 10.0, 20.0, 30.0]
    assert fanuc_text(t, axis="z", note="run 7 (left rail) spline") == (
        "(GUIDEWAY PITCH ERROR COMPENSATION AXIS Z)\n"
        "(ONE COUNT = 1 UM X MAGNIFICATION 2; VALUES ARE INCREMENTAL CORRECTIONS)\n"
        "(RUN 7 [LEFT RAIL] SPLINE)\n"  # comments do not nest: ( ) become [ ]
        "(REFERENCE POSITION 10 MM = POINT 5)\n"
        "PARAM 3605#0=1\n"
        "PARAM 3620=5\n"
        "PARAM 3621=5\n"
        "PARAM 3622=7\n"
        "PARAM 3623=2\n"
        "(3624 IN MM; SERIES THAT TAKE DETECTION UNITS: 10000)\n"
        "PARAM 3624=10.000\n"
        "PARAM 3626=8\n"
        "(REFERENCE RETURN IN - DIRECTION, 1006#5 ZMI = 1: 3627 IS THE + TABLE AT THE REFERENCE)\n"
        "PARAM 3627=2\n"
        "(POSITIVE DIRECTION)\n"
        "PITCH 5=-1\n"
        "PITCH 6=4\n"
        "PITCH 7=-7\n"
        "(NEGATIVE DIRECTION)\n"
        "PITCH 8=-4\n"
        "PITCH 9=4\n"
        "PITCH 10=3\n"
    )


def test_bidirectional_reference_return_plus_3627_on_the_minus_table() -> None:
    # grid 0, 10, 20, reference 0 mm at the negative end; first point 0 → 3620 = 0, 3621 = 1, 3622 = 2.
    # e↑ = 1, 2, 4; e_ref = e↑(0) = 1: c↑ = 0, −1, −3 (v↑ = −1, −2)
    # e↓ = −2, 0, 3: c↓ = 3, 1, −2 (v↓ = −2, −3); 3627 = c↓(0) = 3
    grid = np.array([0.0, 10.0, 20.0])
    t = fanuc_pitch_table(np.array([1.0, 2.0, 4.0]), np.array([-2.0, 0.0, 3.0]), grid_mm=grid,
                          reference_position_mm=0.0)
    assert (t.reference_number, t.negative_end, t.positive_end) == (0, 1, 2)
    assert t.negative_table_start == 3 and t.reference_offset == 3
    assert t.values.tolist() == [-1, -2] and t.values_negative is not None
    assert t.values_negative.tolist() == [-2, -3]
    up, down = t.absolute_counts()
    assert up.tolist() == [0, -1, -3] and down is not None and down.tolist() == [3, 1, -2]
    # the listing says which reference return (the control's 1006#5 ZMI, not written) its 3627 is for
    assert "\n(REFERENCE RETURN IN + DIRECTION, 1006#5 ZMI = 0: 3627 IS THE - TABLE AT THE REFERENCE)\nPARAM 3627=3\n" \
        in fanuc_text(t)
    # e↓ = 1, 3, 3 equals e↑ at the reference: 3627 = 0, c↓ = 0, −2, −2
    t = fanuc_pitch_table(np.array([1.0, 2.0, 4.0]), np.array([1.0, 3.0, 3.0]), grid_mm=grid,
                          reference_position_mm=0.0, first_number=1)
    assert (t.reference_number, t.negative_end) == (0, 1) and t.reference_offset == 0
    up, down = t.absolute_counts()
    assert up.tolist() == [0, -1, -3] and down is not None and down.tolist() == [0, -2, -2]


def test_single_table_with_reference_return_minus_is_the_plus_curve() -> None:
    # one table for both directions: the reference-return direction changes nothing but the record
    e = np.array([0.0, 3.0, -2.0])
    grid = np.array([0.0, 10.0, 20.0])
    t = fanuc_pitch_table(e, None, grid_mm=grid, reference_position_mm=0.0, reference_direction=-1)
    assert t.values.tolist() == [-3, 5] and t.reference_direction == -1 and not t.bidirectional
    assert t.absolute_counts()[0].tolist() == [0, -3, 2]


def test_two_grid_positions_are_enough() -> None:
    # grid 0, 100, reference 100 mm: 1 interval below; first point 0 → 3620 = 0, 3621 = 0, 3622 = 0.
    # e = 3, 0 → c = −3, 0 → v = 3
    t = fanuc_pitch_table(np.array([3.0, 0.0]), None, grid_mm=np.array([0.0, 100.0]), reference_position_mm=100.0)
    assert (t.reference_number, t.negative_end, t.positive_end) == (0, 0, 0)
    assert t.values.tolist() == [3]
    assert fanuc_text(t).endswith("(BOTH DIRECTIONS)\nPITCH 0=3\n")


def test_point_number_zero_is_allowed_below_zero_is_refused() -> None:
    grid = np.arange(0.0, 31.0, 10.0)  # reference at 20 mm: 2 intervals on the negative side
    t = fanuc_pitch_table(np.zeros(4), None, grid_mm=grid, reference_position_mm=20.0, reference_number=1)
    assert (t.negative_end, t.positive_end) == (0, 2)  # 3621 = 1 − 2 + 1 = 0
    with pytest.raises(ValueError, match=re.escape("reference point number 0 leaves point numbers below 0 "
                                                   "(2 intervals on the negative side)")):
        fanuc_pitch_table(np.zeros(4), None, grid_mm=grid, reference_position_mm=20.0, reference_number=0)


def test_integer_inputs_are_taken_as_numbers_not_wrapping_integers() -> None:
    # a grid of int8 −100, 100 mm: the interval is 200 mm (int8 arithmetic would wrap to −56)
    t = fanuc_pitch_table(np.zeros(2), None, grid_mm=np.array([-100, 100], dtype=np.int8),
                          reference_position_mm=-100.0)
    assert t.interval_mm == 200.0 and t.positions_mm().tolist() == [-100.0, 100.0]
    # errors of int8 −100, 100 um, reference at the first: c = 0, −200 → v = −200
    t = fanuc_pitch_table(np.array([-100, 100], dtype=np.int8), None, grid_mm=np.array([0.0, 10.0]),
                          reference_position_mm=0.0)
    assert t.values.tolist() == [-200]
    # the same as the − curve with the reference return in −: e_ref = −100,
    # c↑ = −(0 + 100) = −100, −100 (v↑ = 0), c↓ = 0, −200 (v↓ = −200), 3627 = c↑(0) = −100
    t = fanuc_pitch_table(np.zeros(2), np.array([-100, 100], dtype=np.int8), grid_mm=np.array([0.0, 10.0]),
                          reference_position_mm=0.0, reference_direction=-1)
    assert t.values.tolist() == [0] and t.values_negative is not None and t.values_negative.tolist() == [-200]
    assert t.reference_offset == -100


# ----------------------------------------------------------------------------- grid tolerances


def test_equidistance_tolerance_is_1e_9_of_the_interval_or_of_1_mm() -> None:
    ok = [np.array([0.0, 50.0, 100.0 + 1e-9, 150.0]),  # 1e-9 mm off on a 50 mm interval (tolerance 5e-8 mm)
          np.array([0.0, 0.5, 1.0]),
          # exactly the tolerance, 1e-9 mm, on a sub-mm interval (all three differences exact in binary)
          np.array([0.0, 2.0**-40, 2.0**-39 + 1e-9])]
    for grid in ok:
        t = fanuc_pitch_table(np.zeros(len(grid)), None, grid_mm=grid, reference_position_mm=0.0)
        assert t.interval_mm == grid[1]
    bad = [np.array([0.0, 0.5, 1.0 + 1.5e-9]),  # 1.5e-9 mm off on 0.5 mm: above 1e-9 × 1 mm
           np.array([0.0, 50.0, 100.0 + 6e-8])]  # above 1e-9 × 50 mm
    for grid in bad:
        with pytest.raises(ValueError, match="^Fanuc pitch compensation needs an equidistant grid$"):
            fanuc_pitch_table(np.zeros(len(grid)), None, grid_mm=grid, reference_position_mm=0.0)


def test_reference_position_tolerance_and_range() -> None:
    grid = np.array([0.0, 1.0, 2.0])
    # 1e-6 mm off a grid position on a 1 mm interval is exactly the tolerance (1e-6 intervals): taken
    t = fanuc_pitch_table(np.zeros(3), None, grid_mm=grid, reference_position_mm=1e-6)
    assert t.reference_number == 0 and t.negative_end == 1
    for ref in (2e-6, 0.5, -1.0, 3.0):
        with pytest.raises(ValueError, match="^the reference position must be one of the grid positions$"):
            fanuc_pitch_table(np.zeros(3), None, grid_mm=grid, reference_position_mm=ref)


def test_grid_must_increase() -> None:
    for grid, first_two in ((np.array([0.0, 0.0]), "0 and 0"), (np.array([20.0, 10.0, 0.0]), "20 and 10")):
        with pytest.raises(ValueError, match=re.escape(f"the grid positions must increase (3624 > 0); the first two "
                                                       f"are {first_two} mm")):
            fanuc_pitch_table(np.zeros(len(grid)), None, grid_mm=grid, reference_position_mm=float(grid[0]))


# ------------------------------------------------------------------------------------ refusals


def test_refusals_name_the_problem() -> None:
    grid = np.array([0.0, 10.0, 20.0])
    with pytest.raises(ValueError, match="^a pitch table needs at least 2 grid positions$"):
        fanuc_pitch_table(np.zeros(1), None, grid_mm=np.array([0.0]), reference_position_mm=0.0)
    with pytest.raises(ValueError, match="^magnification must be a positive integer$"):
        fanuc_pitch_table(np.zeros(3), None, grid_mm=grid, reference_position_mm=0.0, magnification=0)
    for unit in (0.0, -1.0):
        with pytest.raises(ValueError, match="^detection unit must be positive$"):
            fanuc_pitch_table(np.zeros(3), None, grid_mm=grid, reference_position_mm=0.0, detection_unit_um=unit)
    for direction in (0, 2, -2):
        with pytest.raises(ValueError, match=r"^reference direction must be \+1 or -1$"):
            fanuc_pitch_table(np.zeros(3), None, grid_mm=grid, reference_position_mm=0.0,
                              reference_direction=direction)


def test_negative_direction_table_placement() -> None:
    # 5 grid positions from 0, reference 0, first point 10: 3620 = 9, + table points 10 … 13 (4 values);
    # a − table of 4 values at s covers s … s + 3 and overlaps unless s + 3 < 10 or s > 13
    grid = np.arange(0.0, 41.0, 10.0)

    def build(start: int) -> FanucPitchTable:
        return fanuc_pitch_table(np.zeros(5), np.zeros(5), grid_mm=grid, reference_position_mm=0.0,
                                 first_number=10, negative_table_start=start)

    for start in (0, 6, 14, 100):
        t = build(start)
        assert (t.negative_end, t.positive_end, t.negative_table_start) == (10, 13, start)
        assert f"PARAM 3626={start}\n" in fanuc_text(t)
    for start in (7, 10, 13):
        with pytest.raises(ValueError, match="^the negative-direction table overlaps the positive-direction table$"):
            build(start)
    with pytest.raises(ValueError, match=re.escape("negative-direction table start (3626) -1 is below 0")):
        build(-1)


def test_listing_refuses_an_inconsistent_table() -> None:
    # points 1 … 3 need 3 values; 2 given: no listing with a silently missing point
    short = FanucPitchTable(0, 1, 3, 1, 10.0, 1.0, 0.0, np.array([1, 2]))
    with pytest.raises(ValueError):
        fanuc_text(short)
    # bidirectional without 3626
    no_start = FanucPitchTable(0, 1, 2, 1, 10.0, 1.0, 0.0, np.array([1, 2]), values_negative=np.array([0, 0]))
    with pytest.raises(ValueError, match=re.escape("a bidirectional table needs parameter 3626 (the first point of its "
                                                   "negative-direction table)") + "$"):
        fanuc_text(no_start)
