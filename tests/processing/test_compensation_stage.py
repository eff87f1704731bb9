"""The compensation stage of each controller (processing/compensation/stage*.py) against values
computed by hand from the controllers' documented rules (standards.md §4.1, §4.2, §4.3, §4.4,
shared/reference/linuxcnc.md)."""

from __future__ import annotations

import numpy as np
import pytest

from processing.compensation.fanuc import fanuc_pitch_table, fanuc_text
from processing.compensation.stage import Compensator, detect_format, load_controller_table
from processing.compensation.stage_linuxcnc import read_linuxcnc_comp

TYPE1 = "0.0 0.010 -0.005\n10.0 0.020 0.005\n20.0 0.0 0.0\n"


def f32(v: float) -> float:
    return float(np.float32(v))


# ---------------------------------------------------------------------------------------------- LinuxCNC

def test_linuxcnc_type1_interpolates_per_direction_and_holds_the_ends() -> None:
    t = load_controller_table(TYPE1, "linuxcnc", comp_file_type=1)
    # half way between 0 and 10: (0.010 + 0.020) / 2 forward, (-0.005 + 0.005) / 2 reverse
    assert t.correction(5.0, 1) == pytest.approx(0.015, abs=1e-8)
    assert t.correction(5.0, -1) == pytest.approx(0.0, abs=1e-8)
    assert t.correction(12.5, 1) == pytest.approx(0.020 - 0.25 * 0.020, abs=1e-8)
    # outside the table the first / last entry's trim holds
    assert t.correction(-3.0, 1) == f32(0.010) and t.correction(-3.0, -1) == f32(-0.005)
    assert t.correction(25.0, 1) == 0.0 and t.correction(1e9, -1) == 0.0
    # before any motion LinuxCNC has applied nothing
    assert t.correction(5.0, 0) == 0.0


def test_linuxcnc_type0_columns_are_actual_positions() -> None:
    # type 0: trim = nominal - actual: 10 - 10.003 = -0.003 forward, 10 - 9.998 = +0.002 reverse
    t = load_controller_table("0.0 0.0 0.0\n10.0 10.003 9.998\n", "linuxcnc", comp_file_type=0)
    assert t.correction(10.0, 1) == pytest.approx(-0.003, abs=1e-7)
    assert t.correction(10.0, -1) == pytest.approx(0.002, abs=1e-7)
    assert t.correction(5.0, 1) == pytest.approx(-0.0015, abs=1e-7)


def test_linuxcnc_trims_are_float32() -> None:
    t = load_controller_table("0.0 0.1234567891 0\n1.0 0 0\n", "linuxcnc", comp_file_type=1)
    assert t.correction(0.0, 1) == f32(0.1234567891) != 0.1234567891


@pytest.mark.parametrize("breaker", ["# a comment\n", "\n", "nominal forward reverse\n", "1.0,2.0,3.0\n",
                                     "5.0 0.001\n"])
def test_linuxcnc_loader_stops_silently_at_the_first_line_not_three_numbers(breaker: str) -> None:
    text = "0.0 0.010 0.010\n" + breaker + "10.0 0.020 0.020\n"
    comp = read_linuxcnc_comp(text, 1)
    assert list(comp.nominal) == [0.0] and comp.lines_read == 1 and comp.refused == ()
    t = load_controller_table(text, "linuxcnc", comp_file_type=1)
    assert t.correction(10.0, 1) == f32(0.010)  # the second entry never arrived


def test_linuxcnc_extra_text_after_three_numbers_is_ignored_and_tabs_are_white_space() -> None:
    comp = read_linuxcnc_comp("0.0\t0.001\t0.002 trailing words\n1.0 0.003 0.004\n", 1)
    assert list(comp.nominal) == [0.0, 1.0]


def test_linuxcnc_non_increasing_entries_are_refused_and_reading_goes_on() -> None:
    comp = read_linuxcnc_comp("0.0 0 0\n10.0 0.01 0.01\n10.0 0.5 0.5\n5.0 0.5 0.5\n20.0 0.02 0.02\n", 1)
    assert list(comp.nominal) == [0.0, 10.0, 20.0]
    assert comp.refused == ("line 3: compensation values must increase", "line 4: compensation values must increase")


