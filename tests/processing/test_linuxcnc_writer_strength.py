"""LinuxCNC COMP_FILE writer: the number of decimals and the rotary unit scale, with the
expected lines written out by hand (standards.md 4.1: type 0 = nominal, nominal + e↑,
nominal + e↓; type 1 = nominal, −e↑, −e↓; arcsec → deg is /3600) — issue 28."""

from __future__ import annotations

import numpy as np
import pytest

from processing.compensation.linuxcnc import linuxcnc_applied, linuxcnc_columns, linuxcnc_comp_text
from processing.compensation.tables import ErrorTable

DEG = np.array([0.0, 90.0, 180.0, 270.0])
UP_ARCSEC = np.array([0.0, 36.0, -18.0, 7.2])  # 0.01, -0.005, 0.002 deg
DOWN_ARCSEC = np.array([0.0, 30.0, -12.0, 3.6])  # 0.008333…, -0.003333…, 0.001 deg
ROTARY = ErrorTable(DEG, UP_ARCSEC, DOWN_ARCSEC, "bidirectional", "linear")


def test_rotary_type_1_trims_in_degrees() -> None:
    text = linuxcnc_comp_text(ROTARY, file_type=1, unit_scale=1 / 3600)
    assert text == ("0.000000 0.000000 0.000000\n"
                    "90.000000 -0.010000 -0.008333\n"
                    "180.000000 0.005000 0.003333\n"
                    "270.000000 -0.002000 -0.001000\n")


def test_rotary_type_0_actual_positions_in_degrees() -> None:
    text = linuxcnc_comp_text(ROTARY, file_type=0, unit_scale=1 / 3600)
    assert text.splitlines()[1:3] == ["90.000000 90.010000 90.008333", "180.000000 179.995000 179.996667"]


def test_decimals_are_the_number_asked_for() -> None:
    assert linuxcnc_columns(ROTARY, file_type=1, unit_scale=1 / 3600, decimals=3)[1] == ("90.000", "-0.010", "-0.008")
    assert linuxcnc_columns(ROTARY, file_type=0, unit_scale=1 / 3600, decimals=4)[2] == (
        "180.0000", "179.9950", "179.9967")
    linear = ErrorTable(np.array([0.0, 100.0]), np.array([1.2345, -2.5]), np.array([0.0, 0.0004]),
                        "bidirectional", "linear")
    assert linuxcnc_comp_text(linear, decimals=5) == "0.00000 -0.00123 0.00000\n100.00000 0.00250 0.00000\n"
    assert linuxcnc_comp_text(linear, decimals=7) == ("0.0000000 -0.0012345 0.0000000\n"
                                                      "100.0000000 0.0025000 -0.0000004\n")
    # type 0: the actual position is the rounded nominal plus the error, so both round alike
    odd = ErrorTable(np.array([12.34567, 99.99951]), np.array([2.0, 0.0]), np.array([0.0, 0.0]),
                     "bidirectional", "linear")
    assert linuxcnc_comp_text(odd, file_type=0, decimals=3) == "12.346 12.348 12.346\n100.000 100.000 100.000\n"
    with pytest.raises(ValueError, match="strictly increasing at 2 decimals"):
        linuxcnc_comp_text(ErrorTable(np.array([1.001, 1.004]), np.zeros(2), np.zeros(2), "bidirectional",
                                      "linear"), decimals=2)


