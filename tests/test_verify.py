"""``guideway verify``: the whole loop in simulation — as-found run → ``guideway export`` → as-left run with
``acquire --simulate --compensation FILE`` → verify.

The expected values are computed here from the two runs' points.csv with the ISO 230-2 formulas written out
below (standards.md §1.3, k = 2), and the prediction from the as-found means plus the correction the written
file makes, read by the test-side reader written from LinuxCNC's rules (tests/controller_parsers.py)."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.cli import ROOT, guideway, one_line_error
from tests.controller_parsers import read_linuxcnc_comp

K = 2.0
VALUES = ("E", "E_up", "E_down", "M", "B", "B_mean", "A", "A_up", "A_down", "R", "R_up", "R_down")


def setup_file(tmp_path: Path, end_mm: float = 400.0, runs: int = 5, name: str = "pos.toml") -> Path:
    text = (ROOT / "docs" / "setup-positioning.toml").read_text(encoding="utf-8")
    text = text.replace("end_mm = 1000.0", f"end_mm = {end_mm}").replace("runs = 5 ", f"runs = {runs} ")
    # the controller reports the axis at 20 C: deviation = reading - target
    text = text.replace("readings_compensated = false", "readings_compensated = true")
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def acquire(setup: Path, out: Path, *extra: str | Path, seed: int = 0) -> None:
    res = guideway("acquire", "positioning", "--setup", setup, "--out", out, "--simulate", "--auto",
                   "--seed", str(seed), *extra)
    assert res.returncode == 0, res.stderr


def stats(run_dir: Path, shift: dict[int, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Per target (ascending) and direction: mean and s (ddof 1) of reading - target in um; ``shift``: a
    correction per direction (um, per target) added to every point."""
    pts = pd.read_csv(run_dir / "points.csv")
    pts["e"] = (pts["reading_mm"] - pts["target_mm"]) * 1000.0
    x = np.array(sorted(pts["target_mm"].unique()))
    out: dict[str, np.ndarray] = {"x": x}
    for d, name in ((1, "up"), (-1, "down")):
        g = pts[pts["direction"] == d].groupby("target_mm")["e"]
        mean = g.mean().reindex(x).to_numpy()
        out[f"mean_{name}"] = mean + (shift[d] if shift else 0.0)
        out[f"s_{name}"] = g.std(ddof=1).reindex(x).to_numpy()
    return out


def iso(s: dict[str, np.ndarray]) -> dict[str, float]:
    """ISO 230-2 axis values from per-target means and s (standards.md §1.3, k = 2)."""
    up, dn, su, sd = s["mean_up"], s["mean_down"], s["s_up"], s["s_down"]
    both = np.concatenate([up, dn])
    bi = (up + dn) / 2
    rev = up - dn
    return {
        "E_up": up.max() - up.min(), "E_down": dn.max() - dn.min(), "E": both.max() - both.min(),
        "M": bi.max() - bi.min(), "B": np.abs(rev).max(), "B_mean": rev.mean(),
        "R_up": (2 * K * su).max(), "R_down": (2 * K * sd).max(),
        "R": np.maximum(np.maximum(K * su + K * sd + np.abs(rev), 2 * K * su), 2 * K * sd).max(),
        "A_up": (up + K * su).max() - (up - K * su).min(), "A_down": (dn + K * sd).max() - (dn - K * sd).min(),
        "A": np.concatenate([up + K * su, dn + K * sd]).max() - np.concatenate([up - K * su, dn - K * sd]).min(),
    }