def test_linuxcnc_at_most_256_entries() -> None:
    text = "".join(f"{i}.0 0.001 0.001\n" for i in range(260))
    comp = read_linuxcnc_comp(text, 1)
    assert len(comp) == 256 and comp.nominal[-1] == 255.0 and len(comp.refused) == 4
    assert comp.refused[0] == "line 257: too many compensation entries"


def test_linuxcnc_a_file_it_reads_nothing_from_and_a_missing_type_are_refused() -> None:
    with pytest.raises(ValueError, match="first line is not three numbers"):
        load_controller_table("# header\n0 0 0\n", "linuxcnc", comp_file_type=1)
    with pytest.raises(ValueError, match="COMP_FILE_TYPE"):
        load_controller_table(TYPE1, "linuxcnc")
    with pytest.raises(ValueError, match="COMP_FILE_TYPE must be 0 or 1"):
        load_controller_table(TYPE1, "linuxcnc", comp_file_type=2)


def test_direction_comes_from_the_commanded_motion_and_is_kept_at_rest() -> None:
    t = load_controller_table(TYPE1, "linuxcnc", comp_file_type=1)
    c = Compensator(t, start=0.0)
    assert c.move_to(0.0) == 0.0  # no motion yet
    assert c.move_to(5.0) == pytest.approx(0.015, abs=1e-8)  # moving +
    assert c.move_to(5.0) == pytest.approx(0.015, abs=1e-8) and c.direction == 1  # at rest: kept
    assert c.move_to(7.0) == pytest.approx(0.017, abs=1e-8)
    assert c.move_to(5.0) == pytest.approx(0.0, abs=1e-8) and c.direction == -1  # reversed
    assert c.move_to(5.0) == pytest.approx(0.0, abs=1e-8) and c.direction == -1


# ---------------------------------------------------------------------------------------------- Fanuc

# standards.md §4.4: the 0i-PB manual's example, interval 50 mm, reference = point 40 at 0 mm
MANUAL_INCREMENTS = [2, 1, 1, -2, 0, -1, 0, -1, 2, 1, 0, -1, -1, -2, 0, 1, 2]  # points 33 … 49
MANUAL_PROFILE = [0, 2, 3, 4, 2, 2, 1, 1, 0, 2, 3, 3, 2, 1, -1, -1, 0, 2]  # x = -400 … +450 mm


def fanuc_listing(increments: list[int], *, first: int = 33, ref: int = 40, mag: int = 1, interval: str = "50.000",
                  extra: tuple[str, ...] = (), comments: tuple[str, ...] = ()) -> str:
    lines = [*comments, "PARAM 3605#0=0", f"PARAM 3620={ref}", f"PARAM 3621={first}",
             f"PARAM 3622={first + len(increments) - 1}", f"PARAM 3623={mag}", f"PARAM 3624={interval}", *extra]
    lines += [f"PITCH {first + i}={v}" for i, v in enumerate(increments)]
    return "\n".join(lines) + "\n"


def test_fanuc_manual_example_cumulative_from_the_reference() -> None:
    t = load_controller_table(fanuc_listing(MANUAL_INCREMENTS), "fanuc", reference_position=0.0)
    x = np.arange(-400.0, 451.0, 50.0)
    got = [t.correction(v, 1) * 1000.0 for v in x]  # counts of 1 um
    assert got == pytest.approx(MANUAL_PROFILE, abs=1e-12)
    assert t.correction(25.0, 1) * 1000 == pytest.approx(1.0)  # half of point 41's increment (+2)
    assert t.correction(-375.0, 1) * 1000 == pytest.approx(1.0)
    assert t.correction(-1000.0, 1) * 1000 == pytest.approx(0.0)  # below point 32: nothing more output
    assert t.correction(2000.0, 1) * 1000 == pytest.approx(2.0)  # beyond point 49: held


def test_fanuc_magnification_detection_unit_and_reference_position() -> None:
    # one count = 0.5 um x magnification 3 = 1.5 um; the reference point (0 counts) at x = 200 mm
    t = load_controller_table(fanuc_listing(MANUAL_INCREMENTS, mag=3), "fanuc", reference_position=200.0,
                              detection_unit_um=0.5)
    assert t.correction(200.0, 1) == 0.0
    assert t.correction(250.0, 1) == pytest.approx(2 * 1.5e-3)  # point 41: +2 counts
    assert t.correction(-200.0, 1) == pytest.approx(0.0)  # x_ref - 400: profile 0


