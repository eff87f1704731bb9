"""ISO 230-2 / VDI 3441: the cases a mutation run found unchecked (issue 28).  Expected values
come from the formulas of standards.md 1.3/1.5 written out here with the statistics module."""

from __future__ import annotations

import json
import math
import statistics as st

import numpy as np
import pytest

from processing.iso230_2 import AXIS_QUANTITIES, PER_TARGET_COLUMNS, VDI3441_QUANTITIES, iso230_2_from_arrays

TARGETS = np.array([0.0, 120.5, 251.0, 370.25, 500.0])
UP = np.array([[1.0, 1.4, 0.8], [2.2, 2.9, 2.5], [-0.4, 0.3, 0.1], [1.9, 1.1, 1.6], [0.5, 0.9, 0.2]])
DOWN = np.array([[-0.7, -0.2, -0.5], [0.9, 1.6, 1.2], [-1.8, -1.1, -1.5], [0.2, 0.6, -0.3], [-1.0, -0.4, -0.9]])


def reference(up: list[list[float]], down: list[list[float]], k: float = 2.0) -> dict[str, float]:
    """ISO 230-2 axis values and VDI 3441 from per-target lists of deviations (no NaN)."""
    mu, md = [st.mean(r) for r in up], [st.mean(r) for r in down]
    su, sd = [st.stdev(r) for r in up], [st.stdev(r) for r in down]
    m = len(mu)
    b = [mu[i] - md[i] for i in range(m)]
    xbar = [(mu[i] + md[i]) / 2 for i in range(m)]
    ri = [max(k * su[i] + k * sd[i] + abs(b[i]), 2 * k * su[i], 2 * k * sd[i]) for i in range(m)]
    ps = [6 * (su[i] + sd[i]) / 2 for i in range(m)]
    u = [abs(v) for v in b]
    return {
        "B": max(u), "B_mean": sum(b) / m, "R_up": max(2 * k * s for s in su), "R_down": max(2 * k * s for s in sd),
        "R": max(ri), "E_up": max(mu) - min(mu), "E_down": max(md) - min(md), "E": max(mu + md) - min(mu + md),
        "M": max(xbar) - min(xbar),
        "A_up": max(mu[i] + k * su[i] for i in range(m)) - min(mu[i] - k * su[i] for i in range(m)),
        "A_down": max(md[i] + k * sd[i] for i in range(m)) - min(md[i] - k * sd[i] for i in range(m)),
        "A": (max([mu[i] + k * su[i] for i in range(m)] + [md[i] + k * sd[i] for i in range(m)])
              - min([mu[i] - k * su[i] for i in range(m)] + [md[i] - k * sd[i] for i in range(m)])),
        "P": max(xbar[i] + (u[i] + ps[i]) / 2 for i in range(m)) - min(xbar[i] - (u[i] + ps[i]) / 2 for i in range(m)),
        "Pa": max(xbar) - min(xbar), "Ps_max": max(ps), "Ps_mean": sum(ps) / m, "U_max": max(u), "U_mean": sum(u) / m,
    }


@pytest.mark.parametrize("k", [2.0, 3.0])
def test_every_value_against_the_written_formulas(k: float) -> None:
    res = iso230_2_from_arrays(TARGETS, UP, DOWN, k=k)
    ref = reference(UP.tolist(), DOWN.tolist(), k)
    for q in AXIS_QUANTITIES:
        assert res.axis[q] == pytest.approx(ref[q], abs=1e-12), q
    for q in VDI3441_QUANTITIES:
        assert res.vdi3441[q] == pytest.approx(ref[q], abs=1e-12), q
    assert res.directions == "bidirectional" and (res.runs_up, res.runs_down) == (3, 3)


def test_a_missing_approach_is_left_out_of_mean_and_s() -> None:
    """One ↑ approach at target 2 is NaN: that target's mean and s come from the other two."""
    up = UP.copy()
    up[1, 1] = np.nan
    res = iso230_2_from_arrays(TARGETS, up, DOWN)
    row = res.per_target.iloc[1]
    assert row["n_up"] == 2
    assert row["mean_up"] == pytest.approx(st.mean([2.2, 2.5]), abs=1e-12)
    assert row["s_up"] == pytest.approx(st.stdev([2.2, 2.5]), abs=1e-12)
    ref = reference([[v for v in r if not math.isnan(v)] for r in up.tolist()], DOWN.tolist())
    for q in AXIS_QUANTITIES:
        assert res.axis[q] == pytest.approx(ref[q], abs=1e-12), q


@pytest.mark.parametrize("k", [0.0, -2.0, math.nan])
def test_a_coverage_factor_that_is_not_positive_is_refused(k: float) -> None:
    with pytest.raises(ValueError, match="coverage factor k must be positive"):
        iso230_2_from_arrays(TARGETS, UP, DOWN, k=k)


