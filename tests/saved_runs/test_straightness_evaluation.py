"""A version-2 straightness run with a return pass and uncertainty inputs,
processed from its directory: JSON keys, results files, bad inputs."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from saved_runs.errors import RunFormatError
from saved_runs.evaluation.evaluate import process_run_dir

V1 = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"


def make_round_trip(tmp_path: Path, uncertainty: dict | None = None) -> Path:
    """The frozen v1 run turned into v2 with a return pass: the forward rows
    replayed backwards 1 h later with +0.5 um on stry (a drift step)."""
    run = tmp_path / "run"
    shutil.copytree(V1, run)
    meta = json.loads((run / "run.json").read_text())
    meta["version"] = 2
    meta["setup"]["return_pass"] = True
    if uncertainty is not None:
        meta["setup"]["uncertainty"] = uncertainty
    (run / "run.json").write_text(json.dumps(meta))
    with open(run / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    header = [*rows[0].keys(), "pass"]
    out = [{**r, "pass": "0"} for r in rows]
    for r in reversed(rows):
        out.append({**r, "pass": "1", "time_s": repr(float(r["time_s"]) + 3600.0),
                    "stry_um": repr(float(r["stry_um"]) + 0.5)})
    with open(run / "points.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=header, lineterminator="\n")
        w.writeheader()
        w.writerows(out)
    return run


def test_round_trip_run_processes_and_writes(tmp_path: Path) -> None:
    run = make_round_trip(tmp_path, {"offset_mm": 0.2})
    _, ev = process_run_dir(run, method="first-order", mc_trials=200)
    d = ev.to_dict()
    fwd_only = process_run_dir(V1, method="first-order", mc_trials=0)[1].to_dict()
    # same channels + 0.5 um on the return pass: mean = forward + 0.25 everywhere
    for a, b in zip(d["profile"], fwd_only["profile"], strict=True):
        assert a["height_um"] == pytest.approx(b["height_um"] + 0.25, abs=1e-9)
    rp = d["return_pass"]
    assert rp["closure_um"] == pytest.approx(0.5, abs=1e-9)
    assert rp["drift_um_per_h"] == pytest.approx(0.5, rel=1e-3)  # ~1 h between visits
    assert d["uncertainty_um"]["inputs"]["offset_mm"] == 0.2
    assert d["uncertainty_um"]["inputs"]["angle_urad"] == 0.2  # default
    out = ev.write(run / "results")
    assert (out / "profile.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((out / "summary.json").read_text())["return_pass"]["closure_um"] == pytest.approx(0.5)


def test_bad_uncertainty_input_is_a_run_format_error(tmp_path: Path) -> None:
    run = make_round_trip(tmp_path, {"angle_urad": "big"})
    with pytest.raises(RunFormatError, match="angle_urad"):
        process_run_dir(run, mc_trials=0)


@pytest.mark.parametrize(("column", "value", "method", "refused"), [
    ("pitch_urad", "nan", "exact", True),
    ("pitch_urad", "inf", "first-order", True),
    ("yaw_urad", "nan", "exact", True),  # exact uses all six channels
    ("yaw_urad", "nan", "first-order", False),  # first-order does not use yaw
])
def test_a_missing_channel_value_names_station_and_column(tmp_path: Path, column: str, value: str, method: str,
                                                           refused: bool) -> None:
    run = tmp_path / "run"
    shutil.copytree(V1, run)
    with open(run / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    rows[3][column] = value
    with open(run / "points.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    if not refused:
        process_run_dir(run, method=method, mc_trials=0)
        return
    with pytest.raises(RunFormatError) as info:
        process_run_dir(run, method=method, mc_trials=0)
    msg = str(info.value)
    assert f"station {rows[3]['station']} has {column} = {value}" in msg and "\n" not in msg


def test_default_monte_carlo_trials_shrink_on_long_runs() -> None:
    from saved_runs.evaluation.straightness import default_mc_trials

    assert default_mc_trials(20) == 10_000 and default_mc_trials(200) == 10_000
    assert default_mc_trials(1000) == 2000  # trials x stations = 2e6
    assert default_mc_trials(10_000) == 1000  # never fewer than 1000
