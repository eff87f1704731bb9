"""``guideway export`` end to end: a hand-written positioning run (docs/run-format.md,
"Positioning runs") → the positioning evaluator → a controller file, read back with the
test-side readers."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from processing.columns import POSITIONING_LINEAR
from saved_runs.export.build import export_run
from saved_runs.export.options import ExportOptions
from tests.cli import guideway, one_line_error
from tests.controller_parsers import read_fanuc, read_linuxcnc_comp, read_siemens_lec
from tui.cli import main

TARGETS_MM = [0.0, 101.5, 198.0, 302.5, 400.0]
ERR_UP_UM = [0.0, 2.0, 3.5, 1.0, -1.5]  # mean deviation actual − target, + approach
ERR_DN_UM = [1.5, 3.0, 4.0, 3.0, 0.5]  # − approach
SCATTER_UM = [-0.2, -0.1, 0.0, 0.1, 0.2]  # per run, mean zero: the means are exactly the above


def write_run(run_dir: Path, targets_mm: list[float] = TARGETS_MM, err_up_um: list[float] = ERR_UP_UM,
              err_dn_um: list[float] = ERR_DN_UM, scatter_um: list[float] = SCATTER_UM) -> None:
    """A complete positioning run: target i, run j, direction d reads targets_mm[i] + (err_d[i] +
    scatter_um[j]) um (scatter_um[j] may also be a list, one value per target)."""
    TARGETS_MM, ERR_UP_UM, ERR_DN_UM, SCATTER_UM = targets_mm, err_up_um, err_dn_um, scatter_um  # noqa: N806
    run_dir.mkdir()
    meta = {
        "format": "guideway-run", "version": 2, "kind": "positioning", "status": "complete",
        "created": "2026-11-22T10:00:00Z", "ended": "2026-11-22T10:30:00Z", "uid": "e2e-export",
        "machine": "test machine", "axis": "X", "operator": "test", "notes": "", "axis_type": "linear",
        "points": 2 * len(TARGETS_MM) * len(SCATTER_UM),
        "setup": {
            "axis_name": "X", "targets_mm": TARGETS_MM, "runs": len(SCATTER_UM), "cycle": "linear",
            "overrun_mm": 5.0, "trigger": "in-position", "dwell_s": 1.0, "feed_mm_min": 1000.0,
            "environment": {"refractive_index_assumed": 1.0, "wavelength_nm": 632.991,
                            "expansion_ppm_per_k": 11.5, "dead_path_mm": 0.0, "abbe_offset_mm": [0.0, 0.0],
                            "co2_ppm": 450, "readings_compensated": True},
        },
        "instruments": {},
    }
    (run_dir / "run.json").write_text(json.dumps(meta, indent=2), encoding="utf-8")
    rows, t = [",".join(POSITIONING_LINEAR)], 0.0
    for j, scatter in enumerate(SCATTER_UM, start=1):
        for direction, errors in ((1, ERR_UP_UM), (-1, ERR_DN_UM)):
            order = range(len(TARGETS_MM)) if direction == 1 else reversed(range(len(TARGETS_MM)))
            for i in order:
                t += 10.0
                off = scatter[i] if isinstance(scatter, list) else scatter
                reading = TARGETS_MM[i] + (errors[i] + off) / 1000.0
                rows.append(",".join(str(v) for v in (j, direction, i + 1, TARGETS_MM[i], repr(reading), t,
                                                      0, 0, 0, 0, 0, 20.0, 1013.25, 50.0, 20.0, 0)))
    (run_dir / "points.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")


@pytest.fixture
def run_dir(tmp_path: Path) -> Path:
    write_run(tmp_path / "run")
    return tmp_path / "run"


def test_linuxcnc_file_corrects_the_measured_means(run_dir: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.comp"
    assert main(["export", str(run_dir), "--format", "linuxcnc", "--linuxcnc-type", "1", "--out", str(out)]) == 0
    c = read_linuxcnc_comp(out.read_text(encoding="utf-8"), 1)
    x = np.array(TARGETS_MM)
    np.testing.assert_allclose(c.nominal, x)
    np.testing.assert_allclose(np.array(ERR_UP_UM) + c.correction_um(x, +1), 0.0, atol=2e-3)
    np.testing.assert_allclose(np.array(ERR_DN_UM) + c.correction_um(x, -1), 0.0, atol=2e-3)
    printed = capsys.readouterr().out
    assert "residual after compensation" in printed and "spline" in printed and "segments" in printed


def test_residual_comparison_is_evaluated_on_every_run(run_dir: Path) -> None:
    # the linear table passes through the means, so each point keeps its run's scatter
    _, ex = export_run(run_dir, ExportOptions(fmt="csv"))
    cmp = ex.comparison.set_index("model")
    assert cmp.attrs["basis"] == "points" and cmp.attrs["n_points"] == 2 * len(TARGETS_MM) * len(SCATTER_UM)
    scatter = np.array(SCATTER_UM)
    assert cmp.loc["linear"].range == pytest.approx(scatter.max() - scatter.min(), abs=1e-6)
    assert cmp.loc["linear"].rms == pytest.approx(np.sqrt(np.mean(scatter**2)), abs=1e-6)
    raw = np.concatenate([np.add.outer(scatter, ERR_UP_UM).ravel(), np.add.outer(scatter, ERR_DN_UM).ravel()])
    assert cmp.loc["none"].range == pytest.approx(raw.max() - raw.min(), abs=1e-6)


def test_siemens_and_fanuc_files(run_dir: Path, tmp_path: Path) -> None:
    lec_path, fanuc_path = tmp_path / "x.ini", tmp_path / "x.txt"
    assert main(["export", str(run_dir), "--format", "siemens", "--step", "100", "--out", str(lec_path)]) == 0
    lec = read_siemens_lec(lec_path.read_text(encoding="utf-8"))
    assert lec.axis == "X1" and (lec.minimum, lec.maximum, lec.step) == (0.0, 400.0, 100.0)
    mean = (np.array(ERR_UP_UM) + np.array(ERR_DN_UM)) / 2
    np.testing.assert_allclose(lec.values_mm * 1000, np.interp([0, 100, 200, 300, 400], TARGETS_MM, mean),
                               atol=1e-3)
    assert main(["export", str(run_dir), "--format", "fanuc", "--step", "100", "--out", str(fanuc_path)]) == 0
    f = read_fanuc(fanuc_path.read_text(encoding="utf-8"))
    grid = np.arange(0.0, 401.0, 100.0)
    e_up = np.interp(grid, TARGETS_MM, ERR_UP_UM)
    np.testing.assert_allclose(e_up + f.correction_um(grid, 0.0, +1, 1.0), 0.0, atol=0.5)


@pytest.mark.parametrize(("args", "message"), [
    (("--tolerance", "-1"), "--tolerance must be a number >= 0 (um or arcsec), got -1"),
    (("--tolerance", "nan"), "--tolerance must be a number >= 0 (um or arcsec), got nan"),
    (("--initial-knots", "-1"), "--initial-knots must be >= 0, got -1"),
    (("--degree", "-2"), "--degree must be >= 0, got -2"),
])
def test_bad_model_options_are_one_line_errors(run_dir: Path, tmp_path: Path, args: tuple[str, ...],
                                               message: str) -> None:
    # they used to drop that model from the comparison ("not fitted") and exit 0, also when the table's
    # own model was another one
    res = guideway("export", run_dir, "--format", "csv", "--out", tmp_path / "t.csv", *args)
    one_line_error(res, message)
    assert not (tmp_path / "t.csv").exists()


def test_zero_tolerance_is_the_spline_through_every_target(run_dir: Path, tmp_path: Path) -> None:
    # --tolerance 0 hung (the spline's rounding at its last knot kept "adding" that knot)
    res = guideway("export", run_dir, "--format", "csv", "--model", "spline", "--tolerance", "0",
                   "--out", tmp_path / "t.csv", "--json")
    assert res.returncode == 0, res.stderr
    spline = next(r for r in json.loads(res.stdout)["comparison"] if r["model"] == "spline")
    assert spline["table_points"] == len(TARGETS_MM) and spline["E_um"] == pytest.approx(0.0, abs=1e-9)


def test_an_unwritable_out_is_a_one_line_error(run_dir: Path, tmp_path: Path) -> None:
    # an --out that is a directory, or under a file, ended in a traceback (IsADirectoryError, FileExistsError)
    (tmp_path / "adir").mkdir()
    one_line_error(guideway("export", run_dir, "--format", "csv", "--out", tmp_path / "adir"),
                   f"--out {tmp_path / 'adir'} is a directory; give a file name")
    (tmp_path / "afile").write_text("", encoding="utf-8")
    one_line_error(guideway("export", run_dir, "--format", "csv", "--out", tmp_path / "afile" / "t.csv"),
                   f"cannot write the table to {tmp_path / 'afile' / 't.csv'}")