def test_fanuc_reads_the_reference_position_and_unit_from_the_listing_comments() -> None:
    text = fanuc_listing(MANUAL_INCREMENTS, comments=("(GUIDEWAY PITCH ERROR COMPENSATION AXIS Y)",
                                                      "(ONE COUNT = 2 UM X MAGNIFICATION 1; VALUES ARE ...)",
                                                      "(REFERENCE POSITION 100 MM = POINT 40)"))
    t = load_controller_table(text, "fanuc")
    assert (t.reference_position, t.detection_unit_um, t.axis) == (100.0, 2.0, "Y")
    assert t.correction(150.0, 1) == pytest.approx(4e-3)
    with pytest.raises(ValueError, match="reference position"):
        load_controller_table(fanuc_listing(MANUAL_INCREMENTS), "fanuc")


def test_fanuc_values_are_whole_counts() -> None:
    text = fanuc_listing(MANUAL_INCREMENTS).replace("PITCH 35=1", "PITCH 35=1.5")
    with pytest.raises(ValueError, match="line .*not a Fanuc listing line"):
        load_controller_table(text, "fanuc", reference_position=0.0)


def test_fanuc_bidirectional_minus_table_from_3626_with_3627_at_the_reference() -> None:
    extra = ("PARAM 3626=60", "PARAM 3627=5")
    text = fanuc_listing(MANUAL_INCREMENTS, extra=extra).replace("PARAM 3605#0=0", "PARAM 3605#0=1")
    text += "".join(f"PITCH {60 + i}=1\n" for i in range(len(MANUAL_INCREMENTS)))
    t = load_controller_table(text, "fanuc", reference_position=0.0)
    assert t.correction(0.0, -1) * 1000 == pytest.approx(5.0)
    assert t.correction(100.0, -1) * 1000 == pytest.approx(7.0)  # 5 + two increments of 1
    assert t.correction(-100.0, -1) * 1000 == pytest.approx(3.0)
    assert t.correction(100.0, 1) * 1000 == pytest.approx(3.0)  # the + table as before


def test_fanuc_backlash_1851_after_power_on_and_reversals() -> None:
    text = fanuc_listing([0] * len(MANUAL_INCREMENTS), extra=("PARAM 1851=4",))
    t = load_controller_table(text, "fanuc", reference_position=0.0)  # reference return in +
    c = Compensator(t, start=0.0)
    assert c.move_to(0.0) == 0.0  # power-on: the reference-return direction, nothing output
    assert c.move_to(100.0) == 0.0  # the first move in that direction outputs nothing
    assert c.move_to(50.0) == pytest.approx(-4e-3)  # the first reversal: 4 units in the new direction
    assert c.move_to(50.0) == pytest.approx(-4e-3)  # at rest: kept
    assert c.move_to(10.0) == pytest.approx(-4e-3)
    assert c.move_to(60.0) == pytest.approx(0.0)  # back in +: taken back
    t_minus = load_controller_table(text, "fanuc", reference_position=0.0, reference_direction=-1)
    c = Compensator(t_minus, start=0.0)
    assert c.move_to(-10.0) == 0.0 and c.move_to(10.0) == pytest.approx(4e-3)


def test_fanuc_1852_for_rapid_only_with_1800_bit_4() -> None:
    base = fanuc_listing([0] * 17, extra=("PARAM 1851=4", "PARAM 1852=9"))
    t = load_controller_table(base, "fanuc", reference_position=0.0)
    assert t.correction(0.0, -1, rapid=True) == pytest.approx(-4e-3)  # RBK = 0: 1851 for everything
    t = load_controller_table(base.replace("PARAM 1851=4", "PARAM 1800#4=1\nPARAM 1851=4"), "fanuc",
                              reference_position=0.0)
    assert t.correction(0.0, -1, rapid=True) == pytest.approx(-9e-3)
    assert t.correction(0.0, -1) == pytest.approx(-4e-3)


def test_fanuc_pitch_acts_only_after_reference_return() -> None:
    t = load_controller_table(fanuc_listing(MANUAL_INCREMENTS, extra=("PARAM 1851=4",)), "fanuc",
                              reference_position=0.0)
    assert t.correction(100.0, 1, referenced=False) == 0.0
    assert t.correction(100.0, -1, referenced=False) == pytest.approx(-4e-3)  # backlash from power-on
    assert t.correction(100.0, 1) == pytest.approx(3e-3)


