"""saved_runs/export against the agreed positioning-evaluation interface, fed a test-side
object of that shape (``result.per_target`` with target / mean_up / mean_down, ``axis_type``,
``unit``); the files are read back by tests/controller_parsers.py."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from saved_runs.errors import UserError
from saved_runs.export.build import build_export, export_run
from saved_runs.export.options import ExportOptions
from tests.controller_parsers import read_fanuc, read_linuxcnc_comp, read_siemens_lec
from tui.cli import main

TARGET = np.array([0.0, 52.5, 98.0, 151.5, 199.0, 250.5, 302.0, 348.5, 400.0])
UP = np.array([0.0, 1.8, 3.1, 2.2, 0.4, -1.0, -0.6, 1.1, 2.9])
DOWN = UP - np.array([2.0, 2.2, 2.1, 1.7, 1.9, 2.4, 2.0, 1.8, 2.2])


@dataclass
class Result:
    per_target: pd.DataFrame
    axis_type: str = "linear"
    unit: str = "um"


def result(target: np.ndarray = TARGET, up: np.ndarray = UP, down: np.ndarray = DOWN, **kw: str) -> Result:
    df = pd.DataFrame({"target_index": np.arange(1, len(target) + 1), "target": target,
                       "mean_up": up, "mean_down": down})
    return Result(df, **kw)


def test_linuxcnc_export_corrects_the_measured_means() -> None:
    ex = build_export(result(), ExportOptions(fmt="linuxcnc", linuxcnc_type=0))
    c = read_linuxcnc_comp(ex.text, 0)
    np.testing.assert_allclose(UP + c.correction_um(TARGET, +1), 0.0, atol=2e-3)
    np.testing.assert_allclose(DOWN + c.correction_um(TARGET, -1), 0.0, atol=2e-3)
    assert list(ex.comparison["model"]) == ["none", "linear", "spline", "segments", "polynomial"]
    assert ex.comparison.iloc[0].max_abs == pytest.approx(np.max(np.abs(np.r_[UP, DOWN])))


def test_linuxcnc_with_a_step_resamples_onto_an_equidistant_grid() -> None:
    ex = build_export(result(), ExportOptions(fmt="linuxcnc", model="spline", step=25.0))
    c = read_linuxcnc_comp(ex.text, 1)
    np.testing.assert_allclose(c.nominal, np.arange(0.0, 401.0, 25.0))
    both = np.r_[UP + c.correction_um(TARGET, +1), DOWN + c.correction_um(TARGET, -1)]
    spline_row = ex.comparison.set_index("model").loc["spline"]
    assert np.max(np.abs(both)) == pytest.approx(spline_row.max_abs, abs=2e-3)


def test_siemens_export_is_the_mean_curve_and_reports_the_backlash() -> None:
    ex = build_export(result(), ExportOptions(fmt="siemens", step=50.0, axis="Y"))
    lec = read_siemens_lec(ex.text)
    assert lec.axis == "Y1" and lec.step == 50.0 and lec.minimum == 0.0 and lec.maximum == 400.0
    mean = (UP + DOWN) / 2
    grid = np.arange(0.0, 401.0, 50.0)
    np.testing.assert_allclose(lec.values_mm * 1000, np.interp(grid, TARGET, mean), atol=1e-3)
    assert ex.table.backlash == pytest.approx(np.mean(UP - DOWN))
    assert any("mean reversal" in n for n in ex.notes)
    with pytest.raises(UserError, match="not direction dependent"):
        build_export(result(), ExportOptions(fmt="siemens", mode="bidirectional"))


def test_siemens_default_grid_and_reference_zero() -> None:
    ex = build_export(result(), ExportOptions(fmt="siemens", reference_position=200.0))
    lec = read_siemens_lec(ex.text)
    assert lec.step == 50.0  # (400 − 0)/(9 − 1)
    assert lec.value_mm(np.array([200.0]))[0] == 0.0


def test_fanuc_export_bidirectional() -> None:
    ex = build_export(result(), ExportOptions(fmt="fanuc", step=50.0, fanuc_first_point=1, axis="X"))
    f = read_fanuc(ex.text)
    assert f.params["3605#0"] == 1 and f.params["3620"] == 0 and f.params["3621"] == 1
    assert f.params["3622"] == 8
    grid = np.arange(0.0, 401.0, 50.0)
    e_up, e_dn = np.interp(grid, TARGET, UP), np.interp(grid, TARGET, DOWN)
    np.testing.assert_allclose(e_up + f.correction_um(grid, 0.0, +1, 1.0), 0.0, atol=0.5)
    np.testing.assert_allclose(e_dn + f.correction_um(grid, 0.0, -1, 1.0), 0.0, atol=0.5)


def test_fanuc_backlash_mode_gives_the_lost_motion() -> None:
    # lost motion: the axis stops 1.2 um short when moving +, 1.2 um past when moving − ...
    ex = build_export(result(TARGET, UP - 1.2, UP + 1.2), ExportOptions(fmt="fanuc", mode="backlash", step=50.0))
    assert ex.table.backlash == pytest.approx(-2.4)  # B̄ = x̄↑ − x̄↓
    assert "1851 = 2 " in ex.notes[0]  # ... 2.4 um lost motion → 2 detection units
    assert read_fanuc(ex.text).params["3605#0"] == 0
    with pytest.raises(UserError, match="rotary"):
        build_export(result(axis_type="rotary", unit="arcsec"), ExportOptions(fmt="fanuc"))


def test_rotary_axis_units() -> None:
    target = np.arange(0.0, 361.0, 45.0)
    up = np.array([0.0, 3.6, 7.2, 3.6, 0.0, -3.6, -7.2, -3.6, 0.0])  # arcsec
    ex = build_export(result(target, up, up, axis_type="rotary", unit="arcsec"),
                      ExportOptions(fmt="siemens", siemens_modulo=True))
    lec = read_siemens_lec(ex.text)
    assert lec.modulo and lec.values_mm[2] == pytest.approx(0.002)  # 7.2 arcsec = 0.002 deg
    c = read_linuxcnc_comp(build_export(result(target, up, up, axis_type="rotary", unit="arcsec"),
                                        ExportOptions(fmt="linuxcnc")).text, 1)
    assert c.trim(np.array([90.0]), +1)[0] == pytest.approx(-0.002, abs=1e-9)
    with pytest.raises(UserError, match="um"):
        build_export(result(unit="arcsec"), ExportOptions(fmt="csv"))


def test_bad_inputs_are_user_errors() -> None:
    with pytest.raises(UserError, match="positioning"):
        build_export(object(), ExportOptions(fmt="csv"))
    with pytest.raises(UserError, match="mean_down"):
        build_export(Result(pd.DataFrame({"target": TARGET, "mean_up": UP})), ExportOptions(fmt="csv"))
    with pytest.raises(UserError, match="at least 2"):
        build_export(result(TARGET[:1], UP[:1], DOWN[:1]), ExportOptions(fmt="csv"))
    with pytest.raises(UserError, match="larger step"):
        build_export(result(), ExportOptions(fmt="siemens", step=1e-5))
    with pytest.raises(UserError, match="256"):
        build_export(result(), ExportOptions(fmt="linuxcnc", step=1.0))
    bad = pd.DataFrame({"target": TARGET, "direction": 0, "deviation": UP})
    with pytest.raises(UserError, match=r"\+1 or -1"):
        build_export(result(), ExportOptions(fmt="csv"), deviations=bad)


def test_polynomial_on_few_targets_uses_a_lower_degree_and_says_so() -> None:
    # 5 targets, default degree 6 → degree min(6, 5 − 2) = 3, a least-squares cubic per direction
    ex = build_export(result(TARGET[:5], UP[:5], DOWN[:5]), ExportOptions(fmt="csv", model="polynomial"))
    assert any("polynomial degree 3 (of 6 requested" in n for n in ex.notes)
    x = TARGET[:5] / 100.0
    a = np.vander(x, 4)
    for mean, tab in ((UP[:5], ex.table.error_up), (DOWN[:5], ex.table.error_down)):
        fit = a @ np.linalg.lstsq(a, mean, rcond=None)[0]
        np.testing.assert_allclose(tab, fit, atol=1e-9)
    assert "degree 3" in ex.comparison.set_index("model").loc["polynomial"].detail


STRAIGHTNESS_RUN = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"


def test_a_straightness_run_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(UserError, match="straightness run"):
        export_run(STRAIGHTNESS_RUN, ExportOptions(fmt="csv"))
    assert main(["export", str(STRAIGHTNESS_RUN), "--format", "csv"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "guideway: error:" in err and "positioning" in err
