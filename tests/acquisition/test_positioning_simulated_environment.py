"""A simulated positioning run processed end to end: the simulated controller reports what a real
one does (raw counts through air of the logged index, the axis expanded at its material temperature,
standards.md §3.5), so processing recovers the simulated axis's own errors at 20 C."""

from __future__ import annotations

import io
import json
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from acquisition.acquire import SimOptions, run_positioning
from acquisition.setup.positioning import positioning_setup_from_dict
from mocks.machine_axis import AxisErrors
from saved_runs.evaluation.evaluate import process_run_dir
from tui.cli import main

ROOT = Path(__file__).resolve().parents[2]

# The axis's errors (um): no thermal growth, so the truth at a target does not depend on machine time.
ERRORS = {"pitch_amplitude": 4.0, "pitch_wavelength": 700.0, "slope_per_m": 6.0, "backlash": 3.0,
          "periodic": 0.6, "periodic_period": 10.0, "thermal_per_m_per_h": 0.0}
# Several K off 20 C: uncompensated, the air alone is about -1 ppm/K and the steel 11.5 ppm/K.
CONDITIONS = {"air_temp_c": 24.5, "air_pressure_hpa": 985.0, "humidity_pct": 62.0, "material_temp_c": 23.0,
              "drift_c_per_h": 0.8}


def setup_source(environment: dict[str, Any]) -> dict[str, Any]:
    d = tomllib.loads((ROOT / "docs" / "setup-positioning.toml").read_text())
    d["axis"].update({"end_mm": 600.0, "runs": 2})
    d["environment"].update(environment)
    d["simulation"].update({**ERRORS, **CONDITIONS})
    return d


def process_json(run_dir: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, Any]:
    capsys.readouterr()
    assert main(["process", str(run_dir), "--json", "--no-write"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("environment", [
    {"refractive_index_assumed": 1.0, "dead_path_mm": 0.0},           # raw vacuum-wavelength counts
    {"refractive_index_assumed": 1.00027, "dead_path_mm": 350.0},     # a fixed index, a dead path
    {"readings_compensated": True},                                   # the controller compensates
    {"refractive_index_assumed": 1.0, "index_equation": "edlen"},     # the set-up chooses Edlén
], ids=["vacuum-counts", "fixed-index-dead-path", "compensated", "edlen"])
def test_processing_recovers_the_simulated_axis_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        environment: dict[str, Any]) -> None:
    src = setup_source(environment)
    s = positioning_setup_from_dict(src)
    res = run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=5, noise=False), auto=True,
                          setup_source=src, stream=io.StringIO())
    assert res.outcome.exit_status == "success", res.outcome.reason
    out = process_json(tmp_path / "run", capsys)

    # ground truth: the error model itself (um, at 20 C), written out here from the set-up's values
    truth = AxisErrors(pitch=((ERRORS["pitch_amplitude"], ERRORS["pitch_wavelength"], 0.4),),
                       slope_per_m=ERRORS["slope_per_m"], backlash=ERRORS["backlash"], periodic=ERRORS["periodic"],
                       periodic_period=ERRORS["periodic_period"], thermal_per_m_per_h=0.0, noise=0.0)
    targets = np.array([t["target"] for t in out["targets"]])
    assert targets.tolist() == list(s.targets)
    up = np.array([truth.deviation(p, +1, 0.0) for p in targets])
    down = np.array([truth.deviation(p, -1, 0.0) for p in targets])
    np.testing.assert_allclose([t["mean_up"] for t in out["targets"]], up, rtol=0, atol=1e-3)
    np.testing.assert_allclose([t["mean_down"] for t in out["targets"]], down, rtol=0, atol=1e-3)
    both = np.concatenate([up, down])
    assert out["iso230_2"]["E"] == pytest.approx(both.max() - both.min(), abs=2e-3)
    assert out["environment"]["applied"] == (not environment.get("readings_compensated", False))
    if out["environment"]["applied"]:
        assert out["environment"]["equation"] == environment.get("index_equation", "ciddor")

    # the live display showed each point as process evaluates it: the compensated deviation, labelled
    _, ev = process_run_dir(tmp_path / "run")
    offline = {(int(r.run), int(r.direction), int(r.target_index)): r.deviation for r in ev.deviations.itertuples()}
    assert res.live is not None and set(res.live.deviations) == set(offline)
    for key, value in offline.items():
        assert res.live.deviations[key] == pytest.approx(value, abs=1e-9)
        assert res.live.deviations[key] == pytest.approx(truth.deviation(s.targets[key[2] - 1], key[1], 0.0),
                                                         abs=1e-3)
    assert res.live.label == ("readings compensated by the controller" if environment.get("readings_compensated")
                              else "environment-compensated")


def test_raw_readings_carry_the_air_index_and_the_expansion(tmp_path: Path) -> None:
    # the uncompensated readings are far from the axis: the conditions really are in them
    src = setup_source({"refractive_index_assumed": 1.0})
    s = positioning_setup_from_dict(src)
    shown = io.StringIO()
    run_positioning(s, tmp_path / "run", simulate=SimOptions(seed=5, noise=False), auto=True, stream=shown)
    from saved_runs.store.reader import load_run

    pts = load_run(tmp_path / "run").points
    far = pts[pts["target_mm"] == max(s.targets)]
    raw_dev_um = (far["reading_mm"] - far["target_mm"]) * 1000
    # n_air - 1 is about 2.6e-4 at these conditions, expansion 11.5e-6 * 3 K: > 150 um at 600 mm
    assert (raw_dev_um > 150).all()
    # ... and the live display does not show them as deviations: the axis errors are within 13 um
    live = [line for line in shown.getvalue().splitlines() if line.startswith("  live: ")]
    assert len(live) == len(pts) and all(line.endswith("µm (environment-compensated)") for line in live)
    values = [float(line.split("deviation ")[1].split()[0]) for line in live]
    assert max(abs(v) for v in values) < 13.0
