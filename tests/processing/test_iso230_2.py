"""ISO 230-2 / VDI 3441 statistics.

Expected values come from (a) a data set small enough to work out by hand and
(b) the formulas of standards.md §1.3/§1.5 written out again below with plain
Python loops; the relations and invariances listed in §1.3 are property tests.
"""

from __future__ import annotations

import math
import random
import statistics

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from processing.iso230_2 import AXIS_QUANTITIES, QUANTITY_NAMES, evaluate_iso230_2, iso230_2_from_arrays


def long_table(targets, up, down) -> pd.DataFrame:
    rows = []
    for i, t in enumerate(targets):
        for d, data in ((1, up), (-1, down)):
            for j, x in enumerate(data[i]):
                rows.append({"target_index": i + 1, "target": t, "direction": d, "run": j + 1, "deviation": x})
    return pd.DataFrame(rows)


def test_hand_worked_example() -> None:
    # Target 1: up 1, 2, 3 (mean 2, s 1); down 0, 0, 0 (mean 0, s 0); B_1 = 2.
    # Target 2: up 4, 4, 4 (mean 4, s 0); down 5, 6, 7 (mean 6, s 1); B_2 = -2.
    res = evaluate_iso230_2(long_table([0.0, 100.0], [[1, 2, 3], [4, 4, 4]], [[0, 0, 0], [5, 6, 7]]))
    a = res.axis
    # R_1 = max(2*1 + 2*0 + 2, 4, 0) = 4;  R_2 = max(0 + 2 + 2, 0, 4) = 4
    expected = {"B": 2, "B_mean": 0, "R_up": 4, "R_down": 4, "R": 4, "E_up": 2, "E_down": 6, "E": 6,
                "M": 4,  # mean_bi 1, 5
                "A_up": 4,  # max(2+2, 4+0) - min(2-2, 4-0)
                "A_down": 8,  # max(0, 6+2) - min(0, 6-2)
                "A": 8}
    for q, v in expected.items():
        assert a[q] == pytest.approx(v, abs=1e-12), q
    pt = res.per_target
    assert pt["mean_up"].tolist() == [2, 4] and pt["mean_down"].tolist() == [0, 6]
    assert pt["reversal"].tolist() == [2, -2]
    assert pt["target_index"].tolist() == [1, 2] and pt["target"].tolist() == [0.0, 100.0]
    # VDI 3441: U = 2, 2; Ps = 6 * (1 + 0)/2 = 3 at both; P = max(1 + 2.5, 5 + 2.5) - min(1 - 2.5, 5 - 2.5) = 9
    v = res.vdi3441
    assert v == pytest.approx({"P": 9, "Pa": 4, "Ps_max": 3, "Ps_mean": 3, "U_max": 2, "U_mean": 2})
    assert res.unit == "um" and res.axis_type == "linear" and res.directions == "bidirectional"


def reference(targets, up, down, k):
    """standards.md §1.3 and §1.5 written out with loops (independent of the implementation)."""
    m = len(targets)
    mu, md, su, sd = [], [], [], []
    for i in range(m):
        mu.append(sum(up[i]) / len(up[i]))
        md.append(sum(down[i]) / len(down[i]))
        su.append(math.sqrt(sum((x - mu[i]) ** 2 for x in up[i]) / (len(up[i]) - 1)))
        sd.append(math.sqrt(sum((x - md[i]) ** 2 for x in down[i]) / (len(down[i]) - 1)))
    xb = [(mu[i] + md[i]) / 2 for i in range(m)]
    Bi = [mu[i] - md[i] for i in range(m)]
    Riu = [2 * k * s for s in su]
    Rid = [2 * k * s for s in sd]
    Ri = [max(k * su[i] + k * sd[i] + abs(Bi[i]), Riu[i], Rid[i]) for i in range(m)]
    out = {
        "B": max(abs(b) for b in Bi), "B_mean": sum(Bi) / m,
        "R_up": max(Riu), "R_down": max(Rid), "R": max(Ri),
        "E_up": max(mu) - min(mu), "E_down": max(md) - min(md), "E": max(mu + md) - min(mu + md),
        "M": max(xb) - min(xb),
        "A_up": max(mu[i] + k * su[i] for i in range(m)) - min(mu[i] - k * su[i] for i in range(m)),
        "A_down": max(md[i] + k * sd[i] for i in range(m)) - min(md[i] - k * sd[i] for i in range(m)),
        "A": max(max(mu[i] + k * su[i], md[i] + k * sd[i]) for i in range(m))
        - min(min(mu[i] - k * su[i], md[i] - k * sd[i]) for i in range(m)),
    }
    U = [abs(b) for b in Bi]
    Ps = [6 * (su[i] + sd[i]) / 2 for i in range(m)]
    vdi = {"P": max(xb[i] + (U[i] + Ps[i]) / 2 for i in range(m)) - min(xb[i] - (U[i] + Ps[i]) / 2 for i in range(m)),
           "Pa": max(xb) - min(xb), "Ps_max": max(Ps), "Ps_mean": sum(Ps) / m, "U_max": max(U), "U_mean": sum(U) / m}
    return out, vdi, {"mean_up": mu, "mean_down": md, "s_up": su, "s_down": sd, "reversal": Bi, "R_i": Ri}


