"""`guideway simulate` and `guideway diagnose` from the command line: a simulated run passes
process, report, export and diagnose like a measured one; the diagnosis finds what the scenario
hid, writes its report and a model file that, reused, leaves nothing to find; bad input gets one
line and exit code 2."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from saved_runs.store.reader import load_run
from tests.cli import guideway, one_line_error

SCENARIO = """
kind = "positioning"
seed = 7
[axis]
targets_mm = [0.0, 52.1, 98.7, 151.9, 203.4, 248.2, 302.6, 351.0, 398.4, 452.3, 500.0, 547.7, 603.1, 648.9,
              701.5, 752.0, 797.3, 850.8, 902.6, 948.1, 1000.0]
runs = 4
[trigger]
dwell_s = 2.0
[noise]
reading_um = 0.2
[[effect]]
type = "thermal_growth"
ppm_per_min = 0.06
[[effect]]
type = "periodic"
amplitude_um = 0.9
wavelength_mm = 310.0
phase_rad = -0.4
"""

STRAIGHTNESS = """
kind = "straightness"
[block]
length_mm = 100.0
stations = 12
return_pass = true
[[effect]]
type = "sensor_drift"
um_per_min = 0.03
"""


def test_simulated_positioning_run_goes_through_every_command(tmp_path: Path) -> None:
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(SCENARIO)
    run = tmp_path / "run"
    code, out, _ = guideway("simulate", str(scenario), "--out", str(run))
    assert code == 0 and "168 points" in out
    meta = load_run(run).meta
    assert meta["status"] == "complete" and meta["simulation"]["seed"] == 7
    code, out, _ = guideway("process", str(run), "--json")
    assert code == 0 and json.loads(out)["kind"] == "positioning"
    assert guideway("report", str(run))[0] == 0
    assert guideway("export", str(run), "--format", "linuxcnc", "--out", str(tmp_path / "comp.tbl"))[0] == 0

    report, model = tmp_path / "diagnosis.html", tmp_path / "model.toml"
    code, out, err = guideway("diagnose", str(run), "--json", "--report", str(report), "--out", str(model))
    assert code == 0, err
    d = json.loads(out)
    assert sorted(d["named"]) == ["periodic", "thermal_growth"] and d["ambiguous"] == []
    assert d["final"]["rms_um"] <= 1.2 * 0.2 < d["baseline"]["rms_um"]
    assert [s["rms_um"] for s in d["steps"]] == sorted((s["rms_um"] for s in d["steps"]), reverse=True)
    final = {e["type"]: e for e in d["final"]["model"]}
    for kind, name, value in (("thermal_growth", "ppm_per_min", 0.06), ("periodic", "amplitude_um", 0.9),
                              ("periodic", "wavelength_mm", 310.0)):
        assert abs(final[kind][name] - value) <= 4 * final[kind]["se"][name], (kind, name, final[kind])
    html = report.read_text()
    assert html.count("<img") >= 2 + len(d["steps"]) and "Step 2" in html and "Final model" in html

    # the model written back is a model file: reused, nothing is missing any more
    code, out, _ = guideway("diagnose", str(run), "--model", str(model), "--json")
    again = json.loads(out)
    assert code == 0 and again["named"] == [] and again["steps"] == []
    assert again["baseline"]["rms_um"] == pytest.approx(d["final"]["rms_um"], rel=1e-3)


def test_a_noise_free_simulation_names_exactly_what_it_hid(tmp_path: Path) -> None:
    """``simulate --no-noise``: the hidden effects come back to the precision of the wavelength search and
    nothing else is named (not the rounding left after them, not a time-origin leak into a scale error)."""
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(SCENARIO)
    run = tmp_path / "run"
    assert guideway("simulate", str(scenario), "--out", str(run), "--no-noise")[0] == 0
    code, out, err = guideway("diagnose", str(run), "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["named"] == ["periodic", "thermal_growth"] and d["ambiguous"] == [], d["named"]
    final = {e["type"]: e for e in d["final"]["model"]}
    assert final["thermal_growth"]["ppm_per_min"] == pytest.approx(0.06, rel=1e-4)
    assert final["periodic"]["amplitude_um"] == pytest.approx(0.9, rel=1e-4)
    assert final["periodic"]["wavelength_mm"] == pytest.approx(310.0, abs=0.01)
    assert d["final"]["rms_um"] < 1e-4


def test_simulate_is_reproducible_by_seed(tmp_path: Path) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(STRAIGHTNESS)
    for name, seed in (("a", "3"), ("b", "3"), ("c", "4")):
        assert guideway("simulate", str(scenario), "--out", str(tmp_path / name), "--seed", seed)[0] == 0
    text = {n: (tmp_path / n / "points.csv").read_text() for n in "abc"}
    assert text["a"] == text["b"] != text["c"]
    assert guideway("process", str(tmp_path / "a"), "--mc-trials", "0")[0] == 0
    code, out, _ = guideway("diagnose", str(tmp_path / "a"))
    assert code == 0 and "named: sensor_drift" in out


@pytest.mark.parametrize(("text", "fragment"), [
    ('kind = "positioning"\n[[effect]]\ntype = "sag"\n', "type 'sag' is not a positioning effect"),
    ('kind = "positioning"\n[[effect]]\ntype = "linear_scale"\nppm = 2.0\nfree = true\n', "free is for model files"),
    ('kind = "positioning"\n[axis]\nend_mm = 500.0\n[[effect]]\ntype = "periodic"\namplitude_um = 1.0\n',
     "wavelength_mm is missing"),
    ('kind = "straightness"\n[[effect]]\ntype = "sensor_gain"\nppm = 5.0\n', "no [block] table"),
    ('kind = "positioning"\n[noise]\nreading_nm = 3\n[axis]\nend_mm = 500.0\n', "unknown key 'reading_nm'"),
    ('kind = "positioning"\nseed = -3\n[axis]\nend_mm = 500.0\n', "seed must be a whole number >= 0"),
])
def test_bad_scenarios_are_one_line_errors(tmp_path: Path, text: str, fragment: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    one_line_error(guideway("simulate", str(path), "--out", str(tmp_path / "run")), fragment)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("command", [["simulate", "SCENARIO", "--out", "RUN"], ["demo", "--out", "RUN"],
                                     ["acquire", "positioning", "--simulate", "--out", "RUN"], ["sim", "serve"],
                                     ["tui", "--out", "RUN"]])
def test_a_negative_seed_is_a_one_line_error(tmp_path: Path, command: list[str]) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(STRAIGHTNESS)
    args = [{"SCENARIO": str(scenario), "RUN": str(tmp_path / "run")}.get(a, a) for a in command]
    one_line_error(guideway(*args, "--seed", "-1"), "a seed is a whole number >= 0")
    assert not (tmp_path / "run").exists()


def test_bad_diagnose_input_is_a_one_line_error(tmp_path: Path) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(STRAIGHTNESS)
    assert guideway("simulate", str(scenario), "--out", str(tmp_path / "run"))[0] == 0
    model = tmp_path / "m.toml"
    model.write_text('kind = "positioning"\n[[effect]]\ntype = "backlash"\nfree = true\n')
    one_line_error(guideway("diagnose", str(tmp_path / "run"), "--model", str(model)), "is a positioning model",
                   "straightness run")
    model.write_text('kind = "straightness"\n[[effect]]\ntype = "lever_arm"\nerror_mm = "x"\n')
    one_line_error(guideway("diagnose", str(tmp_path / "run"), "--model", str(model)), "error_mm must be a number")
    # a model effect the run cannot evaluate (an imported run without times): no silent NaN
    data = tmp_path / "data.csv"
    data.write_text("run,direction,target_mm,reading_mm\n" + "".join(
        f"{r},{d},{p},{p + 1e-4 * (r + d)}\n" for r in (1, 2) for d in (1, -1) for p in (0.0, 250.0, 500.0)))
    assert guideway("import", "positioning", str(data), "--out", str(tmp_path / "imported"),
                   "--compensated")[0] == 0
    model.write_text('kind = "positioning"\n[[effect]]\ntype = "thermal_drift"\nfree = true\n')
    res = guideway("diagnose", str(tmp_path / "imported"), "--model", str(model))
    one_line_error(res, "thermal_drift cannot be evaluated", "no time_s recorded")
    assert res.stdout == ""
    one_line_error(guideway("diagnose", str(tmp_path / "nothing")), "no such run directory")
    res = guideway("diagnose", str(tmp_path / "run"), "--model", str(tmp_path / "missing.toml"))
    one_line_error(res)
    assert res.stderr.startswith("guideway: error:")


def test_documented_examples_load() -> None:
    from acquisition.simulated.scenario import load_scenario
    from saved_runs.diagnosis.model_file import load_model

    root = Path(__file__).resolve().parents[1] / "docs"
    pos = load_scenario(root / "scenario-positioning.toml")
    assert pos.positioning is not None and len(pos.positioning.targets) == 21
    assert [e.type for e in pos.effects] == ["backlash", "thermal_growth", "periodic"]
    st = load_scenario(root / "scenario-straightness.toml")
    assert st.straightness is not None and st.straightness.return_pass
    model = load_model(root / "model-positioning.toml")
    assert [(e.type, sorted(e.free)) for e in model.effects] == [("backlash", ["reversal_um"])]