@pytest.fixture(scope="module")
def loop(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("loop")
    setup = setup_file(tmp)
    found, left = tmp / "found", tmp / "left"
    acquire(setup, found, seed=0)
    res = guideway("export", found, "--format", "linuxcnc", "--json")  # to results/compensation-linuxcnc.comp
    assert res.returncode == 0, res.stderr
    (tmp / "export.json").write_text(res.stdout)
    table = found / "results" / "compensation-linuxcnc.comp"
    acquire(setup, left, "--compensation", table, "--comp-file-type", "1", seed=1)
    return {"tmp": tmp, "setup": setup, "found": found, "left": left, "table": table}


def verify_json(found: Path, left: Path) -> dict:
    res = guideway("verify", found, left, "--json")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_found_left_predicted_and_reduction_of_every_value(loop: dict[str, Path]) -> None:
    out = verify_json(loop["found"], loop["left"])
    s_found, s_left = stats(loop["found"]), stats(loop["left"])
    x = s_found["x"]
    comp = read_linuxcnc_comp(loop["table"].read_text(encoding="utf-8"), 1)
    s_pred = stats(loop["found"], {d: comp.correction_um(x, d) for d in (1, -1)})
    found, left, pred = iso(s_found), iso(s_left), iso(s_pred)
    assert set(out["values"]) == set(VALUES)
    for q in VALUES:
        v = out["values"][q]
        assert {"found", "left", "predicted", "reduction_pct", "u_found", "u_left", "u_predicted",
                "u_reduction_pct", "flags"} <= set(v)
        assert v["found"] == pytest.approx(found[q], abs=1e-6), q
        assert v["left"] == pytest.approx(left[q], abs=1e-6), q
        assert v["predicted"] == pytest.approx(pred[q], abs=2e-3), q  # float32 trims of LinuxCNC
        assert v["reduction_pct"] == pytest.approx(100.0 * (1.0 - abs(left[q]) / abs(found[q])), abs=1e-6), q
    # the table works: E from several um to a fraction of the repeatability, as the export predicted
    e = out["values"]["E"]
    assert e["found"] > 5.0 and e["reduction_pct"] > 80.0
    assert abs(e["left"] - e["predicted"]) < left["R"]
    assert e["u_found"] > 0 and e["u_left"] > 0 and e["u_reduction_pct"] > 0
    # predicted = the export's "as written" figure
    exported = json.loads((loop["tmp"] / "export.json").read_text())
    assert e["predicted"] == pytest.approx(exported["table_as_written"]["E_um"], abs=0.01)
    assert out["values"]["M"]["predicted"] == pytest.approx(exported["table_as_written"]["M_um"], abs=0.01)
    # a table does not change the repeatability: R_up predicted = found
    assert out["values"]["R_up"]["predicted"] == pytest.approx(found["R_up"], abs=1e-6)
    # drift: the range of left - predicted over targets and directions
    drift = np.concatenate([s_left[f"mean_{n}"] - s_pred[f"mean_{n}"] for n in ("up", "down")])
    assert out["drift"]["range"] == pytest.approx(drift.max() - drift.min(), abs=2e-3)
    assert out["unit"] == "um" and len(out["targets"]) == 2 * len(x)


def test_the_table_is_the_one_exported_from_as_found(loop: dict[str, Path]) -> None:
    out = verify_json(loop["found"], loop["left"])
    sha = hashlib.sha256(loop["table"].read_bytes()).hexdigest()
    t = out["table"]
    assert t["sha256"] == sha and t["exported_from_found"] is True and t["found_as"] == "exports.json"
    assert t["export"]["model"] == "linear"
    rec = json.loads((loop["found"] / "results" / "exports.json").read_text())["exports"][-1]
    assert rec["sha256"] == sha and rec["run_uid"] == json.loads((loop["found"] / "run.json").read_text())["uid"]
    # without the record, the table is still found by its bytes among results/compensation-*
    copy = loop["tmp"] / "found-norecord"
    shutil.copytree(loop["found"], copy)
    (copy / "results" / "exports.json").unlink()
    assert verify_json(copy, loop["left"])["table"]["found_as"] == "results/compensation-linuxcnc.comp"
    # another table: said plainly, and the prediction is that table's
    other = loop["tmp"] / "other.comp"
    other.write_text("0.0 0.001 0.001\n400.0 0.001 0.001\n", encoding="utf-8")
    left2 = loop["tmp"] / "left-other"
    acquire(setup_file(loop["tmp"], runs=2, name="pos2.toml"), left2, "--compensation", other, "--comp-file-type",
            "1", seed=2)
    res = guideway("verify", loop["found"], left2)
    assert res.returncode == 0, res.stderr
    assert "other.comp" in res.stdout and "NOT a table exported from AS_FOUND" in res.stdout
    out2 = verify_json(loop["found"], left2)
    assert out2["table"]["exported_from_found"] is False
    s_found = stats(loop["found"])
    m_pred = iso({**s_found, "mean_up": s_found["mean_up"] + 1.0, "mean_down": s_found["mean_down"] + 1.0})["E"]
    assert out2["values"]["E"]["predicted"] == pytest.approx(m_pred, abs=2e-3)


def test_text_and_report(loop: dict[str, Path]) -> None:
    report = loop["tmp"] / "verify.html"
    res = guideway("verify", loop["found"], loop["left"], "--report", report)
    assert res.returncode == 0, res.stderr
    assert "the table exported from AS_FOUND" in res.stdout and "verdict: E " in res.stdout
    assert "drift between the runs" in res.stdout
    html = report.read_text(encoding="utf-8")
    assert "Before and after" in html and html.count("<img") == 2 and "reduction %" in html


def edited(src: Path, dst: Path, **changes: object) -> Path:
    shutil.copytree(src, dst)
    meta = json.loads((dst / "run.json").read_text())
    for key, value in changes.items():
        if value is None:
            meta.pop(key, None)
        else:
            meta[key] = value
    (dst / "run.json").write_text(json.dumps(meta))
    return dst


def test_refusals(loop: dict[str, Path]) -> None:
    found, left, tmp = loop["found"], loop["left"], loop["tmp"]
    # AS_LEFT without a table: the as-found run itself, or a run that does not record it
    one_line_error(guideway("verify", found, found), "AS_LEFT", "measured with no compensation table active",
                   "guideway compare")
    one_line_error(guideway("verify", found, edited(left, tmp / "r-unrecorded", compensation=None)),
                   "does not record which compensation table was active")
    # both measured with the same table: nothing changed between them
    one_line_error(guideway("verify", left, left), "measured with the same table active", "nothing was changed")
    # another axis, another machine
    meta = json.loads((left / "run.json").read_text())
    one_line_error(guideway("verify", found, edited(left, tmp / "r-axis", axis="Y",
                                                    setup={**meta["setup"], "axis_name": "Y"})),
                   "axis 'Y'", "same axis")
    one_line_error(guideway("verify", found, edited(left, tmp / "r-machine", machine="Another")),
                   "machine", "Another")
    # not positioning runs
    straight = tmp / "straight"
    res = guideway("acquire", "straightness", "--setup", ROOT / "docs" / "setup-straightness.toml", "--out", straight,
                   "--simulate", "--auto")
    assert res.returncode == 0, res.stderr
    one_line_error(guideway("verify", straight, left), "straightness run", "two positioning runs")
    # a run that cannot be evaluated
    bad = edited(left, tmp / "r-empty")
    (bad / "points.csv").write_text((left / "points.csv").read_text().splitlines()[0] + "\n")
    res = guideway("verify", found, bad)
    assert res.returncode == 2 and "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    # other targets
    other = tmp / "left-380"
    acquire(setup_file(tmp, end_mm=380.0, runs=2, name="pos380.toml"), other, "--compensation", loop["table"],
            "--comp-file-type", "1", seed=3)
    one_line_error(guideway("verify", found, other), "targets do not match", "same set-up")
    # the table file changed since AS_LEFT was measured
    changed = tmp / "changed.comp"
    changed.write_text("0.0 0.002 0.002\n400.0 0.002 0.002\n", encoding="utf-8")
    left3 = tmp / "left-changed"
    acquire(setup_file(tmp, runs=2, name="pos3.toml"), left3, "--compensation", changed, "--comp-file-type", "1",
            seed=4)
    changed.write_text("0.0 0.003 0.003\n400.0 0.003 0.003\n", encoding="utf-8")
    one_line_error(guideway("verify", found, left3), "is not the table that was active during the run")


def test_export_says_how_to_load_the_table(loop: dict[str, Path]) -> None:
    found, tmp = loop["found"], loop["tmp"]
    res = guideway("export", found, "--format", "linuxcnc", "--linuxcnc-type", "0", "--out", tmp / "x.comp")
    assert res.returncode == 0, res.stderr
    text = res.stdout[res.stdout.index("load it (the tool writes nothing into the controller):"):]
    for line in ("[JOINT_n] section of the joint that drives axis X", "COMP_FILE = x.comp", "COMP_FILE_TYPE = 0",
                 "BACKLASH of that joint is ignored", "restart LinuxCNC", "home the joint",
                 "--compensation x.comp --comp-file-type 0", "guideway verify AS_FOUND AS_LEFT"):
        assert line in text, line
    # Fanuc, one table + backlash: the parameters in the file's order, 1851, power off, reference return
    out = guideway("export", found, "--format", "fanuc", "--mode", "backlash", "--out", tmp / "f.txt", "--json")
    assert out.returncode == 0, out.stderr
    steps = json.loads(out.stdout)["load"]
    params = [ln.removeprefix("PARAM ").replace("=", " = ") for ln in (tmp / "f.txt").read_text().splitlines()
              if ln.startswith("PARAM ")]
    assert params[0].startswith("3605#0") and "enter the parameters in this order: " + ", ".join(params) in steps
    s = stats(found)
    lost_um = -float(np.mean(s["mean_up"] - s["mean_down"]))  # lost motion = -mean reversal, whole detection units
    assert any(f"1851 = {int(np.floor(lost_um + 0.5))} (detection units" in st for st in steps), steps
    joined = " | ".join(steps)
    assert joined.index("parameters") < joined.index("pitch error compensation screen") < joined.index("power off") \
        < joined.index("return the axis to the reference position")
    # Siemens: MD38000 >= the points written, MD32450 = the lost motion in mm, referencing last before measuring
    out = guideway("export", found, "--format", "siemens", "--out", tmp / "s.ini", "--json")
    steps = json.loads(out.stdout)["load"]
    points = sum(ln.startswith("$AA_ENC_COMP[") for ln in (tmp / "s.ini").read_text().splitlines())
    assert f"MD38000 MM_ENC_COMP_MAX_POINTS[0] of axis X1 >= {points}" in steps[0]
    assert any(st.startswith(f"MD32450 BACKLASH = {lost_um / 1000.0:.6f} mm") for st in steps), (steps, lost_um)
    assert steps[-2] == "reference the axis: LEC is active only after referencing"


def test_as_left_on_shifted_targets_against_leave_one_target_out(loop: dict[str, Path]) -> None:
    found, tmp = loop["found"], loop["tmp"]
    shifted = tmp / "left-shifted"
    acquire(loop["setup"], shifted, "--shift-targets", "50", "--compensation", loop["table"], "--comp-file-type", "1",
            seed=6)
    x_found = stats(found)["x"]
    setup = json.loads((shifted / "run.json").read_text())["setup"]
    expected = [t + 50.0 for t in x_found if t + 50.0 <= x_found.max()]
    assert setup["targets_mm"] == pytest.approx(expected, abs=1e-9) and setup["shift_targets_mm"] == 50.0
    out = verify_json(found, shifted)
    pts = pd.read_csv(shifted / "points.csv")
    r = (pts["reading_mm"] - pts["target_mm"]).to_numpy() * 1000.0
    between = out["between_points"]
    assert between["rms"] == pytest.approx(float(np.sqrt(np.mean(r**2))), abs=1e-6)
    assert between["max"] == pytest.approx(float(np.max(np.abs(r))), abs=1e-6) and between["points"] == len(r)
    exported = json.loads((tmp / "export.json").read_text())["residuals"]["linear"]["leave_one_target_out"]
    assert between["leave_one_target_out"]["rms"] == pytest.approx(exported["rms_um"], abs=1e-9)
    assert between["leave_one_target_out"]["max"] == pytest.approx(exported["max_um"], abs=1e-9)
    e = out["values"]["E"]
    assert e["left"] == pytest.approx(iso(stats(shifted))["E"], abs=1e-6) and e["predicted"] is None
    assert out["drift"] is None and out["targets"] == []
    res = guideway("verify", found, shifted, "--report", tmp / "shifted.html")
    assert "error left between the table's points (targets shifted by 50 mm)" in res.stdout
    assert "leave-one-target-out predicted RMS" in res.stdout
    # a shift that leaves fewer than 2 targets is refused
    one_line_error(guideway("acquire", "positioning", "--setup", loop["setup"], "--out", tmp / "r-shift", "--simulate",
                            "--auto", "--shift-targets", "1000"), "shift_targets_mm = 1000 leaves 0 target(s)")


def test_a_second_table_exported_from_an_as_left_run(loop: dict[str, Path]) -> None:
    # LEFT (measured with t1) -> export (t1 + the measured difference, CARTO) -> AGAIN with t2: the prediction takes
    # t1's correction out of LEFT's means and puts t2's in
    left, tmp = loop["left"], loop["tmp"]
    t2 = tmp / "t2.comp"
    assert guideway("export", left, "--format", "linuxcnc", "--out", t2).returncode == 0
    again = tmp / "again"
    acquire(loop["setup"], again, "--compensation", t2, "--comp-file-type", "1", seed=7)
    out = verify_json(left, again)
    assert out["table"]["exported_from_found"] is True
    assert any("CARTO" in n for n in out["notes"])
    x = stats(left)["x"]
    c1 = read_linuxcnc_comp(loop["table"].read_text(encoding="utf-8"), 1)
    c2 = read_linuxcnc_comp(t2.read_text(encoding="utf-8"), 1)
    pred = iso(stats(left, {d: c2.correction_um(x, d) - c1.correction_um(x, d) for d in (1, -1)}))
    for q in ("E", "M", "B", "A"):
        assert out["values"][q]["predicted"] == pytest.approx(pred[q], abs=2e-3), q


def test_an_export_elsewhere_from_an_unprocessed_run_is_recorded(loop: dict[str, Path]) -> None:
    run = loop["tmp"] / "found-bare"
    shutil.copytree(loop["found"], run)
    shutil.rmtree(run / "results")
    out = loop["tmp"] / "elsewhere" / "x.comp"
    res = guideway("export", run, "--format", "linuxcnc", "--out", out)
    assert res.returncode == 0, res.stderr
    (rec,) = json.loads((run / "results" / "exports.json").read_text())["exports"]
    assert rec["path"] == str(out.resolve()) and rec["sha256"] == hashlib.sha256(out.read_bytes()).hexdigest()
    assert rec["leave_one_target_out"]["rms"] > 0
