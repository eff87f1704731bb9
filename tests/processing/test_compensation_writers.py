"""Controller file writers, read back by the test-side readers in tests/controller_parsers.py
that follow the controllers' documented rules, applied as the controller would."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from processing.compensation.fanuc import (
    absolute_from_incremental,
    fanuc_pitch_table,
    fanuc_text,
    incremental_from_absolute,
)
from processing.compensation.generic_csv import csv_text
from processing.compensation.linuxcnc import linuxcnc_comp_text
from processing.compensation.residuals import compare_models
from processing.compensation.siemens import siemens_lec_text
from processing.compensation.tables import ErrorTable, build_table, equidistant_grid
from tests.controller_parsers import read_fanuc, read_linuxcnc_comp, read_siemens_lec, sscanf_lf3

# Measured per-target means (ISO 230-2 style irregular targets), um
TARGET = np.array([0.0, 47.5, 101.25, 148.0, 203.5, 251.0, 297.75, 350.0, 398.5, 452.0, 500.0])
UP = 4.0 * np.sin(TARGET / 90.0) + 0.006 * TARGET
DOWN = UP - 2.5 + 0.8 * np.cos(TARGET / 60.0)


def one_point_table(error_um: float, mode: str = "bidirectional") -> ErrorTable:
    p = np.array([0.0, 100.0, 200.0])
    e = np.array([0.0, error_um, 0.0])
    return ErrorTable(p, e, e.copy(), mode, "linear")


# ---------------------------------------------------------------------------------- LinuxCNC


def test_reader_follows_the_linuxcnc_parser_rules() -> None:
    doc_type0 = "-1.000 -1.005 -0.995\n0.000 0.002 -0.003\n1.000 1.003 0.998\n"  # ini-config example
    c = read_linuxcnc_comp(doc_type0, 0)
    np.testing.assert_allclose(c.forward, [0.005, -0.002, -0.003], atol=1e-7)
    assert sscanf_lf3("1,2,3") == [1.0]  # CSV ends the file
    assert sscanf_lf3("\t1.5e1  2\t-3 trailing text") == [15.0, 2.0, -3.0]
    c = read_linuxcnc_comp("0 0 0\n1 1 1\n# comment\n2 2 2\n", 1)
    assert c.nominal == [0.0, 1.0] and c.lines_read == 2
    c = read_linuxcnc_comp("0 0 0\n2 0 0\n1 0 0\n3 0 0\n", 1)
    assert c.nominal == [0.0, 2.0, 3.0] and c.errors == ["compensation values must increase"]


@pytest.mark.parametrize("file_type", [0, 1])
def test_linuxcnc_sign_a_plus_5um_error_is_a_minus_5um_trim(file_type: int) -> None:
    text = linuxcnc_comp_text(one_point_table(5.0), file_type=file_type)
    line = text.splitlines()[1].split()
    if file_type == 0:  # documented: actual position = nominal + error
        assert [float(v) for v in line] == [100.0, 100.005, 100.005]
    else:  # documented: trim added to the command = −error
        assert [float(v) for v in line] == [100.0, -0.005, -0.005]
    c = read_linuxcnc_comp(text, file_type)
    assert c.trim(np.array([100.0]), +1)[0] == pytest.approx(-0.005, abs=1e-9)
    assert 5.0 + c.correction_um(np.array([100.0]), -1)[0] == pytest.approx(0.0, abs=1e-4)


@pytest.mark.parametrize("file_type", [0, 1])
@pytest.mark.parametrize("model", ["linear", "spline", "segments", "polynomial"])
def test_linuxcnc_round_trip_reproduces_the_model_residual(file_type: int, model: str) -> None:
    table = build_table(TARGET, UP, DOWN, model=model, degree=4)
    text = linuxcnc_comp_text(table, file_type=file_type)
    assert all(len(sscanf_lf3(ln)) == 3 for ln in text.splitlines())  # no header, no comment
    c = read_linuxcnc_comp(text, file_type)
    assert c.lines_read == len(table) and not c.errors
    for mean, e_tab, direction in ((UP, table.error_up, +1), (DOWN, table.error_down, -1)):
        compensated = mean + c.correction_um(TARGET, direction)
        intended = mean - np.interp(TARGET, table.position, e_tab)
        np.testing.assert_allclose(compensated, intended, atol=2e-3)  # 1 nm file resolution, float32 trims
    if model == "linear":  # the table nodes are the targets: nothing left
        np.testing.assert_allclose(UP + c.correction_um(TARGET, +1), 0.0, atol=2e-3)
    comp = compare_models(TARGET, UP, DOWN, models=[model], degree=4).iloc[1]
    both = np.r_[UP + c.correction_um(TARGET, +1), DOWN + c.correction_um(TARGET, -1)]
    assert np.max(np.abs(both)) == pytest.approx(comp.max_abs, abs=2e-3)


def test_linuxcnc_backlash_mode_folds_the_reversal_into_the_table() -> None:
    table = build_table(TARGET, UP, DOWN, mode="backlash")
    c = read_linuxcnc_comp(linuxcnc_comp_text(table, file_type=1), 1)
    b = np.mean(UP - DOWN)
    np.testing.assert_allclose(c.trim(TARGET, +1) - c.trim(TARGET, -1), -b / 1000.0, atol=2e-6)


def test_linuxcnc_limits() -> None:
    p = np.arange(257.0)
    big = ErrorTable(p, np.zeros(257), np.zeros(257), "bidirectional", "linear")
    with pytest.raises(ValueError, match="at most 256"):
        linuxcnc_comp_text(big)
    ok = ErrorTable(p[:256], np.zeros(256), np.zeros(256), "bidirectional", "linear")
    assert read_linuxcnc_comp(linuxcnc_comp_text(ok), 1).lines_read == 256
    close = ErrorTable(np.array([0.0, 1e-8]), np.zeros(2), np.zeros(2), "bidirectional", "linear")
    with pytest.raises(ValueError, match="strictly increasing"):
        linuxcnc_comp_text(close)
    with pytest.raises(ValueError, match="0 or 1"):
        linuxcnc_comp_text(ok, file_type=2)


# ---------------------------------------------------------------------------------- Fanuc

MANUAL_INCREMENTS = [+2, +1, +1, -2, 0, -1, 0, -1, +2, +1, 0, -1, -1, -2, 0, +1, +2]  # points 33 … 49
MANUAL_ABSOLUTE = [0, 2, 3, 4, 2, 2, 1, 1, 0, 2, 3, 3, 2, 1, -1, -1, 0, 2]  # x = −400 … 450 mm


def test_fanuc_manual_example_converts_both_ways() -> None:
    assert list(incremental_from_absolute(np.array(MANUAL_ABSOLUTE))) == MANUAL_INCREMENTS
    assert list(absolute_from_incremental(np.array(MANUAL_INCREMENTS), 33, 40)) == MANUAL_ABSOLUTE


def test_fanuc_manual_example_round_trips_through_the_writer() -> None:
    # interval 50 mm, reference = point 40 at 0 mm; an error of −c um gives a correction of c counts
    grid = np.arange(-400.0, 451.0, 50.0)
    t = fanuc_pitch_table(-np.array(MANUAL_ABSOLUTE, dtype=float), None, grid_mm=grid, reference_position_mm=0.0,
                          reference_number=40)
    assert (t.reference_number, t.negative_end, t.positive_end) == (40, 33, 49)
    assert list(t.values) == MANUAL_INCREMENTS
    f = read_fanuc(fanuc_text(t))
    assert f.params["3620"] == 40 and f.params["3621"] == 33 and f.params["3622"] == 49
    assert f.params["3624"] == 50.0 and f.params["3605#0"] == 0
    assert [f.points[n] for n in range(33, 50)] == MANUAL_INCREMENTS
    assert list(f.absolute_counts(grid, 0.0, +1)) == MANUAL_ABSOLUTE


def test_fanuc_sign_and_cumulative_rounding() -> None:
    grid = np.arange(0.0, 1001.0, 100.0)
    # +5 um error at 100 mm (0 at the reference, 0 mm) → absolute correction −5 counts
    t = fanuc_pitch_table(np.r_[0.0, 5.0, np.zeros(9)], None, grid_mm=grid, reference_position_mm=0.0)
    assert read_fanuc(fanuc_text(t)).absolute_counts(np.array([100.0]), 0.0, +1)[0] == -5
    # magnification 2: −5/2 = −2.5 → −3 counts (half away from zero) = −6 um
    t = fanuc_pitch_table(np.r_[0.0, 5.0, np.zeros(9)], None, grid_mm=grid, reference_position_mm=0.0,
                          magnification=2)
    assert read_fanuc(fanuc_text(t)).correction_um(np.array([100.0]), 0.0, +1, 1.0)[0] == -6.0
    # 0.4 um more error per interval: rounding every increment would give 0 everywhere; rounding
    # the cumulative value gives round(−0.4 k) = 0, 0, −1, −1, −2, −2, −2, −3, −3, −4, −4
    t = fanuc_pitch_table(0.4 * np.arange(11), None, grid_mm=grid, reference_position_mm=0.0)
    f = read_fanuc(fanuc_text(t))
    assert list(f.absolute_counts(grid, 0.0, +1)) == [0, 0, -1, -1, -2, -2, -2, -3, -3, -4, -4]
    assert sum(t.values) == -4


def test_fanuc_bidirectional_tables_reproduce_the_intended_correction() -> None:
    step, ref = 50.0, 100.0
    grid = equidistant_grid(0.0, 500.0, step, anchor=ref)
    table = build_table(TARGET, UP, DOWN, model="spline", positions=grid)
    t = fanuc_pitch_table(table.error_up, table.error_down, grid_mm=grid, reference_position_mm=ref,
                          first_number=10)
    f = read_fanuc(fanuc_text(t))
    assert f.params["3605#0"] == 1 and f.params["3621"] == 10 and f.params["3620"] == 11
    assert f.params["3626"] == f.params["3622"] + 1
    e_ref = table.error_up[2]  # reference return in + direction: the + curve is zero at the reference
    assert f.params["3627"] == round(-(table.error_down[2] - e_ref))
    for e_tab, direction in ((table.error_up, +1), (table.error_down, -1)):
        compensated = e_tab + f.correction_um(grid, ref, direction, 1.0)
        np.testing.assert_allclose(compensated, e_ref, atol=0.5 + 1e-9)  # within half a count


def test_fanuc_bidirectional_reference_return_minus_reproduces_the_intended_correction() -> None:
    step, ref = 50.0, 100.0
    grid = equidistant_grid(0.0, 500.0, step, anchor=ref)
    table = build_table(TARGET, UP, DOWN, model="spline", positions=grid)
    t = fanuc_pitch_table(table.error_up, table.error_down, grid_mm=grid, reference_position_mm=ref,
                          first_number=10, reference_direction=-1)
    f = read_fanuc(fanuc_text(t))
    e_ref = table.error_down[2]  # reference return in − direction: the − curve is zero at the reference
    # 3627: the + table at the reference, approached against the reference return
    assert f.params["3627"] == round(-(table.error_up[2] - e_ref))
    for e_tab, direction in ((table.error_up, +1), (table.error_down, -1)):
        compensated = e_tab + f.correction_um(grid, ref, direction, 1.0, reference_direction=-1)
        np.testing.assert_allclose(compensated, e_ref, atol=0.5 + 1e-9)  # within half a count


def test_fanuc_reader_reference_return_minus_hand_counts() -> None:
    # grid 0 … 30 mm, reference 10 mm = point 5, × 2; reference return in −: e_ref = e↓(10) = 8 um,
    # c↑ = round(−(2 − 8, 4 − 8, −4 − 8, 9 − 8)/2) = 3, 2, 6, −1; c↓ = round(−(0 − 8, 8 − 8, 1 − 8, −6 − 8)/2)
    # = 4, 0, 4, 7 (halves away from zero)
    t = fanuc_pitch_table(np.array([2.0, 4.0, -4.0, 9.0]), np.array([0.0, 8.0, 1.0, -6.0]),
                          grid_mm=np.array([0.0, 10.0, 20.0, 30.0]), reference_position_mm=10.0, magnification=2,
                          reference_number=5, reference_direction=-1)
    f = read_fanuc(fanuc_text(t))
    x = np.array([0.0, 10.0, 20.0, 30.0])
    assert f.absolute_counts(x, 10.0, +1, reference_direction=-1).tolist() == [3, 2, 6, -1]
    assert f.absolute_counts(x, 10.0, -1, reference_direction=-1).tolist() == [4, 0, 4, 7]
    with pytest.raises(AssertionError, match="reference return"):  # the listing says it is for −
        f.absolute_counts(x, 10.0, +1)


def test_fanuc_rejects_bad_grids() -> None:
    with pytest.raises(ValueError, match="grid positions"):
        fanuc_pitch_table(np.zeros(3), None, grid_mm=np.array([0.0, 10.0, 20.0]), reference_position_mm=5.0)
    with pytest.raises(ValueError, match="equidistant"):
        fanuc_pitch_table(np.zeros(3), None, grid_mm=np.array([0.0, 10.0, 25.0]), reference_position_mm=0.0)
    with pytest.raises(ValueError, match="overlaps"):
        fanuc_pitch_table(np.zeros(3), np.zeros(3), grid_mm=np.array([0.0, 10.0, 20.0]), reference_position_mm=0.0,
                          negative_table_start=1)


# ---------------------------------------------------------------------------------- Siemens


def test_siemens_sign_a_plus_5um_error_is_a_plus_0_005_value() -> None:
    text = siemens_lec_text(np.array([0.0, 100.0, 200.0]), np.array([0.0, 5.0, 0.0]), axis="X1")
    lec = read_siemens_lec(text)
    assert lec.values_mm[1] == 0.005 and lec.axis == "X1" and lec.encoder == 0
    assert 5.0 + lec.correction_um(np.array([100.0]))[0] == pytest.approx(0.0)


def test_siemens_round_trip_reproduces_the_model_residual() -> None:
    grid = equidistant_grid(0.0, 500.0, 25.0)
    table = build_table(TARGET, UP, DOWN, model="segments", mode="backlash", positions=grid)
    text = siemens_lec_text(grid, table.error_up, axis="Y1", encoder=1, max_points=21)
    lec = read_siemens_lec(text)
    assert (lec.step, lec.minimum, lec.maximum, lec.modulo) == (25.0, 0.0, 500.0, False)
    assert lec.axis == "Y1" and lec.encoder == 1
    mean = (UP + DOWN) / 2
    compensated = mean + lec.correction_um(TARGET)
    np.testing.assert_allclose(compensated, mean - np.interp(TARGET, grid, table.error_up), atol=1e-3)
    with pytest.raises(ValueError, match="MD38000"):
        siemens_lec_text(grid, table.error_up, max_points=20)


def test_siemens_limits_and_modulo() -> None:
    with pytest.raises(ValueError, match="equidistant"):
        siemens_lec_text(np.array([0.0, 1.0, 3.0]), np.zeros(3))
    with pytest.raises(ValueError, match="6 decimals"):
        siemens_lec_text(np.array([0.0, 1 / 3, 2 / 3]), np.zeros(3))
    with pytest.raises(ValueError, match="equal values"):
        siemens_lec_text(np.array([0.0, 180.0, 360.0]), np.array([1.0, 0.0, 2.0]), modulo=True)
    lec = read_siemens_lec(siemens_lec_text(np.array([0.0, 180.0, 360.0]), np.array([3.6, 0.0, 3.6]),
                                            unit_scale=1 / 3600, decimals=8, modulo=True))
    assert lec.modulo and lec.values_mm[0] == 0.001


# ---------------------------------------------------------------------------------- CSV


def test_csv_columns_and_signs() -> None:
    rows = list(csv.DictReader(io.StringIO(csv_text(one_point_table(5.0)))))
    assert list(rows[0]) == ["position_mm", "error_up_um", "error_down_um", "correction_up_um",
                             "correction_down_um"]
    assert float(rows[1]["error_up_um"]) == 5.0 and float(rows[1]["correction_down_um"]) == -5.0
    assert rows[0]["correction_up_um"] == "0.000000"  # never "-0.000000"
