"""``guideway export`` scores the table it wrote: the file is read back with the test-side
controller readers (tests/controller_parsers.py), applied at every measured point as the
controller applies it (linear between its points, end values held, the reported backlash as
±B̄/2), and the residual figures computed here from those residuals must be what the tool prints
(``--json``).  The grid never reaches outside the measured range.  The run is the ISO 230-2
target set of the simulated 1000 mm axis, where the old grid ended at 1243 mm."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from saved_runs.errors import UserError
from saved_runs.export.build import export_run
from saved_runs.export.options import ExportOptions
from tests.controller_parsers import read_fanuc, read_linuxcnc_comp, read_siemens_lec
from tests.test_export_end_to_end import write_run
from tui.cli import main

TARGETS = [4.404, 312.43, 572.084, 805.396, 995.31]  # irregular, as generated for a 0 … 1000 mm axis
UP = [0.5, 86.4, 156.2, 227.4, 276.6]  # grossly uncompensated axis, um
DOWN = [4.7, 88.9, 159.1, 230.3, 279.9]
SCATTER = [[0.3, -0.2, 0.1, 0.4, -0.3], [-0.1, 0.5, -0.4, 0.0, 0.2], [-0.2, -0.3, 0.3, -0.4, 0.1]]


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    write_run(tmp_path / "run", TARGETS, UP, DOWN, SCATTER)
    return tmp_path / "run"


def measured() -> pd.DataFrame:
    """Every point of the run: target, direction, run, deviation (um), as written by write_run."""
    rows = [(t, d, j, e[i] + off[i]) for j, off in enumerate(SCATTER, start=1)
            for d, e in ((1, UP), (-1, DOWN)) for i, t in enumerate(TARGETS)]
    return pd.DataFrame(rows, columns=["target", "direction", "run", "deviation"])


def figures(dev: pd.DataFrame, r: np.ndarray) -> dict[str, float]:
    """max|r|, range, RMS and ISO 230-2 E, M of residuals r at the points of dev (definitions)."""
    df = dev.assign(r=r)
    means = df.groupby(["target", "direction"])["r"].mean().unstack("direction")
    bi = (means[1] + means[-1]) / 2
    return {"max_um": float(np.max(np.abs(r))), "range_um": float(np.ptp(r)), "rms_um": float(np.sqrt(np.mean(r**2))),
            "E_um": float(np.nanmax(means.to_numpy()) - np.nanmin(means.to_numpy())),
            "M_um": float(bi.max() - bi.min())}


def export_json(run_dir: Path, out: Path, *args: str, capsys: pytest.CaptureFixture[str]) -> dict:
    assert main(["export", str(run_dir), "--out", str(out), "--json", *args]) == 0
    return json.loads(capsys.readouterr().out)


def mean_reversal() -> float:
    return float(np.mean(np.array(UP) - np.array(DOWN)))  # B̄: the scatter is zero-mean per target


def check_written(got: dict, dev: pd.DataFrame, correction: np.ndarray) -> None:
    r = dev["deviation"].to_numpy() + correction
    want = figures(dev, r)
    for k, v in want.items():
        assert got["table_as_written"][k] == pytest.approx(v, abs=1e-9), k


def test_fanuc_table_stays_inside_and_is_scored_as_written(run_dir: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    got = export_json(run_dir, tmp_path / "x.txt", "--format", "fanuc", capsys=capsys)
    f = read_fanuc((tmp_path / "x.txt").read_text(encoding="utf-8"))
    ref = TARGETS[0]  # default reference position: the first target
    at = f.point_positions_mm(ref)
    assert at[0] >= TARGETS[0] - 1e-9 and at[-1] <= TARGETS[-1] + 1e-9  # no 1243 mm point
    assert len(at) == len(TARGETS)  # one interval per target interval, step rounded down to 1 um
    assert f.params["3624"] == 247.726 and at[-1] == pytest.approx(995.308)
    dev = measured()
    corr = np.concatenate([f.correction_um_anywhere(g.target.to_numpy(), ref, d, 1.0)
                           for d, g in dev.groupby("direction", sort=False)])
    dev = pd.concat([g for _, g in dev.groupby("direction", sort=False)])
    check_written(got, dev, corr)
    assert got["table"]["step_mm"] == 247.726 and got["table"]["last_mm"] == pytest.approx(995.308)
    assert any("regridding costs accuracy" in line for line in got["costs"])
    assert any("0.002 mm before the last target" in n for n in got["notes"])


def test_fanuc_bidirectional_reference_return_minus_is_scored_as_written(run_dir: Path, tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    # 3627 belongs to the + table with a reference return in − (read by the test-side reader from the manual's rule)
    got = export_json(run_dir, tmp_path / "x.txt", "--format", "fanuc", "--fanuc-reference-direction", "-1",
                      capsys=capsys)
    f = read_fanuc((tmp_path / "x.txt").read_text(encoding="utf-8"))
    assert f.params["3605#0"] == 1
    ref = TARGETS[0]
    # the − curve is the zero at the reference: 3627 = round(−(e↑ − e↓)) there = round(−(0.5 − 4.7)) = 4
    assert f.params["3627"] == 4
    dev = measured()
    corr = np.concatenate([f.correction_um_anywhere(g.target.to_numpy(), ref, d, 1.0, reference_direction=-1)
                           for d, g in dev.groupby("direction", sort=False)])
    dev = pd.concat([g for _, g in dev.groupby("direction", sort=False)])
    check_written(got, dev, corr)


def test_fanuc_backlash_mode_applies_the_reported_parameter(run_dir: Path, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    got = export_json(run_dir, tmp_path / "x.txt", "--format", "fanuc", "--mode", "backlash", "--step", "100",
                      capsys=capsys)
    text = (tmp_path / "x.txt").read_text(encoding="utf-8")
    f = read_fanuc(text)
    assert f.params["3605#0"] == 0
    lost = int(text.split("1851 = ")[1].split()[0])  # the comment line of the listing
    b = -lost * 1.0  # B̄ as the backlash parameter holds it (lost motion L = −B̄), um
    assert lost == round(-mean_reversal())
    dev = measured()
    ref = TARGETS[0]
    at = f.point_positions_mm(ref)
    assert at[0] == ref and at[-1] == pytest.approx(904.404)  # 4.404 + 9·100: inside, not 1004.404
    corr = f.correction_um_anywhere(dev.target.to_numpy(), ref, +1, 1.0) - dev.direction.to_numpy() * b / 2
    check_written(got, dev, corr)
    assert any("90.906 mm before the last target" in n for n in got["notes"])


def test_siemens_table_stays_inside_and_is_scored_as_written(run_dir: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    got = export_json(run_dir, tmp_path / "x.ini", "--format", "siemens", capsys=capsys)
    lec = read_siemens_lec((tmp_path / "x.ini").read_text(encoding="utf-8"))
    assert lec.minimum == TARGETS[0] and lec.maximum == TARGETS[-1]  # (995.31 − 4.404)/4 = 247.7265 exactly
    assert lec.step == 247.7265
    dev = measured()
    corr = lec.correction_um(dev.target.to_numpy()) - dev.direction.to_numpy() * mean_reversal() / 2
    check_written(got, dev, corr)


def test_siemens_with_a_coarse_step_ends_inside(run_dir: Path, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    got = export_json(run_dir, tmp_path / "x.ini", "--format", "siemens", "--step", "300",
                      "--reference-position", "500", capsys=capsys)
    lec = read_siemens_lec((tmp_path / "x.ini").read_text(encoding="utf-8"))
    assert (lec.minimum, lec.maximum) == (4.404, 904.404)
    dev = measured()
    assert lec.value_mm(np.array([500.0]))[0] == pytest.approx(0.0, abs=1e-6)
    corr = lec.correction_um(dev.target.to_numpy()) - dev.direction.to_numpy() * mean_reversal() / 2
    check_written(got, dev, corr)
    assert any("reference position 500" in n for n in got["notes"])


@pytest.mark.parametrize("file_type", [0, 1])
def test_linuxcnc_on_the_targets_costs_nothing(run_dir: Path, tmp_path: Path, file_type: int,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    got = export_json(run_dir, tmp_path / "x.comp", "--format", "linuxcnc", "--linuxcnc-type", str(file_type),
                      capsys=capsys)
    c = read_linuxcnc_comp((tmp_path / "x.comp").read_text(encoding="utf-8"), file_type)
    np.testing.assert_allclose(c.nominal, TARGETS)
    dev = measured()
    corr = np.where(dev.direction > 0, c.correction_um(dev.target.to_numpy(), +1),
                    c.correction_um(dev.target.to_numpy(), -1))
    r = dev.deviation.to_numpy() + corr
    assert got["table_as_written"]["rms_um"] == pytest.approx(figures(dev, r)["rms_um"], abs=2e-3)  # float32 trims
    assert got["on_the_grid"] is None and got["costs"] == []
    # a table through the means leaves each point's scatter about its target's mean
    scatter = dev.deviation - dev.groupby(["target", "direction"]).deviation.transform("mean")
    assert got["model_on_its_nodes"]["rms_um"] == pytest.approx(float(np.sqrt(np.mean(scatter**2))), abs=1e-9)


def test_tables_never_reach_outside_the_measured_range(run_dir: Path) -> None:
    for opts in (ExportOptions(fmt="linuxcnc", step=300.0), ExportOptions(fmt="csv", step=300.0),
                 ExportOptions(fmt="fanuc", step=100.0, reference_position=312.43),
                 ExportOptions(fmt="siemens", step=250.0)):
        _, ex = export_run(run_dir, opts)
        assert ex.table.position[0] >= TARGETS[0] - 1e-9 and ex.table.position[-1] <= TARGETS[-1] + 1e-9, opts
    _, ex = export_run(run_dir, ExportOptions(fmt="fanuc", step=100.0, reference_position=312.43))
    assert ex.table.position[0] == pytest.approx(12.43) and 312.43 in list(np.round(ex.table.position, 6))


def test_grid_refusals(run_dir: Path) -> None:
    with pytest.raises(UserError, match="outside the measured range"):
        export_run(run_dir, ExportOptions(fmt="fanuc", reference_position=0.0))
    with pytest.raises(UserError, match="whole number of detection units"):
        export_run(run_dir, ExportOptions(fmt="fanuc", step=100.0005))
    with pytest.raises(UserError, match="6 decimals"):
        export_run(run_dir, ExportOptions(fmt="siemens", step=1 / 3 * 100))
    with pytest.raises(UserError, match="fewer than 2 table points"):
        export_run(run_dir, ExportOptions(fmt="siemens", step=2000.0))


def test_equidistant_targets_on_the_grid_cost_no_regridding(tmp_path: Path) -> None:
    targets = [0.0, 100.0, 200.0, 300.0, 400.0]
    write_run(tmp_path / "run", targets, UP, DOWN, SCATTER)
    _, ex = export_run(tmp_path / "run", ExportOptions(fmt="siemens"))
    assert ex.grid_step == 100.0 and not any("regridding" in c for c in ex.cost)
    assert ex.scores is not None and ex.scores.grid is not None
    assert ex.scores.grid["rms"] == pytest.approx(ex.scores.nodes["rms"], abs=1e-12)


def test_json_residuals_by_hand_and_the_file_mode(run_dir: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    old = os.umask(0o022)
    try:
        got = export_json(run_dir, tmp_path / "x.csv", "--format", "csv", capsys=capsys)
    finally:
        os.umask(old)
    assert (tmp_path / "x.csv").stat().st_mode & 0o777 == 0o644
    assert got["out"] == str(tmp_path / "x.csv")
    dev = measured()
    lin = got["residuals"]["linear"]
    assert set(got["residuals"]) == {"linear", "spline", "segments", "polynomial"}
    assert set(lin) == {"in_sample", "leave_one_run_out", "leave_one_target_out"}
    in_sample = dev.deviation - dev.groupby(["target", "direction"]).deviation.transform("mean")
    assert lin["in_sample"]["rms_um"] == pytest.approx(float(np.sqrt(np.mean(in_sample**2))), abs=1e-9)
    r = []
    for j in (1, 2, 3):  # the linear table of the other two runs passes through their means
        others = dev[dev.run != j].groupby(["target", "direction"]).deviation.mean()
        held = dev[dev.run == j]
        r += [e - others[(t, d)] for t, d, e in held[["target", "direction", "deviation"]].itertuples(index=False)]
    assert lin["leave_one_run_out"]["rms_um"] == pytest.approx(float(np.sqrt(np.mean(np.square(r)))), abs=1e-9)
    assert lin["leave_one_run_out"]["max_um"] == pytest.approx(float(np.max(np.abs(r))), abs=1e-9)
    assert lin["leave_one_target_out"]["folds"] == len(TARGETS)


def test_json_and_table_on_stdout_exclude_each_other(run_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(run_dir), "--format", "csv", "--out", "-", "--json"]) == 2
    assert "--json" in capsys.readouterr().err
