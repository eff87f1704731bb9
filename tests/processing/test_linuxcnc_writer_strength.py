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