def test_fanuc_rotary_table_wraps_per_revolution() -> None:
    # standards.md rotary example: 3625 = 360, interval 45, reference point 60, points 60 … 68 (60 = 68)
    inc = {60: 1, 61: 2, 62: 1, 63: -1, 64: -2, 65: 0, 66: 1, 67: -2, 68: 1}  # 61 … 68 sum to 0
    text = "\n".join(["PARAM 3620=60", "PARAM 3621=60", "PARAM 3622=68", "PARAM 3623=1", "PARAM 3624=45",
                      "PARAM 3625=360", *[f"PITCH {n}={v}" for n, v in inc.items()]]) + "\n"
    t = load_controller_table(text, "fanuc", reference_position=0.0)
    profile = {0: 0, 45: 2, 90: 3, 135: 2, 180: 0, 225: 0, 270: 1, 315: -1}
    for a, counts in profile.items():
        assert t.correction(float(a), 1) * 1000 == pytest.approx(counts)
        assert t.correction(a + 360.0, 1) * 1000 == pytest.approx(counts)
        assert t.correction(a - 720.0, 1) * 1000 == pytest.approx(counts)
    assert t.correction(22.5, 1) * 1000 == pytest.approx(1.0)
    assert t.correction(337.5, 1) * 1000 == pytest.approx(-0.5)  # 315 -> 360: -1 -> 0


# ---------------------------------------------------------------------------------------------- Siemens

LEC = """%_N_AX_EEC_INI
CHANDATA(1)
$AA_ENC_COMP[0,0,X1]=0.003 ; +3 um
$AA_ENC_COMP[0,1,X1]=0.01
$AA_ENC_COMP[0,2,X1]=0.012
$AA_ENC_COMP_STEP[0,X1]=1.0
$AA_ENC_COMP_MIN[0,X1]=-1.0
$AA_ENC_COMP_MAX[0,X1]=1.0
$AA_ENC_COMP_IS_MODULO[0,X1]=0
M17
"""


def test_siemens_lec_is_the_error_interpolated_held_and_not_direction_dependent() -> None:
    t = load_controller_table(LEC, "siemens")
    assert t.axis == "X1"
    # a positive value moves the axis in the negative direction: correction = -value
    assert t.correction(-1.0, 1) == pytest.approx(-0.003)
    assert t.correction(-0.5, 1) == pytest.approx(-(0.003 + 0.01) / 2)
    assert t.correction(0.25, -1) == pytest.approx(-(0.01 + 0.25 * 0.002))
    assert t.correction(-0.5, -1) == t.correction(-0.5, 1) == t.correction(-0.5, 0)
    assert t.correction(-50.0, 1) == pytest.approx(-0.003) and t.correction(50.0, 1) == pytest.approx(-0.012)
    assert t.correction(0.0, 1, referenced=False) == 0.0  # active only after referencing


def test_siemens_modulo_table_repeats() -> None:
    text = """%_N_AX_EEC_INI
$AA_ENC_COMP[0,0,C1]=0.001
$AA_ENC_COMP[0,1,C1]=0.002
$AA_ENC_COMP[0,2,C1]=0.004
$AA_ENC_COMP[0,3,C1]=0.001
$AA_ENC_COMP_STEP[0,C1]=120
$AA_ENC_COMP_MIN[0,C1]=0
$AA_ENC_COMP_MAX[0,C1]=360
$AA_ENC_COMP_IS_MODULO[0,C1]=1
M17
"""
    t = load_controller_table(text, "siemens")
    assert t.modulo
    assert t.correction(40.0, 1) == pytest.approx(-(0.001 + 0.001 * 40 / 120))
    assert t.correction(400.0, 1) == pytest.approx(t.correction(40.0, 1))
    assert t.correction(-80.0, 1) == pytest.approx(-(0.004 - 0.003 * 40 / 120))  # -80 = 280 deg: 240 -> 360
    assert t.correction(720.0, 1) == pytest.approx(-0.001)