@pytest.mark.parametrize(("which", "arrow"), [("up", "↑"), ("down", "↓")])
def test_a_unidirectional_test_is_reported_as_its_direction(which: str, arrow: str) -> None:
    empty = np.full((len(TARGETS), 0), np.nan)
    up, down = (UP, empty) if which == "up" else (empty, DOWN)
    res = iso230_2_from_arrays(TARGETS, up, down)
    assert res.directions == which
    assert any(f"({arrow} only)" in n for n in res.notes)
    assert (res.runs_up, res.runs_down) == ((3, 0) if which == "up" else (0, 3))
    for q in ("B", "B_mean", "E", "M", "A", "R"):
        assert math.isnan(res.axis[q]), q
    data = UP if which == "up" else DOWN
    means = data.mean(axis=1)
    assert res.axis[f"E_{which}"] == pytest.approx(means.max() - means.min(), abs=1e-12)
    other = "down" if which == "up" else "up"
    assert math.isnan(res.axis[f"E_{other}"]) and math.isnan(res.axis[f"A_{other}"])
    assert all(math.isnan(res.vdi3441[q]) for q in VDI3441_QUANTITIES)


def test_accuracy_is_not_reported_when_a_target_has_one_approach() -> None:
    """A needs s at every target: with one ↑ approach at one target, A↑ and A are NaN, A↓ is not;
    R↑ is the max over the targets that have an s (standards.md 1.3)."""
    up = UP.copy()
    up[3, 1:] = np.nan
    res = iso230_2_from_arrays(TARGETS, up, DOWN)
    assert math.isnan(res.axis["A_up"]) and math.isnan(res.axis["A"])
    ref = reference(UP.tolist(), DOWN.tolist())
    assert res.axis["A_down"] == pytest.approx(ref["A_down"], abs=1e-12)
    s_up = [st.stdev(r) for i, r in enumerate(UP.tolist()) if i != 3]
    assert res.axis["R_up"] == pytest.approx(4 * max(s_up), abs=1e-12)
    assert any("fewer than 2 approaches" in n for n in res.notes)
    assert math.isnan(res.per_target.iloc[3]["s_up"]) and res.per_target.iloc[3]["n_up"] == 1
    # VDI 3441 P, Ps_mean need the scatter at every target; U_mean and U_max do not
    assert math.isnan(res.vdi3441["P"]) and math.isnan(res.vdi3441["Ps_mean"])
    assert res.vdi3441["U_mean"] == pytest.approx(
        st.mean(abs(st.mean([v for v in u if not math.isnan(v)]) - st.mean(d))
                for u, d in zip(up.tolist(), DOWN.tolist(), strict=True)), abs=1e-12)


def test_vdi_p_not_from_partial_data_when_a_target_lacks_a_direction() -> None:
    down = DOWN.copy()
    down[2, :] = np.nan  # target 3 never approached ↓
    res = iso230_2_from_arrays(TARGETS, UP, down)
    assert res.directions == "bidirectional"
    for q in ("P", "Ps_mean", "U_mean"):
        assert math.isnan(res.vdi3441[q]), q
    assert math.isnan(res.axis["A"]) and math.isnan(res.axis["A_down"])
    assert not math.isnan(res.axis["A_up"])


def test_to_dict_keys_and_json() -> None:
    up = UP.copy()
    up[0, 0] = np.nan
    res = iso230_2_from_arrays(TARGETS, up, DOWN, axis_type="rotary", k=2.0)
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))  # NaN became null
    assert set(d) == {"axis_type", "unit", "target_unit", "edition", "k", "directions", "runs_up", "runs_down",
                      "repeatability_evaluated", "notes", "iso230_2", "vdi3441", "targets"}
    assert (d["axis_type"], d["unit"], d["target_unit"], d["k"]) == ("rotary", "arcsec", "deg", 2.0)
    assert d["edition"] == "ISO 230-2:2014" and d["directions"] == "bidirectional"
    assert (d["runs_up"], d["runs_down"], d["repeatability_evaluated"]) == (3, 3, True)
    assert list(d["iso230_2"]) == list(AXIS_QUANTITIES) and list(d["vdi3441"]) == list(VDI3441_QUANTITIES)
    assert len(d["targets"]) == len(TARGETS) and all(list(t) == list(PER_TARGET_COLUMNS) for t in d["targets"])
    first = d["targets"][0]
    assert first["target_index"] == 1 and isinstance(first["target_index"], int)
    assert first["n_up"] == 2 and first["mean_up"] == pytest.approx(st.mean([1.4, 0.8]))
    assert d["iso230_2"]["A_up"] == pytest.approx(res.axis["A_up"])
    single = iso230_2_from_arrays(TARGETS, UP[:, :1], DOWN[:, :1]).to_dict()
    assert single["repeatability_evaluated"] is False and single["iso230_2"]["R"] is None
    assert single["targets"][0]["s_up"] is None
