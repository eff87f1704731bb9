"""The measured datum angles (``[geometry] datum_angles_urad``, docs/setup-straightness.toml):
set-up validation, run.json, processing of a simulated run, and the live profile of a
resumed run (which must use the same first step as ``guideway process``)."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from acquisition.acquire import SimOptions, run_straightness
from acquisition.demo import demo_setup
from acquisition.live import LiveProfile
from acquisition.setup.stored import straightness_setup_from_run
from acquisition.setup.straightness import straightness_setup_from_dict
from processing.decoupling import decouple
from processing.geometry import DatumAngles
from saved_runs.errors import SetupError
from saved_runs.report.build import build_report
from saved_runs.store.reader import load_run
from tui.cli import main

from ..cli import guideway, one_line_error
from ..saved_runs.html_report import parse

TOML_GEOMETRY = {"mirror_mm": [50, 110, 0], "sensor_mm": [150, 0, 40]}


def setup_dict(**geometry) -> dict:
    return {"block": {"length_mm": 100.0, "stations": 5}, "geometry": {**TOML_GEOMETRY, **geometry}}


def test_measured_angles_are_read_and_stored_in_run_json() -> None:
    s = straightness_setup_from_dict(setup_dict(datum_angles_urad={"pitch": 42.5, "roll": -3}), "s.toml")
    assert s.geometry.datum_angles_urad == DatumAngles(roll_urad=-3.0, pitch_urad=42.5)
    stored = s.to_run_setup()["geometry"]
    assert stored["datum_angles_urad"] == {"roll": -3.0, "pitch": 42.5}  # only what was measured
    assert straightness_setup_from_run({**s.header(), "setup": s.to_run_setup()}) == s
    plain = straightness_setup_from_dict(setup_dict(), "s.toml")
    assert plain.geometry.datum_angles_urad == DatumAngles() and "datum_angles_urad" not in (
        plain.to_run_setup()["geometry"])


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (42.0, "[geometry] datum_angles_urad must be a table"),
        ({"tilt": 1.0}, "unknown key(s) tilt; use roll, yaw, pitch"),
        ({"pitch": "high"}, "datum_angles_urad.pitch must be a finite number (urad)"),
        ({"pitch": True}, "datum_angles_urad.pitch must be a finite number (urad)"),
        ({"roll": float("nan")}, "datum_angles_urad.roll must be a finite number (urad)"),
        ({"yaw": 0.02e6}, "check the units"),
    ],
)
def test_bad_datum_angles_are_one_line_errors(value: object, message: str) -> None:
    with pytest.raises(SetupError) as info:
        straightness_setup_from_dict(setup_dict(datum_angles_urad=value), "s.toml")
    text = str(info.value)
    assert text.startswith("s.toml: [geometry]") and message in text and "\n" not in text


def test_a_simulated_run_uses_the_measured_angles(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    setup = demo_setup(stations=5, samples=1)
    setup = replace(setup, geometry=replace(setup.geometry, datum_angles_urad=DatumAngles(pitch_urad=33.0)))
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=3, noise=False), auto=True,
                           stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    run = tmp_path / "run"
    assert json.loads((run / "run.json").read_text())["setup"]["geometry"]["datum_angles_urad"] == {"pitch": 33.0}
    assert main(["process", str(run), "--json", "--no-write", "--mc-trials", "0"]) == 0
    d = json.loads(capsys.readouterr().out)["datum_angles_urad"]
    assert d == {"roll": 0.0, "yaw": 0.0, "pitch": 33.0,
                 "source": {"roll": "assumed", "yaw": "assumed", "pitch": "measured"}}
    assert main(["process", str(run), "--no-write", "--mc-trials", "0"]) == 0
    printed = capsys.readouterr().out
    assert "datum angles (laser frame): pitch 33.000 urad measured; roll 0 and yaw 0 assumed" in printed
    doc = build_report(run, out=tmp_path / "r.html", mc_trials=0).read_text(encoding="utf-8")
    rows = {r[0]: r[1:] for t in parse(doc).tables for r in t if r}
    assert rows["datum angles (laser frame)"][0].startswith("pitch 33.000 urad measured")
    doc = build_report(run, out=tmp_path / "f.html", method="first-order", mc_trials=0).read_text(encoding="utf-8")
    assert "datum angles" not in doc  # first-order and patent do not use them


def test_bad_angles_in_run_json_are_refused_by_process(tmp_path: Path) -> None:
    res = run_straightness(demo_setup(stations=3, samples=1), tmp_path / "run",
                           simulate=SimOptions(seed=1, noise=False), auto=True, stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    meta_path = tmp_path / "run" / "run.json"
    meta = json.loads(meta_path.read_text())
    meta["setup"]["geometry"]["datum_angles_urad"] = {"pitch": 5e5}
    meta_path.write_text(json.dumps(meta))
    one_line_error(guideway("process", tmp_path / "run", "--no-write", "--mc-trials", "0"), "setup.geometry",
                   "check the units")


def test_live_profile_of_a_resumed_run_uses_the_first_step_on_disk(tmp_path: Path) -> None:
    """A run resumed after station 3: the live heights of the later stations equal the
    offline profile, because the datum pitch comes from the same first step."""
    setup = demo_setup(stations=7, samples=1)
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=8), auto=True, stream=io.StringIO())
    assert res.outcome.exit_status == "success"
    points = load_run(tmp_path / "run").points
    records = points.to_dict("records")
    live = LiveProfile(setup.geometry, first=records[0], first_step=records[1])
    for row in records[4:]:
        live("event", {"data": row})
    offline = decouple(points, setup.geometry, "exact")["height_um"].to_numpy()
    np.testing.assert_allclose([live.heights[(0, k)] for k in range(4, 7)], offline[4:], atol=1e-9)
    # without the first step the datum pitch would be taken as 0: in the laser frame that changes
    # a height only at second order (datum pitch x angle change x lever, ~1e-5 um here), but it does
    blind = LiveProfile(setup.geometry, first=records[0])
    blind("event", {"data": records[6]})
    assert abs(blind.heights[(0, 6)] - offline[6]) > 1e-7
    # and a redone first step replaces the one the estimate uses
    fresh = LiveProfile(setup.geometry)
    for row in records[:2]:
        fresh("event", {"data": row})
    fresh("retract", {"match": {"pass": 0, "station": 1}})
    assert fresh.first_step is None
    fresh("event", {"data": records[1]})
    fresh("event", {"data": records[6]})
    assert fresh.heights[(0, 6)] == pytest.approx(offline[6], abs=1e-9)