def test_siemens_two_cec_tables_make_it_direction_dependent() -> None:
    text = LEC.replace("M17\n", "") + """$AN_CEC[0,0]=0
$AN_CEC[0,1]=0.004
$AN_CEC_INPUT_AXIS[0]=(X1)
$AN_CEC_OUTPUT_AXIS[0]=(X1)
$AN_CEC_STEP[0]=2.0
$AN_CEC_MIN[0]=-1.0
$AN_CEC_MAX[0]=1.0
$AN_CEC_DIRECTION[0]=1
$AN_CEC[1,0]=0.002
$AN_CEC[1,1]=0.002
$AN_CEC_INPUT_AXIS[1]=(X1)
$AN_CEC_OUTPUT_AXIS[1]=(X1)
$AN_CEC_STEP[1]=2.0
$AN_CEC_MIN[1]=-1.0
$AN_CEC_MAX[1]=1.0
$AN_CEC_DIRECTION[1]=-1
$AN_CEC[2,0]=0.5
$AN_CEC[2,1]=0.5
$AN_CEC_INPUT_AXIS[2]=(Y1)
$AN_CEC_OUTPUT_AXIS[2]=(X1)
$AN_CEC_STEP[2]=2.0
$AN_CEC_MIN[2]=-1.0
$AN_CEC_MAX[2]=1.0
M17
"""
    t = load_controller_table(text, "siemens")
    lec_0 = 0.01
    assert t.correction(0.0, 1) == pytest.approx(-(lec_0 + 0.002))  # + table: half way 0 -> 0.004
    assert t.correction(0.0, -1) == pytest.approx(-(lec_0 + 0.002))
    assert t.correction(1.0, 1) == pytest.approx(-(0.012 + 0.004))
    assert t.correction(1.0, -1) == pytest.approx(-(0.012 + 0.002))
    assert t.correction(1.0, 0) == pytest.approx(-0.012)  # not moved yet: neither direction's table
    # table 2 (sag of X1 over Y1) is another axis's error and is not applied here


def test_siemens_bad_files_are_refused_naming_the_line() -> None:
    with pytest.raises(ValueError, match="line 2: not a"):
        load_controller_table("%_N_AX_EEC_INI\nG01 X10\n", "siemens")
    with pytest.raises(ValueError, match=r"\(MAX - MIN\) / STEP"):
        load_controller_table(LEC.replace("MAX[0,X1]=1.0", "MAX[0,X1]=3.0"), "siemens")


def test_siemens_backlash_md32450_after_a_reversal_from_the_referencing_direction() -> None:
    t = load_controller_table(LEC, "siemens", backlash=0.004)  # 4 um lost motion, referenced moving +
    c = Compensator(t, start=-1.0)
    assert c.move_to(0.0) == pytest.approx(-0.010)  # LEC only
    assert c.move_to(-0.5) == pytest.approx(-0.0065 - 0.004)  # reversed: 4 um more in the new direction
    assert c.move_to(-0.5) == pytest.approx(-0.0065 - 0.004)  # at rest: kept
    assert c.move_to(0.0) == pytest.approx(-0.010)
    assert t.correction(0.0, -1, referenced=False) == 0.0


def test_backlash_parameter_with_the_table() -> None:
    # Fanuc: given in mm, entered as 1851 in whole detection units (2.6 um / 2 um -> 1 unit ... 1.3 -> 1)
    t = load_controller_table(fanuc_listing([0] * 17, extra=("PARAM 1851=9",)), "fanuc", reference_position=0.0,
                              detection_unit_um=2.0, backlash=0.0026)
    assert t.correction(0.0, -1) == pytest.approx(-2e-3)
    with pytest.raises(ValueError, match="LinuxCNC ignores BACKLASH"):
        load_controller_table(TYPE1, "linuxcnc", comp_file_type=1, backlash=0.003)
    with pytest.raises(ValueError, match=">= 0"):
        load_controller_table(LEC, "siemens", backlash=-0.003)


def test_format_detection() -> None:
    assert detect_format(LEC) == "siemens"
    assert detect_format(fanuc_listing(MANUAL_INCREMENTS)) == "fanuc"
    assert detect_format(TYPE1) == "linuxcnc"
    assert detect_format("hello\n") is None