@pytest.mark.parametrize(("seed", "k"), [(1, 2.0), (2, 2.0), (3, 3.0), (4, 1.0)])
def test_against_loop_reference(seed: int, k: float) -> None:
    rnd = random.Random(seed)
    m, n = 7, 5
    targets = sorted(rnd.uniform(0, 1000) for _ in range(m))
    up = [[rnd.gauss(3 * i, 1.5) for _ in range(n)] for i in range(m)]
    down = [[rnd.gauss(3 * i + 2, 1.0) for _ in range(n)] for i in range(m)]
    res = evaluate_iso230_2(long_table(targets, up, down), k=k)
    axis, vdi, per = reference(targets, up, down, k)
    for q in AXIS_QUANTITIES:
        assert res.axis[q] == pytest.approx(axis[q], rel=1e-12, abs=1e-12), q
    for q, v in vdi.items():
        assert res.vdi3441[q] == pytest.approx(v, rel=1e-12, abs=1e-12), q
    for c, v in per.items():
        assert res.per_target[c].to_numpy() == pytest.approx(v, rel=1e-12, abs=1e-12), c
    assert res.k == k


def test_targets_reported_in_ascending_order_whatever_the_row_order() -> None:
    df = long_table([10.0, 20.0, 30.0], [[1, 2], [3, 4], [5, 6]], [[0, 1], [2, 3], [4, 6]])
    shuffled = df.sample(frac=1.0, random_state=3).reset_index(drop=True)
    a, b = evaluate_iso230_2(df), evaluate_iso230_2(shuffled)
    pd.testing.assert_frame_equal(a.per_target, b.per_target)


def test_unidirectional_test_has_no_bidirectional_quantities() -> None:
    df = long_table([0.0, 50.0, 100.0], [[1, 2, 3], [2, 2, 5], [0, 1, 2]], [[], [], []])
    res = evaluate_iso230_2(df)
    assert res.directions == "up"
    assert res.per_target["mean_down"].isna().all()
    assert res.per_target["mean_up"].tolist() == [2, 3, 1]
    assert res.axis["E_up"] == pytest.approx(2)
    s = [1.0, statistics.stdev([2, 2, 5]), 1.0]
    assert res.axis["R_up"] == pytest.approx(4 * max(s))
    for q in ("B", "B_mean", "R", "E", "M", "A", "R_down", "E_down", "A_down"):
        assert math.isnan(res.axis[q]), q
    assert any("unidirectional" in n for n in res.notes)
    d = res.to_dict()
    assert d["iso230_2"]["B"] is None and d["targets"][0]["mean_down"] is None


def test_long_axis_single_run_gives_no_repeatability() -> None:
    # > 2000 mm: one bidirectional run, targets ~250 mm apart (ISO 230-2 long-axis rule).
    targets = [0.0, 260.0, 495.0, 760.0, 1010.0, 1240.0, 1500.0, 1770.0, 2010.0, 2250.0, 2500.0]
    up = [[float(i)] for i in range(len(targets))]
    down = [[float(i) + 1.5] for i in range(len(targets))]
    res = evaluate_iso230_2(long_table(targets, up, down))
    assert res.axis["E"] == pytest.approx(11.5) and res.axis["M"] == pytest.approx(10)
    assert res.axis["B"] == pytest.approx(1.5) and res.axis["B_mean"] == pytest.approx(-1.5)
    for q in ("R_up", "R_down", "R", "A_up", "A_down", "A"):
        assert math.isnan(res.axis[q]), q
    assert math.isnan(res.vdi3441["P"]) and math.isnan(res.vdi3441["Ps_max"])
    assert not res.repeatability_evaluated
    assert any("long-axis" in n and "no repeatability" in n for n in res.notes)


