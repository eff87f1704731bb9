"""The Fanuc loading steps of ``guideway export`` (saved_runs/export/load.py) for a bidirectional listing:
3627 is for one reference-return direction, the control's own parameter 1006#5 ZMI (0: +, 1: −), which the
listing states in a comment and does not set (docs/compensation.md)."""

from __future__ import annotations

from pathlib import Path

from saved_runs.export.load import load_instructions

LISTING = ("PARAM 3605#0=1\nPARAM 3620=5\nPARAM 3621=5\nPARAM 3622=7\nPARAM 3623=2\nPARAM 3624=10.000\n"
           "PARAM 3626=8\n(REFERENCE RETURN IN - DIRECTION, 1006#5 ZMI = 1: 3627 IS THE + TABLE AT THE REFERENCE)\n"
           "PARAM 3627=2\nPITCH 5=-1\nPITCH 6=4\nPITCH 7=-7\nPITCH 8=-4\nPITCH 9=4\nPITCH 10=3\n")


def test_bidirectional_listing_says_to_check_1006_bit_5_and_the_set_up_direction() -> None:
    steps = load_instructions("fanuc", LISTING, Path("f.txt"), axis="X", error_unit="um")
    check = [s for s in steps if "1006#5" in s]
    assert len(check) == 1 and "1006#5 ZMI = 1" in check[0] and "reference return in −" in check[0]
    assert "do not change it" in check[0] and "--fanuc-reference-direction" in check[0]
    # before the parameters are entered, and the as-left run's set-up must say the same direction
    assert steps.index(check[0]) < next(i for i, s in enumerate(steps) if s.startswith("enter the parameters"))
    assert 'file = "f.txt" and reference_direction = -1' in steps[-1] and "verify" in steps[-1]


def test_reference_return_plus_and_one_table_listings() -> None:
    plus = LISTING.replace("IN - DIRECTION, 1006#5 ZMI = 1: 3627 IS THE +",
                           "IN + DIRECTION, 1006#5 ZMI = 0: 3627 IS THE -")
    steps = load_instructions("fanuc", plus, Path("f.txt"), axis="X", error_unit="um")
    assert any("1006#5 ZMI = 0" in s and "reference return in +" in s for s in steps)
    assert "reference_direction" not in steps[-1]  # + is the set-up's default
    one = "PARAM 3605#0=0\nPARAM 3620=5\nPARAM 3621=5\nPARAM 3622=7\nPARAM 3623=2\nPARAM 3624=10.000\nPITCH 5=1\n"
    assert not any("1006#5" in s for s in load_instructions("fanuc", one, Path("f.txt"), axis="X", error_unit="um"))