def test_fanuc_reference_return_minus_puts_3627_on_the_plus_table() -> None:
    # 3627 is the absolute correction at the reference approached against the reference return (standards.md
    # §4.4): with a reference return in − (1006#5 ZMI = 1) that is the + table; the − table is 0 there
    extra = ("PARAM 3626=60", "PARAM 3627=5")
    text = fanuc_listing(MANUAL_INCREMENTS, extra=extra).replace("PARAM 3605#0=0", "PARAM 3605#0=1")
    text += "".join(f"PITCH {60 + i}=1\n" for i in range(len(MANUAL_INCREMENTS)))
    t = load_controller_table(text, "fanuc", reference_position=0.0, reference_direction=-1)
    assert t.correction(0.0, 1) * 1000 == pytest.approx(5.0)
    assert t.correction(100.0, 1) * 1000 == pytest.approx(5.0 + 3.0)  # the manual's profile is 3 at 100 mm
    assert t.correction(-100.0, 1) * 1000 == pytest.approx(5.0 + 1.0)  # and 1 at −100 mm
    assert t.correction(0.0, -1) * 1000 == pytest.approx(0.0)
    assert t.correction(100.0, -1) * 1000 == pytest.approx(2.0)  # two increments of 1 from the reference
    assert t.correction(-100.0, -1) * 1000 == pytest.approx(-2.0)


def _reference_minus_listing() -> str:
    return fanuc_text(fanuc_pitch_table(np.array([2.0, 4.0, -4.0, 9.0]), np.array([0.0, 8.0, 1.0, -6.0]),
                                        grid_mm=np.array([0.0, 10.0, 20.0, 30.0]), reference_position_mm=10.0,
                                        magnification=2, reference_number=5, reference_direction=-1))


def test_fanuc_bidirectional_reference_return_minus_round_trips_writer_to_controller() -> None:
    # grid 0 … 30 mm, reference 10 mm, one count = 1 um × 2.  Reference return in −: the − curve is the zero at
    # the reference, e_ref = e↓(10) = 8 um; the intended corrections c = round(−(e − e_ref)/2), halves away from 0:
    # c↑ = −(2 − 8, 4 − 8, −4 − 8, 9 − 8)/2 = 3, 2, 6, −0.5 → 3, 2, 6, −1
    # c↓ = −(0 − 8, 8 − 8, 1 − 8, −6 − 8)/2 = 4, 0, 3.5, 7 → 4, 0, 4, 7
    t = load_controller_table(_reference_minus_listing(), "fanuc", reference_direction=-1)  # 10 mm: the comment
    x = [0.0, 10.0, 20.0, 30.0]
    assert [round(t.correction(p, 1) * 1000, 9) for p in x] == [2 * c for c in (3, 2, 6, -1)]
    assert [round(t.correction(p, -1) * 1000, 9) for p in x] == [2 * c for c in (4, 0, 4, 7)]
    # at power-on (no motion yet) the control takes the reference-return direction: the − table
    assert t.correction(20.0, 0) * 1000 == pytest.approx(8.0)


def test_fanuc_bidirectional_reference_return_plus_round_trips_writer_to_controller() -> None:
    # e↑ = 1, 2, 4; e↓ = −2, 0, 3 at 0, 10, 20 mm, reference 0 mm returned to in +: e_ref = e↑(0) = 1,
    # c↑ = 0, −1, −3; c↓ = 3, 1, −2 (3627 = 3 on the − table)
    text = fanuc_text(fanuc_pitch_table(np.array([1.0, 2.0, 4.0]), np.array([-2.0, 0.0, 3.0]),
                                        grid_mm=np.array([0.0, 10.0, 20.0]), reference_position_mm=0.0))
    t = load_controller_table(text, "fanuc")
    assert [round(t.correction(p, 1) * 1000, 9) for p in (0.0, 10.0, 20.0)] == [0, -1, -3]
    assert [round(t.correction(p, -1) * 1000, 9) for p in (0.0, 10.0, 20.0)] == [3, 1, -2]


def test_fanuc_listing_for_another_reference_return_is_refused() -> None:
    # the listing says which reference return its 3627 is for; a controller returning the other way would put
    # 3627 on the other table (every correction off by it): refused, naming the set-up's reference_direction
    with pytest.raises(ValueError, match=r"reference return in − \(1006#5 ZMI = 1\).*reference_direction = -1"):
        load_controller_table(_reference_minus_listing(), "fanuc")