def test_rotary_axis_unit() -> None:
    res = iso230_2_from_arrays(np.array([0.0, 90.0]), np.array([[1.0, 3.0], [2.0, 2.0]]),
                               np.array([[0.0, 0.0], [1.0, 1.0]]), axis_type="rotary")
    assert res.unit == "arcsec" and res.target_unit == "deg" and res.axis["E"] == pytest.approx(2.0)


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="direction"):
        evaluate_iso230_2(pd.DataFrame({"target_index": [1], "target": [0.0], "direction": [2], "run": [1],
                                        "deviation": [0.0]}))
    df = long_table([0.0], [[1, 2]], [[1, 2]])
    with pytest.raises(ValueError, match=r"two points for target 1, direction \+1, run 1"):
        evaluate_iso230_2(pd.concat([df, df.iloc[:1]]))
    with pytest.raises(ValueError, match="edition"):
        evaluate_iso230_2(df, edition="ISO 230-2:1988")


def test_gbt_names_cover_every_axis_quantity() -> None:
    for q in AXIS_QUANTITIES:
        en, zh = QUANTITY_NAMES[q]
        assert en and zh and zh != en


# ---- relations and invariances of standards.md §1.3 ----

values = st.floats(min_value=-50, max_value=50, allow_nan=False, allow_infinity=False)


@st.composite
def data_sets(draw):
    m = draw(st.integers(2, 6))
    n = draw(st.integers(2, 5))
    up = np.array(draw(st.lists(values, min_size=m * n, max_size=m * n))).reshape(m, n)
    down = np.array(draw(st.lists(values, min_size=m * n, max_size=m * n))).reshape(m, n)
    return np.arange(m) * 100.0, up, down


def close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-9)


@settings(max_examples=60, deadline=None)
@given(data_sets(), st.floats(min_value=-1000, max_value=1000))
def test_relations_and_invariances(data, c: float) -> None:
    t, up, down = data
    r = iso230_2_from_arrays(t, up, down)
    a = r.axis
    eps = 1e-9
    assert a["M"] <= a["E"] + eps
    assert a["E_up"] <= a["E"] + eps and a["E_down"] <= a["E"] + eps
    assert a["A"] >= a["E"] - eps and a["A"] >= a["A_up"] - eps and a["A"] >= a["A_down"] - eps
    assert a["R"] >= a["R_up"] - eps and a["R"] >= a["R_down"] - eps
    assert np.all(r.per_target["R_i"] >= np.abs(r.per_target["reversal"]) - eps)
    assert a["B"] >= abs(a["B_mean"]) - eps

    # a constant added to every deviation: ranges unchanged, means shifted
    shifted = iso230_2_from_arrays(t, up + c, down + c)
    for q in ("B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M", "A_up", "A_down", "A"):
        assert math.isclose(shifted.axis[q], a[q], rel_tol=1e-9, abs_tol=1e-7), q
    np.testing.assert_allclose(shifted.per_target["mean_up"], r.per_target["mean_up"] + c, atol=1e-7)
    np.testing.assert_allclose(shifted.per_target["mean_bi"], r.per_target["mean_bi"] + c, atol=1e-7)

    # up/down labels swapped: B_i changes sign, B, R, E, M, A do not
    swapped = iso230_2_from_arrays(t, down, up)
    np.testing.assert_allclose(swapped.per_target["reversal"], -r.per_target["reversal"], atol=1e-12)
    for q in ("B", "R", "E", "M", "A"):
        assert close(swapped.axis[q], a[q]), q
    assert close(swapped.axis["B_mean"], -a["B_mean"])
    assert close(swapped.axis["R_up"], a["R_down"]) and close(swapped.axis["A_up"], a["A_down"])

    # the order of the runs does not matter
    rng = np.random.default_rng(0)
    perm = iso230_2_from_arrays(t, up[:, rng.permutation(up.shape[1])], down[:, rng.permutation(down.shape[1])])
    for q in AXIS_QUANTITIES:
        assert close(perm.axis[q], a[q]), q
