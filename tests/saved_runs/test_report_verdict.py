"""What a technician reads first: the SIMULATED banner, the headline result with the verdict
against the set-up's [tolerance] (also in ``process --json``), the identity the device reported
apart from the protocol, units (µm, slope in µm/m) in tables and plots alike, and the
cross-validated compensation residual.  Expected values are computed here from the profile and
the definitions."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from acquisition.setup.positioning import positioning_setup_from_dict
from acquisition.setup.straightness import straightness_setup_from_dict
from saved_runs.errors import SetupError
from saved_runs.evaluation.evaluate import process_run_dir
from saved_runs.report.build import build_report
from saved_runs.results.straightness import profile_figure
from tests.test_export_end_to_end import ERR_DN_UM, ERR_UP_UM, SCATTER_UM, write_run
from tui.cli import main

from .html_report import number, rows_by_first_cell, table_with_header
from .test_report_straightness import straightness_by_definition

V1_RUN = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"


@pytest.fixture()
def run_copy(tmp_path: Path) -> Path:
    return Path(shutil.copytree(V1_RUN, tmp_path / "run"))


def edit_meta(run: Path, **changes: object) -> None:
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    for key, value in changes.items():
        if value is None:
            meta.pop(key, None)
        else:
            meta[key] = value
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")


def profile(run: Path) -> tuple[np.ndarray, np.ndarray]:
    _, ev = process_run_dir(run, mc_trials=0)
    return ev.result.profile["x_mm"].to_numpy(), ev.result.profile["height_um"].to_numpy()


def test_simulated_runs_carry_a_banner_real_ones_do_not(run_copy: Path) -> None:
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    assert '<p class="banner">SIMULATED RUN' in doc and "guideway simulator" in doc  # v1 demo: the sim's identity
    assert doc.index('class="banner"') < doc.index("<h2>")
    edit_meta(run_copy, simulation={"seed": 7, "noise": False})
    assert "(simulated devices (seed 7, instrument noise off))" in build_report(run_copy, mc_trials=0).read_text(
        encoding="utf-8")
    meta = json.loads((run_copy / "run.json").read_text(encoding="utf-8"))
    meta["instruments"]["interferometer"]["vendor"] = "Renishaw"
    edit_meta(run_copy, simulation=None, instruments=meta["instruments"])
    assert 'class="banner"' not in build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")


def test_identity_reported_by_the_device_is_apart_from_protocol_and_driver(run_copy: Path) -> None:
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    rows = rows_by_first_cell(table_with_header(doc, "device", "identity reported by the device"))
    sensor, ifm = rows["sensor"], rows["interferometer"]
    assert sensor["protocol"] == "keyence-lkg"
    assert sensor["identity reported by the device"] == "not reported by the device"  # LK-G: no identity query
    assert sensor["driver / set-up"] == "model: Keyence LK-G (RS-232C)"
    assert ifm["protocol"] == "modbus (ABCD)" and "modbus" not in ifm["identity reported by the device"]
    assert ifm["identity reported by the device"].startswith("vendor: guideway-sim, product_code: SIM-6DOF")


def test_headline_slope_and_units(run_copy: Path) -> None:
    x, h = profile(run_copy)
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    mz = straightness_by_definition(x, h)["minimum-zone line"]
    assert f"Straightness {mz:.3f} µm against the minimum-zone line, over {x[-1] - x[0]:g} mm" in doc
    assert "No tolerance in the set-up ([tolerance] straightness_um, reference_line): no pass/fail verdict." in doc
    lines = rows_by_first_cell(table_with_header(doc, "reference line"))
    xm, hm = x.mean(), h.mean()
    ls_slope_um_per_m = 1000.0 * float(np.sum((x - xm) * (h - hm)) / np.sum((x - xm) ** 2))
    assert number(lines["least-squares line"]["slope (µm/m)"]) == pytest.approx(ls_slope_um_per_m, abs=5e-4)
    _, ev = process_run_dir(run_copy, mc_trials=0)
    fig = profile_figure(ev.result)
    texts = [a.get_ylabel() for a in fig.axes] + [t.get_text() for a in fig.axes for t in a.get_legend().get_texts()]
    assert all(" um" not in t and "(um)" not in t for t in texts) and sum("µm" in t for t in texts) >= 4


@pytest.mark.parametrize(("margin", "result"), [(+0.01, "pass"), (-0.01, "fail")])
def test_straightness_verdict_in_report_and_json(run_copy: Path, capsys: pytest.CaptureFixture[str],
                                                 margin: float, result: str) -> None:
    x, h = profile(run_copy)
    ls = straightness_by_definition(x, h)["least-squares line"]
    meta = json.loads((run_copy / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["tolerance"] = {"straightness_um": round(ls + margin, 6), "reference_line": "least_squares"}
    edit_meta(run_copy, setup=meta["setup"])
    assert main(["process", str(run_copy), "--json", "--mc-trials", "0", "--no-write"]) == 0
    verdict = json.loads(capsys.readouterr().out)["verdict"]
    assert verdict["result"] == result
    (c,) = verdict["checks"]
    assert c["quantity"] == "straightness (least squares line)" and c["value"] == pytest.approx(ls, abs=1e-9)
    assert c["tolerance"] == round(ls + margin, 6) and c["unit"] == "um"
    doc = build_report(run_copy, mc_trials=0).read_text(encoding="utf-8")
    assert f"Verdict: {result.upper()}" in doc and "against the least-squares line" in doc


def test_a_value_within_its_uncertainty_of_the_limit_is_flagged(run_copy: Path) -> None:
    x, h = profile(run_copy)
    mz = straightness_by_definition(x, h)["minimum-zone line"]
    meta = json.loads((run_copy / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["tolerance"] = {"straightness_um": round(mz, 3)}
    edit_meta(run_copy, setup=meta["setup"])
    _, ev = process_run_dir(run_copy, mc_trials=200)
    (c,) = ev.verdict.checks
    assert c.uncertainty is not None and c.uncertainty > abs(mz - round(mz, 3)) and c.within_uncertainty
    assert "not proven, ISO 14253-1" in ev.verdict.text()


def test_tolerance_keys_are_checked() -> None:
    base = {"block": {"length_mm": 100.0, "stations": 5},
            "geometry": {"mirror_mm": [50, 110, 0], "sensor_mm": [150, 0, 40]}}
    s = straightness_setup_from_dict({**base, "tolerance": {"straightness_um": 8}})
    assert s.to_run_setup()["tolerance"] == {"straightness_um": 8.0, "reference_line": "minimum_zone"}
    for bad, msg in (({"straightness": 8}, "unknown key 'straightness'"), ({"straightness_um": -1}, "positive"),
                     ({"straightness_um": 8, "reference_line": "best"}, "reference_line")):
        with pytest.raises(SetupError, match=msg):
            straightness_setup_from_dict({**base, "tolerance": bad})
    pos = {"axis": {"end_mm": 1000.0}, "tolerance": {"A_um": 20, "B_um": 3.5}}
    assert positioning_setup_from_dict(pos).to_run_setup()["tolerance"] == {"A_um": 20.0, "B_um": 3.5}
    with pytest.raises(SetupError, match="unknown key 'A_arcsec'"):
        positioning_setup_from_dict({**pos, "tolerance": {"A_arcsec": 5}})
    rot = {"axis": {"type": "rotary"}, "tolerance": {"A_arcsec": 5}}
    assert positioning_setup_from_dict(rot).tolerance == {"A_arcsec": 5.0}


def positioning_run(tmp_path: Path, tolerance: dict[str, float] | None = None) -> Path:
    run = tmp_path / "pos"
    write_run(run)
    if tolerance:
        meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
        meta["setup"]["tolerance"] = tolerance
        edit_meta(run, setup=meta["setup"])
    return run


def accuracy_by_hand() -> float:
    """ISO 230-2 A: every run j adds SCATTER_UM[j] at every target, so s_i = std(SCATTER_UM) everywhere."""
    s = float(np.std(SCATTER_UM, ddof=1))
    means = np.r_[ERR_UP_UM, ERR_DN_UM]
    return float(means.max() + 2 * s - (means.min() - 2 * s))


@pytest.mark.parametrize(("margin", "result"), [(+0.001, "pass"), (-0.001, "fail")])
def test_positioning_verdict_on_iso_values(tmp_path: Path, capsys: pytest.CaptureFixture[str], margin: float,
                                           result: str) -> None:
    a = accuracy_by_hand()
    run = positioning_run(tmp_path, {"A_um": round(a + margin, 6), "B_um": 100.0})
    assert main(["process", str(run), "--json", "--no-write"]) == 0
    verdict = json.loads(capsys.readouterr().out)["verdict"]
    assert verdict["result"] == result
    checks = {c["quantity"]: c for c in verdict["checks"]}
    assert checks["A"]["value"] == pytest.approx(a, abs=1e-9) and checks["B"]["result"] == "pass"
    doc = build_report(run).read_text(encoding="utf-8")
    assert f"Verdict: {result.upper()}" in doc and f"A = {a:.3f}" in doc


def test_positioning_report_has_the_cross_validated_residual(tmp_path: Path) -> None:
    doc = build_report(positioning_run(tmp_path)).read_text(encoding="utf-8")
    rows = rows_by_first_cell(table_with_header(doc, "model", "leave-one-run-out RMS (µm)"))
    # a linear table through the means of the other 4 runs misses run j by s_j + s_j / 4 (the scatter sums to 0)
    r = 1.25 * np.array(SCATTER_UM)
    assert number(rows["linear"]["leave-one-run-out RMS (µm)"]) == pytest.approx(np.sqrt(np.mean(r**2)), abs=5e-4)
    assert number(rows["linear"]["in-sample RMS (µm)"]) == pytest.approx(np.sqrt(np.mean(np.square(SCATTER_UM))),
                                                                        abs=5e-4)
    assert set(rows) == {"linear", "spline", "segments", "polynomial"}
