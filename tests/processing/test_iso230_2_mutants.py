"""ISO 230-2: notes, refusals, input forms and a hand-made data set (issue 28, mutation survivors).

Expected values are the formulas of standards.md 1.3 written out with plain loops, and the exact
wording of the notes and refusals the user sees."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from processing.iso230_2 import (
    PER_TARGET_COLUMNS,
    check_target_count,
    deviation_arrays,
    evaluate_iso230_2,
    iso230_2_from_arrays,
    required_targets,
)

T5 = [0.0, 100.0, 200.0, 300.0, 400.0]  # 5 targets over 400 mm: meets the target rule, no note
UP2 = [[1.0, 2.0], [0.5, 1.5], [-1.0, 0.0], [2.0, 2.5], [0.0, 1.0]]
DN2 = [[-1.0, 0.0], [0.0, 0.5], [-2.0, -1.0], [1.0, 1.5], [-0.5, 0.5]]
NAN5x2 = [[math.nan, math.nan]] * 5
UNI = ("unidirectional test ({} only): reversal (B, B_mean), E, M and A are bidirectional quantities "
       "and not evaluated")
SINGLE = "single run ({}): no repeatability figures (s, R, A) from one run; only E, M, B, B_mean are evaluated"
FEWER = "fewer than 2 approaches per direction"
SOME = "some targets have fewer than 2 approaches: their s and R are not evaluated, A is not evaluated"
DIFFERS = "the number of approaches differs between targets (missing points)"

# 3 targets x 5 runs x 2 directions (µm).  Target 1: B < 0 and R_i from 2s↑+2s↓+|B|; target 2:
# large ↑ scatter, R_i = 4 s↑; target 3 holds the max of the upper band, target 1 the min.
HT = [0.0, 250.0, 500.0]
HU = [[1.0, 2.0, 1.5, 1.0, 2.5], [3.0, 7.0, 4.0, 9.0, 5.0], [6.0, 6.5, 7.0, 6.0, 6.5]]
HD = [[4.0, 4.5, 5.0, 4.0, 4.5], [5.0, 5.2, 5.1, 5.0, 5.2], [2.0, 3.0, 2.5, 2.0, 3.5]]


def _mean(xs: list[float]) -> float:
    return sum(xs) / len(xs)


def _s(xs: list[float]) -> float:
    mu = _mean(xs)
    return math.sqrt(sum((x - mu) ** 2 for x in xs) / (len(xs) - 1))


def test_hand_made_three_targets_five_runs_all_statistics() -> None:
    k = 2.0
    r = iso230_2_from_arrays(HT, HU, HD)
    mu = [_mean(v) for v in HU]
    md = [_mean(v) for v in HD]
    su = [_s(v) for v in HU]
    sd = [_s(v) for v in HD]
    b = [mu[i] - md[i] for i in range(3)]
    ri = [max(k * su[i] + k * sd[i] + abs(b[i]), 2 * k * su[i], 2 * k * sd[i]) for i in range(3)]
    assert b[0] < 0 and ri[0] == k * su[0] + k * sd[0] + abs(b[0]) and ri[1] == 2 * k * su[1]  # the data's design
    pt = r.per_target
    for col, want in (("mean_up", mu), ("mean_down", md), ("reversal", b), ("s_up", su), ("s_down", sd),
                      ("R_i", ri), ("R_i_up", [2 * k * v for v in su]), ("R_i_down", [2 * k * v for v in sd]),
                      ("mean_bi", [(mu[i] + md[i]) / 2 for i in range(3)])):
        assert pt[col].tolist() == pytest.approx(want), col
    hi = [max(mu[i] + k * su[i], md[i] + k * sd[i]) for i in range(3)]
    lo = [min(mu[i] - k * su[i], md[i] - k * sd[i]) for i in range(3)]
    xbar = [(mu[i] + md[i]) / 2 for i in range(3)]
    want = {"B": max(abs(v) for v in b), "B_mean": _mean(b), "R": max(ri), "R_up": 2 * k * max(su),
            "R_down": 2 * k * max(sd), "E_up": max(mu) - min(mu), "E_down": max(md) - min(md),
            "E": max(mu + md) - min(mu + md), "M": max(xbar) - min(xbar), "A": max(hi) - min(lo),
            "A_up": max(mu[i] + k * su[i] for i in range(3)) - min(mu[i] - k * su[i] for i in range(3))}
    for q, v in want.items():
        assert r.axis[q] == pytest.approx(v), q
    assert r.notes[0].startswith("3 targets over 500 mm (at least 5 required)") and len(r.notes) == 1


def test_bidirectional_two_runs_everywhere_has_no_notes() -> None:
    r = iso230_2_from_arrays(T5, UP2, DN2)
    assert r.directions == "bidirectional" and r.notes == ()


@pytest.mark.parametrize(("up", "down", "arrow", "directions"), [(UP2, NAN5x2, "↑", "up"),
                                                                 (NAN5x2, DN2, "↓", "down")])
def test_unidirectional_note_and_no_bidirectional_values(up, down, arrow, directions) -> None:
    r = iso230_2_from_arrays(T5, up, down)
    assert r.directions == directions and r.notes == (UNI.format(arrow),)
    assert all(math.isnan(r.axis[q]) for q in ("A", "E", "M", "B", "B_mean"))
    assert math.isfinite(r.axis["A_up" if arrow == "↑" else "A_down"])


@pytest.mark.parametrize(("targets", "axis_type", "travel", "why"), [
    (T5, "linear", None, FEWER),
    ([1000.0, 1100.0, 1200.0, 1300.0, 1400.0], "linear", None, FEWER),  # max + min > 2000, span 400
    (T5, "linear", 2500.0, "travel 2500 mm > 2000 mm: ISO 230-2 long-axis test"),
    (T5, "linear", 2000.0, FEWER),
    (T5, "linear", 2000.5, "travel 2000.5 mm > 2000 mm: ISO 230-2 long-axis test"),
    (T5, "rotary", 2500.0, FEWER),
])
def test_single_run_note_names_the_reason(targets, axis_type, travel, why) -> None:
    r = iso230_2_from_arrays(targets, [[1.0], [2.0], [0.0], [1.5], [0.5]], [[0.0], [1.0], [-1.0], [1.0], [0.0]],
                             axis_type=axis_type, travel=travel)
    assert r.notes == (SINGLE.format(why),)
    assert math.isnan(r.axis["R"]) and math.isnan(r.axis["A"]) and math.isfinite(r.axis["E"])


def test_a_target_with_one_approach_is_named_in_the_notes() -> None:
    up = [[1.0, 2.0, 1.5], [0.5, math.nan, math.nan], [-1.0, 0.0, 0.5], [2.0, 2.5, 2.0], [0.0, 1.0, 0.5]]
    dn = [[-1.0, 0.0, -0.5], [0.0, 0.5, 0.0], [-2.0, -1.0, -1.5], [1.0, 1.5, 1.0], [-0.5, 0.5, 0.0]]
    r = iso230_2_from_arrays(T5, up, dn)
    assert r.notes == (SOME, DIFFERS)
    assert math.isnan(r.axis["A"]) and math.isnan(r.axis["A_up"]) and math.isfinite(r.axis["A_down"])


def test_two_approaches_at_some_targets_three_at_others() -> None:
    up = [[1.0, 2.0, 1.5], [0.5, 1.0, math.nan], [-1.0, 0.0, 0.5], [2.0, 2.5, 2.0], [0.0, 1.0, 0.5]]
    r = iso230_2_from_arrays(T5, up, [[-1.0, 0.0, -0.5]] * 5)
    assert r.notes == (DIFFERS,)


def test_target_rule_uses_the_axis_type() -> None:
    wide = [0.0, 500.0, 1000.0, 1500.0, 2000.0]
    lin = iso230_2_from_arrays(wide, UP2, DN2)
    assert len(lin.notes) == 1 and lin.notes[0].startswith("5 targets over 2000 mm (at least 10 required)")
    assert iso230_2_from_arrays(wide, UP2, DN2, axis_type="rotary").notes == ()  # 5 targets suffice on a rotary axis


def test_refusals_say_what_is_wrong() -> None:
    with pytest.raises(ValueError, match=r"^unknown axis_type 'spindle' \(use linear or rotary\)$"):
        iso230_2_from_arrays(T5, UP2, DN2, axis_type="spindle")
    with pytest.raises(ValueError, match=r"^unsupported edition 'ISO 230-2:1988'; choose one of ISO 230-2:1997, "
                                         r"ISO 230-2:2006, ISO 230-2:2014$"):
        iso230_2_from_arrays(T5, UP2, DN2, edition="ISO 230-2:1988")
    with pytest.raises(ValueError, match=r"^no target positions$"):
        iso230_2_from_arrays([], np.empty((0, 2)), np.empty((0, 2)))
    with pytest.raises(ValueError, match=r"^no deviations to evaluate$"):
        iso230_2_from_arrays(T5, NAN5x2, NAN5x2)


def test_integer_targets_and_none_approaches() -> None:
    """Integer targets are reported as floats; None marks a missing approach like NaN."""
    ref = iso230_2_from_arrays(T5, [[1.0, math.nan]] + UP2[1:], [[math.nan, 0.0]] + DN2[1:])
    r = iso230_2_from_arrays([0, 100, 200, 300, 400], [[1.0, None]] + UP2[1:], [[None, 0.0]] + DN2[1:])
    assert r.per_target["target"].dtype == np.float64
    d = r.to_dict()
    assert [type(row["target"]) for row in d["targets"]] == [float] * 5
    assert d == ref.to_dict()


def test_to_dict_keys_and_values() -> None:
    r = iso230_2_from_arrays(T5, UP2, DN2, axis_type="rotary", k=3.0, edition="ISO 230-2:2006")
    d = r.to_dict()
    assert list(d) == ["axis_type", "unit", "target_unit", "edition", "k", "directions", "runs_up", "runs_down",
                       "repeatability_evaluated", "notes", "iso230_2", "vdi3441", "targets"]
    assert (d["axis_type"], d["unit"], d["target_unit"], d["edition"], d["k"]) == (
        "rotary", "arcsec", "deg", "ISO 230-2:2006", 3.0)
    assert (d["directions"], d["runs_up"], d["runs_down"], d["repeatability_evaluated"], d["notes"]) == (
        "bidirectional", 2, 2, True, [])
    assert d["targets"][1]["mean_up"] == 1.0 and d["targets"][1]["s_down"] == pytest.approx(math.sqrt(0.125))
    assert d["targets"][1]["R_i_down"] == pytest.approx(2 * 3.0 * math.sqrt(0.125))
    assert d["targets"][1]["R_i_up"] == pytest.approx(2 * 3.0 * math.sqrt(0.5))
    assert list(d["targets"][0]) == list(PER_TARGET_COLUMNS)


def _long(rows: list[tuple]) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=["target_index", "target", "direction", "run", "deviation"])


ROWS = [(1, 0.0, 1, 1, 1.0), (1, 0.0, -1, 1, -1.0), (2, 100.5, 1, 1, 2.0), (2, 100.5, -1, 1, 0.5),
        (1, 0.0, 1, 2, 1.5), (1, 0.0, -1, 2, -0.5), (2, 100.5, 1, 2, 2.5), (2, 100.5, -1, 2, 1.0)]


def test_deviation_arrays_from_text_columns() -> None:
    """A table read as text (e.g. a CSV without dtypes) gives the same arrays as the numeric one."""
    index, targets, up, down = deviation_arrays(_long(ROWS).astype(str))
    assert index.dtype.kind == "i" and index.tolist() == [1, 2]
    assert targets.dtype == np.float64 and targets.tolist() == [0.0, 100.5]
    assert up.tolist() == [[1.0, 1.5], [2.0, 2.5]] and down.tolist() == [[-1.0, -0.5], [0.5, 1.0]]


def test_deviation_arrays_none_deviation_is_missing() -> None:
    df = _long(ROWS)
    df["deviation"] = pd.Series([1.0, None, 2.0, 0.5, 1.5, -0.5, 2.5, 1.0], dtype=object)
    _, _, up, down = deviation_arrays(df)
    assert math.isnan(down[0, 0]) and down[0, 1] == -0.5 and up[0].tolist() == [1.0, 1.5]


def test_deviation_arrays_ties_in_target_keep_index_order() -> None:
    rows = [(3, 50.0, 1, 1, 3.0), (1, 50.0, 1, 1, 1.0), (2, 0.0, 1, 1, 2.0)]
    index, targets, up, down = deviation_arrays(_long(rows))
    assert index.tolist() == [2, 1, 3] and targets.tolist() == [0.0, 50.0, 50.0] and up[:, 0].tolist() == [2, 1, 3]
    assert down.dtype == np.float64 and np.isnan(down).all()  # no ↓ point: NaN holes


@pytest.mark.parametrize(("rows", "message"), [
    ([(1, 0.0, 0, 1, 1.0)], r"^direction must be \+1 or -1$"),
    ([(1, 0.0, 1, 0, 1.0)], r"^run numbers count from 1$"),
    ([(1, 0.0, 1, 1, 1.0), (1, 5.0, -1, 1, 1.0)], r"^a target_index appears with two different target positions$"),
    (ROWS + [(2, 100.5, -1, 2, 9.0)], r"^two points for target 2, direction -1, run 2; remove one of them$"),
    ([], r"^no points$"),
])
def test_deviation_arrays_refusals(rows, message) -> None:
    with pytest.raises(ValueError, match=message):
        deviation_arrays(_long(rows))


def test_deviation_arrays_names_the_missing_columns() -> None:
    with pytest.raises(ValueError, match=r"^deviations lack column\(s\) run, deviation$"):
        deviation_arrays(_long(ROWS).drop(columns=["run", "deviation"]))


def test_evaluate_long_table_with_a_run_missing_in_one_direction() -> None:
    """Run 3 exists only ↑: the ↓ statistics use runs 1-2 and the result equals the array form."""
    rows = ROWS + [(1, 0.0, 1, 3, 0.5), (2, 100.5, 1, 3, 3.0)]
    r = evaluate_iso230_2(_long(rows), axis_type="rotary")
    ref = iso230_2_from_arrays([0.0, 100.5], [[1.0, 1.5, 0.5], [2.0, 2.5, 3.0]], [[-1.0, -0.5], [0.5, 1.0]],
                               axis_type="rotary")
    assert r.to_dict() == ref.to_dict() and (r.runs_up, r.runs_down) == (3, 2)


def test_check_target_count_accepts_text_targets() -> None:
    """Targets as read from a text file count like numbers (3 targets over 500 mm: 5 required)."""
    note = check_target_count(["0", "250", "500"])
    assert note is not None and note.startswith("3 targets over 500 mm (at least 5 required)")
    assert check_target_count(["0", "250", "500"], "rotary").startswith("3 targets (at least 5 required)")


def test_required_targets_default_is_linear() -> None:
    """5 per metre up to 2 m (1500 mm: 7.5 -> 8), about one every 250 mm beyond (3000 mm: 12 intervals, 13)."""
    assert (required_targets(1500.0), required_targets(3000.0)) == (8, 13)
    assert required_targets(1201.0) == 7  # 6.005 targets -> 7
    assert required_targets(3000.0, "rotary") == 5