@pytest.mark.parametrize("file_type", [0, 1])
def test_rotary_as_written_error_is_in_arcsec(file_type: int) -> None:
    """What the controller removes with the file as written: the 6-decimal degrees back in arcsec
    (30 arcsec = 0.008333 deg as written = 29.9988 arcsec), not 3.6 x off."""
    applied = linuxcnc_applied(ROTARY, file_type=file_type, unit_scale=1 / 3600)
    np.testing.assert_allclose(applied.position, DEG)
    np.testing.assert_allclose(applied.error_up, [0.0, 36.0, -18.0, 7.2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(applied.error_down, [0.0, 29.9988, -11.9988, 3.6], rtol=0, atol=1e-9)


def test_linear_as_written_error_is_in_um() -> None:
    linear = ErrorTable(np.array([0.0, 50.0]), np.array([1.23456, -5.0]), np.array([0.5, 0.0]),
                        "bidirectional", "linear")
    applied = linuxcnc_applied(linear, file_type=1, decimals=4)  # 0.1 um resolution
    np.testing.assert_allclose(applied.error_up, [1.2, -5.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(applied.error_down, [0.5, 0.0], rtol=0, atol=1e-9)


def test_defaults_are_type_1_trims_in_mm_at_6_decimals() -> None:
    """Without options: COMP_FILE_TYPE 1 (trims −e), um → mm (x 1e-3), 6 decimals (1 nm)."""
    table = ErrorTable(np.array([0.0, 250.5]), np.array([1.5, -2.25]), np.array([0.5, 0.0]),
                       "bidirectional", "linear")
    expected = [("0.000000", "-0.001500", "-0.000500"), ("250.500000", "0.002250", "0.000000")]
    assert linuxcnc_columns(table) == expected
    assert linuxcnc_comp_text(table) == "".join(f"{a} {b} {c}\n" for a, b, c in expected)
    applied = linuxcnc_applied(table)  # every value is exact at 6 decimals of a mm: nothing lost
    np.testing.assert_allclose(applied.position, [0.0, 250.5])
    np.testing.assert_allclose(applied.error_up, [1.5, -2.25], rtol=0, atol=1e-9)
    np.testing.assert_allclose(applied.error_down, [0.5, 0.0], rtol=0, atol=1e-9)


def test_too_many_entries_says_what_to_do() -> None:
    p = np.arange(300.0)
    big = ErrorTable(p, np.zeros(300), np.zeros(300), "bidirectional", "linear")
    with pytest.raises(ValueError) as err:
        linuxcnc_columns(big)
    message = str(err.value)
    assert "300 table entries" in message and "at most 256" in message
    assert message.endswith("(use a larger grid step or the segments model)")


@pytest.mark.parametrize("file_type", [0, 1])
def test_error_columns_shorter_than_positions_are_refused(file_type: int) -> None:
    """One error value fewer than positions must not silently drop the last table entry."""
    table = ErrorTable(np.array([0.0, 10.0, 20.0]), np.array([1.0, 2.0]), np.array([1.0, 2.0]),
                       "bidirectional", "linear")
    with pytest.raises(ValueError):
        linuxcnc_columns(table, file_type=file_type)


def test_float32_errors_are_converted_in_double_precision() -> None:
    """7.25 um and -3.5 um are exact in float32; in mm they are 0.00725 and -0.0035 exactly, so
    even at 10 decimals the trims (−e) read -0.0072500000 and 0.0035000000 (float32 arithmetic
    would give -0.0072500003 and 0.0035000001)."""
    table = ErrorTable(np.array([0.0, 100.0]), np.array([7.25, 0.0], dtype=np.float32),
                       np.array([-3.5, 0.0], dtype=np.float32), "bidirectional", "linear")
    assert linuxcnc_columns(table, decimals=10)[0] == ("0.0000000000", "-0.0072500000", "0.0035000000")
    # type 0: the actual positions P + e, same digits
    assert linuxcnc_columns(table, file_type=0, decimals=10)[0] == ("0.0000000000", "0.0072500000",
                                                                    "-0.0035000000")


def test_type_0_float32_positions_keep_the_error_to_half_a_digit() -> None:
    """Type 0 stores actual = P + e and the loader takes nominal − actual, so the error as written
    (actual − nominal) must be e to within half the last digit (0.5 nm at 6 decimals of a mm),
    whatever the positions' dtype.  float32(20.000011) is 20.0000114441… mm, written 20.000011;
    with e↑ = +0.3 nm the actual position is 20.0000113 → 20.000011 (error as written 0 nm,
    |0 − 0.3| <= 0.5), not 20.000012 (1 nm, from adding e to the unrounded 20.0000114441)."""
    position = np.array([20.000011, 30.5], dtype=np.float32)
    e_up_um, e_dn_um = np.array([0.0003, 0.0003]), np.array([-0.0003, -0.0003])
    table = ErrorTable(position, e_up_um, e_dn_um, "bidirectional", "linear")
    rows = linuxcnc_columns(table, file_type=0)
    assert rows[0] == ("20.000011", "20.000011", "20.000011")
    assert rows[1] == ("30.500000", "30.500000", "30.500000")
    half_digit_um = 0.5e-6 * 1e3
    for (nominal, fwd, rev), up_um, dn_um in zip(rows, e_up_um, e_dn_um, strict=True):
        assert abs((float(fwd) - float(nominal)) * 1e3 - up_um) <= half_digit_um + 1e-12
        assert abs((float(rev) - float(nominal)) * 1e3 - dn_um) <= half_digit_um + 1e-12


@pytest.mark.parametrize("file_type", [0, 1])
def test_applied_is_a_bidirectional_table_of_the_same_model(file_type: int) -> None:
    """The file holds a forward and a reverse column (LinuxCNC ignores BACKLASH with a COMP_FILE),
    so what it applies is a bidirectional table with the backlash folded in: ē ± B̄/2."""
    table = ErrorTable(np.array([0.0, 100.0]), np.array([2.0, -1.0]), np.array([2.0, -1.0]),
                       "backlash", "spline", backlash=3.0)
    applied = linuxcnc_applied(table, file_type=file_type)
    assert applied.mode == "bidirectional"
    assert applied.model == "spline"
    assert applied.backlash == 0.0
    np.testing.assert_allclose(applied.error_up, [3.5, 0.5], rtol=0, atol=1e-9)
    np.testing.assert_allclose(applied.error_down, [0.5, -2.5], rtol=0, atol=1e-9)
