"""Compensate and measure again, in simulation, for every controller format: a simulated as-found
run → ``guideway export`` → an as-left run with ``acquire --simulate --compensation FILE``, whose
simulated controller applies the file as that controller does (processing/compensation/stage.py).

The as-left per-target mean errors must agree with the predicted residual within the
repeatability.  The prediction is computed here, independently of the code under test: the as-found
means (from points.csv, the set-up's controller reporting readings already at 20 C) plus the
correction the written file makes, read and applied by the test-side readers written from the
controllers' documented rules (tests/controller_parsers.py).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.cli import ROOT, guideway, one_line_error
from tests.controller_parsers import read_fanuc, read_linuxcnc_comp, read_siemens_lec


def setup_file(tmp_path: Path, extra: str = "", runs: int = 5) -> Path:
    text = (ROOT / "docs" / "setup-positioning.toml").read_text(encoding="utf-8")
    text = text.replace("end_mm = 1000.0", "end_mm = 400.0").replace("runs = 5 ", f"runs = {runs} ")
    # the controller reports the axis at 20 C: deviation = reading - target, no air or material model needed here
    text = text.replace("readings_compensated = false", "readings_compensated = true")
    path = tmp_path / "pos.toml"
    path.write_text(text + extra, encoding="utf-8")
    return path


def means(run_dir: Path) -> pd.DataFrame:
    """Per target and direction: mean and standard deviation of reading - target (um), from points.csv."""
    pts = pd.read_csv(run_dir / "points.csv")
    pts["e_um"] = (pts["reading_mm"] - pts["target_mm"]) * 1000.0
    return pts.groupby(["target_mm", "direction"])["e_um"].agg(["mean", "std", "count"])


def acquire(setup: Path, out: Path, *extra: str | Path, seed: int = 0) -> None:
    res = guideway("acquire", "positioning", "--setup", setup, "--out", out, "--simulate", "--auto",
                   "--seed", str(seed), *extra)
    assert res.returncode == 0, res.stderr


CASES = {
    # name: (export arguments, acquire arguments)
    "linuxcnc-type0": (("--format", "linuxcnc", "--linuxcnc-type", "0"), ("--comp-file-type", "0")),
    "linuxcnc-type1": (("--format", "linuxcnc", "--linuxcnc-type", "1"), ("--comp-file-type", "1")),
    "fanuc": (("--format", "fanuc"), ()),
    "fanuc+1851": (("--format", "fanuc", "--mode", "backlash"), ()),  # one table, the lost motion in 1851
    # bidirectional, the machine returning to the reference in − (1006#5 ZMI = 1): 3627 is on the + table
    "fanuc-reference-minus": (("--format", "fanuc", "--fanuc-reference-direction", "-1"), ()),
    "siemens": (("--format", "siemens"), ()),  # the LEC file alone: not direction dependent
    "siemens+MD32450": (("--format", "siemens"), ()),  # with the reported lost motion in MD32450
}


def predicted_correction_um(name: str, text: str, x: np.ndarray, direction: int, first_target: float,
                            lost_motion_um: float = 0.0) -> np.ndarray:
    """The correction the file makes at ``x`` approached in ``direction``, by the test-side readers;
    ``lost_motion_um``: a backlash parameter made up in the new direction after a reversal from the
    referencing direction (+)."""
    if name.startswith("linuxcnc"):
        return read_linuxcnc_comp(text, int(name[-1])).correction_um(x, direction)
    if name.startswith("fanuc"):  # export default: the reference position at the first target, 1 um detection unit
        # 1851 (whole detection units): made up in the new direction after the first reversal from the
        # reference-return direction (+), so moving - the axis is moved 1851 units further -
        backlash = -float(np.floor(lost_motion_um + 0.5)) if direction < 0 else 0.0
        reference_direction = -1 if name == "fanuc-reference-minus" else 1
        return read_fanuc(text).correction_um_anywhere(x, first_target, direction, 1.0, reference_direction) + backlash
    backlash = lost_motion_um * direction if direction < 0 else 0.0
    return read_siemens_lec(text).correction_um(x) + backlash  # LEC: not direction dependent


@pytest.mark.parametrize("name", list(CASES))
def test_as_left_run_meets_the_predicted_residual(tmp_path: Path, name: str) -> None:
    export_args, acquire_args = CASES[name]
    setup = setup_file(tmp_path)
    found, left, table = tmp_path / "found", tmp_path / "left", tmp_path / f"table-{name}"
    acquire(setup, found, seed=0)
    res = guideway("export", found, *export_args, "--out", table, "--json")
    assert res.returncode == 0, res.stderr
    exported = json.loads(res.stdout)
    m_found = means(found)
    x_all = np.array(sorted({t for t, _ in m_found.index}))
    found_up, found_dn = (m_found.xs(d, level="direction")["mean"].reindex(x_all).to_numpy() for d in (1, -1))
    lost_um = 0.0
    if name in ("siemens+MD32450", "fanuc+1851"):
        # the lost motion the export reports for MD32450 / 1851: -mean(up - down), computed here from the means
        lost_um = round(-float(np.mean(found_up - found_dn)), 3)
        setup = setup_file(tmp_path, f'\n[compensation]\nfile = "{table}"\nbacklash_um = {lost_um}\n')
        acquire(setup, left, seed=1)
    elif name == "fanuc-reference-minus":  # the simulated controller's 1006#5: the set-up's reference_direction
        setup = setup_file(tmp_path, f'\n[compensation]\nfile = "{table}"\nreference_direction = -1\n')
        acquire(setup, left, seed=1)
    else:
        acquire(setup, left, "--compensation", table, *acquire_args, seed=1)  # another seed: other noise

    m_left = means(left)
    text = table.read_text(encoding="utf-8")
    predicted = {}
    for direction in (1, -1):
        found_d = found_up if direction > 0 else found_dn
        corr = predicted_correction_um(name, text, x_all, direction, float(x_all[0]), lost_um)
        predicted[direction] = found_d + corr
    # ISO 230-2 unidirectional repeatability R = 4 s (largest over the targets) of the as-left run
    repeat = 4.0 * float(m_left["std"].max())
    worst = 0.0
    for direction in (1, -1):
        left_d = m_left.xs(direction, level="direction")["mean"].reindex(x_all).to_numpy()
        diff = left_d - predicted[direction]
        worst = max(worst, float(np.max(np.abs(diff))))
        assert np.all(np.abs(diff) <= repeat), (name, direction, diff, repeat)
    # the test can fail: uncompensated, the axis is far outside that band
    raw = float(np.max(np.abs(m_found["mean"])))
    assert raw > 3 * repeat, (raw, repeat)
    assert worst < raw / 3
    # and the export's own figure of the table as written: E of the compensated means, within R
    left_e = float(m_left["mean"].max() - m_left["mean"].min())
    pred_e = max(float(np.max(p)) for p in predicted.values()) - min(float(np.min(p)) for p in predicted.values())
    assert abs(left_e - pred_e) <= repeat
    if name != "siemens":
        assert abs(left_e - exported["table_as_written"]["E_um"]) <= repeat
    else:  # the export's figure counts on MD32450 set to the lost motion it reports: the file alone keeps B
        b_found = float(np.mean(found_up - found_dn))
        b_left = float(np.mean(m_left.xs(1, level="direction")["mean"].reindex(x_all).to_numpy()
                               - m_left.xs(-1, level="direction")["mean"].reindex(x_all).to_numpy()))
        assert abs(b_left - b_found) <= repeat and abs(b_found) > 2.0
        assert left_e - exported["table_as_written"]["E_um"] > 2.0


def test_run_json_records_the_table_and_process_shows_it(tmp_path: Path) -> None:
    setup = setup_file(tmp_path, runs=2)
    found, left, table = tmp_path / "found", tmp_path / "left", tmp_path / "x.comp"
    acquire(setup, found)
    assert json.loads((found / "run.json").read_text())["compensation"] == {"active": False}
    assert guideway("export", found, "--format", "linuxcnc", "--out", table).returncode == 0
    acquire(setup, left, "--compensation", table, "--comp-file-type", "1")
    rec = json.loads((left / "run.json").read_text())["compensation"]
    assert rec["active"] is True and rec["file"] == "x.comp" and rec["format"] == "linuxcnc"
    assert rec["comp_file_type"] == 1 and rec["applied_by"] == "simulated controller"
    assert rec["sha256"] == hashlib.sha256(table.read_bytes()).hexdigest()
    res = guideway("process", left, "--no-write")
    assert f"controller compensation: x.comp (linuxcnc COMP_FILE_TYPE 1, sha256 {rec['sha256'][:12]}" in res.stdout
    assert "controller compensation: none" in guideway("process", found, "--no-write").stdout
    res = guideway("process", left, "--no-write", "--json")
    assert json.loads(res.stdout)["controller_compensation"]["sha256"] == rec["sha256"]
    # a run from before the record existed: unknown, not none
    meta = json.loads((found / "run.json").read_text())
    del meta["compensation"]
    (found / "run.json").write_text(json.dumps(meta))
    assert "controller compensation: not recorded" in guideway("process", found, "--no-write").stdout
    assert json.loads(guideway("process", found, "--no-write", "--json").stdout)["controller_compensation"] == {
        "active": None, "recorded": False}


def test_the_set_up_table_names_the_file_relative_to_the_set_up(tmp_path: Path) -> None:
    (tmp_path / "tables").mkdir()
    table = tmp_path / "tables" / "x.comp"
    table.write_text("0.0 0.001 0.001\n400.0 0.001 0.001\n", encoding="utf-8")
    setup = setup_file(tmp_path, "\n[compensation]\nfile = \"tables/x.comp\"\nformat = \"linuxcnc\"\n"
                                 "comp_file_type = 1\n", runs=1)
    acquire(setup, tmp_path / "left")
    rec = json.loads((tmp_path / "left" / "run.json").read_text())["compensation"]
    assert rec["path"] == str(table.resolve()) and rec["active"]
    # a constant trim of +1 um (no noise would be needed to see it, but the default noise is on)
    acquire(setup_file(tmp_path, runs=1), tmp_path / "found")
    diff = means(tmp_path / "left")["mean"] - means(tmp_path / "found")["mean"]
    assert float(diff.mean()) == pytest.approx(1.0, abs=0.2)


@pytest.mark.parametrize(("table", "args", "fragments"), [
    ("0.0 0.001 0.001\n400.0 0.001 0.001\n", (), ("needs its COMP_FILE_TYPE", "--comp-file-type")),
    ("# header\n0.0 0.001 0.001\n", ("--comp-file-type", "1"), ("LinuxCNC reads no entry",)),
    ("0.0 0.001 0.001\n400.0 0.001 0.001\n", ("--compensation-format", "siemens"),
     ("reads as a linuxcnc table, not siemens",)),
    ("5000.0 0.001 0.001\n6000.0 0.001 0.001\n", ("--comp-file-type", "1"),
     ("covers 5000 … 6000 mm", "not a table of this axis")),
    ("(GUIDEWAY PITCH ERROR COMPENSATION AXIS Y)\n(REFERENCE POSITION 0 MM = POINT 0)\nPARAM 3620=0\nPARAM 3621=1\n"
     "PARAM 3622=2\nPARAM 3623=1\nPARAM 3624=100.000\nPITCH 1=1\nPITCH 2=1\n", (),
     ("a table of axis Y", "this run measures axis X")),
    ("%_N_AX_EEC_INI\n$AA_ENC_COMP[0,0,X1]=0.001\n$AA_ENC_COMP[0,1,X1]=0.001\n$AA_ENC_COMP_STEP[0,X1]=400\n"
     "$AA_ENC_COMP_MIN[0,X1]=0\n$AA_ENC_COMP_MAX[0,X1]=400\n$AA_ENC_COMP_IS_MODULO[0,X1]=1\nM17\n", (),
     ("modulo (rotary) table", "linear")),
])
def test_tables_that_do_not_fit_are_one_line_errors(tmp_path: Path, table: str, args: tuple[str, ...],
                                                    fragments: tuple[str, ...]) -> None:
    path = tmp_path / "t.txt"
    path.write_text(table, encoding="utf-8")
    res = guideway("acquire", "positioning", "--setup", setup_file(tmp_path, runs=1), "--out", tmp_path / "r",
                   "--simulate", "--auto", "--compensation", path, *args)
    one_line_error(res, *fragments)
    assert not (tmp_path / "r").exists()


def test_compensation_is_for_new_positioning_runs(tmp_path: Path) -> None:
    path = tmp_path / "t.comp"
    path.write_text("0 0 0\n1 0 0\n", encoding="utf-8")
    one_line_error(guideway("acquire", "straightness", "--setup", ROOT / "docs" / "setup-straightness.toml",
                            "--out", tmp_path / "s", "--simulate", "--auto", "--compensation", path),
                   "--compensation is for positioning runs")
    one_line_error(guideway("acquire", "--resume", tmp_path / "s", "--compensation", path),
                   "a resumed run keeps the table it started with")


def directional_means(run_dir: Path, x: np.ndarray) -> dict[int, np.ndarray]:
    m = means(run_dir)
    return {d: m.xs(d, level="direction")["mean"].reindex(x).to_numpy() for d in (1, -1)}


def test_export_from_an_as_left_run_is_the_old_table_plus_the_measured_difference(tmp_path: Path) -> None:
    setup = setup_file(tmp_path)
    found, left, again = tmp_path / "found", tmp_path / "left", tmp_path / "again"
    t1, t2 = tmp_path / "t1.comp", tmp_path / "t2.comp"
    acquire(setup, found)
    assert guideway("export", found, "--format", "linuxcnc", "--out", t1).returncode == 0
    acquire(setup, left, "--compensation", t1, "--comp-file-type", "1", seed=1)
    res = guideway("export", left, "--format", "linuxcnc", "--out", t2, "--json")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert "plus the measured difference (CARTO's rule)" in out["notes"][0]
    assert out["combined_with"]["sha256"] == hashlib.sha256(t1.read_bytes()).hexdigest()
    # trim_new = trim_old - e_left (um -> mm) at every target and direction, by the test-side reader
    x = np.array(sorted({t for t, _ in means(found).index}))
    e_left = directional_means(left, x)
    c1 = read_linuxcnc_comp(t1.read_text(), 1)
    c2 = read_linuxcnc_comp(t2.read_text(), 1)
    for d in (1, -1):
        np.testing.assert_allclose(c2.trim(x, d), c1.trim(x, d) - e_left[d] / 1000.0, atol=2e-6)
    assert np.max(np.abs(c2.trim(x, 1))) > 2e-3  # not a table of the small as-left errors alone
    # measured again with the new table: the prediction from the as-found means holds as well
    acquire(setup, again, "--compensation", t2, "--comp-file-type", "1", seed=2)
    e_found, e_again = directional_means(found, x), directional_means(again, x)
    repeat = 4.0 * float(means(again)["std"].max())
    for d in (1, -1):
        predicted = e_found[d] + c2.correction_um(x, d)
        assert np.all(np.abs(e_again[d] - predicted) <= repeat), (d, e_again[d] - predicted, repeat)


def test_export_from_an_as_left_run_refuses_to_combine_other_tables(tmp_path: Path) -> None:
    setup = setup_file(tmp_path, runs=2)
    found, left, t1 = tmp_path / "found", tmp_path / "left", tmp_path / "t1.comp"
    acquire(setup, found)
    res = guideway("export", found, "--format", "linuxcnc", "--out", t1, "--json")
    assert not any("CARTO" in n or "does not record" in n for n in json.loads(res.stdout)["notes"])
    acquire(setup, left, "--compensation", t1, "--comp-file-type", "1", seed=1)
    one_line_error(guideway("export", left, "--format", "fanuc", "--out", tmp_path / "f.txt"),
                   "measured with a linuxcnc table active", "cannot be combined", "--format linuxcnc")
    one_line_error(guideway("export", left, "--format", "csv", "--out", tmp_path / "f.csv"), "cannot be combined")
    one_line_error(guideway("export", left, "--format", "linuxcnc", "--linuxcnc-type", "0", "--out",
                            tmp_path / "t0.comp"), "COMP_FILE_TYPE 1", "--linuxcnc-type 1")
    t1.write_text(t1.read_text() + "\n", encoding="utf-8")
    one_line_error(guideway("export", left, "--format", "linuxcnc", "--out", tmp_path / "t2.comp"),
                   "is not the table that was active during the run")
    # a run from before the record: the export says it cannot know
    meta = json.loads((found / "run.json").read_text())
    del meta["compensation"]
    (found / "run.json").write_text(json.dumps(meta))
    res = guideway("export", found, "--format", "linuxcnc", "--out", tmp_path / "t3.comp", "--json")
    assert "does not record whether a compensation table was active" in json.loads(res.stdout)["notes"][0]


def test_fanuc_reference_return_minus_listing_needs_the_controller_returning_in_minus(tmp_path: Path) -> None:
    # the reference-return direction is the control's parameter 1006#5 ZMI (the set-up's reference_direction),
    # not part of the listing: a listing whose 3627 is for a return in − is refused by a controller set up for +
    setup = setup_file(tmp_path, runs=2)
    found, left, table = tmp_path / "found", tmp_path / "left", tmp_path / "f.txt"
    acquire(setup, found)
    res = guideway("export", found, "--format", "fanuc", "--fanuc-reference-direction", "-1", "--out", table)
    assert res.returncode == 0, res.stderr
    one_line_error(guideway("acquire", "positioning", "--setup", setup, "--out", left, "--simulate", "--auto",
                            "--compensation", table), "reference return in −", "reference_direction = -1")
    assert not left.exists()
    setup = setup_file(tmp_path, f'\n[compensation]\nfile = "{table}"\nreference_direction = -1\n', runs=2)
    acquire(setup, left, seed=1)
    assert json.loads((left / "run.json").read_text())["compensation"]["reference_direction"] == -1
    # a new table from this as-left run is for the same machine: its reference return in − as well
    one_line_error(guideway("export", left, "--format", "fanuc", "--out", tmp_path / "g.txt"),
                   "reference return in −", "--fanuc-reference-direction -1")
    res = guideway("export", left, "--format", "fanuc", "--fanuc-reference-direction", "-1", "--out",
                   tmp_path / "g.txt", "--json")
    assert res.returncode == 0, res.stderr
    assert "CARTO" in json.loads(res.stdout)["notes"][0]


def test_rotary_axis_with_a_modulo_lec_table(tmp_path: Path) -> None:
    # a rotary axis (deg, arcsec): the Siemens modulo table of one revolution, applied by the simulated controller
    setup = tmp_path / "rot.toml"
    setup.write_text('kind = "positioning"\n[axis]\ntype = "rotary"\nname = "C"\nstart_deg = 0.0\nend_deg = 360.0\n'
                     'runs = 5\n', encoding="utf-8")
    found, left, table = tmp_path / "found", tmp_path / "left", tmp_path / "c.ini"
    acquire(setup, found)
    assert guideway("export", found, "--format", "siemens", "--siemens-modulo", "--out", table).returncode == 0
    acquire(setup, left, "--compensation", table, seed=1)
    assert json.loads((left / "run.json").read_text())["compensation"]["table"] == "Siemens C1: LEC 9 points modulo"

    def rotary_means(run_dir: Path) -> pd.DataFrame:
        pts = pd.read_csv(run_dir / "points.csv")
        pts["e"] = (pts["reading_deg"] - pts["target_deg"]) * 3600.0
        return pts.groupby(["target_deg", "direction"])["e"].agg(["mean", "std"])

    m_found, m_left = rotary_means(found), rotary_means(left)
    x = np.array(sorted({t for t, _ in m_found.index}))
    lec = read_siemens_lec(table.read_text(encoding="utf-8"))
    assert lec.modulo
    correction_arcsec = -lec.value_mm(x) * 3600.0  # value in deg, +e: the axis moves the other way
    repeat = 4.0 * float(m_left["std"].max())
    for d in (1, -1):
        predicted = m_found.xs(d, level="direction")["mean"].reindex(x).to_numpy() + correction_arcsec
        got = m_left.xs(d, level="direction")["mean"].reindex(x).to_numpy()
        assert np.all(np.abs(got - predicted) <= repeat), (d, got - predicted, repeat)
        # the check can fail: the table's effect is larger than the band
        assert np.any(np.abs(correction_arcsec) > 1.5 * repeat)


def test_guideway_simulate_records_no_compensation(tmp_path: Path) -> None:
    res = guideway("simulate", ROOT / "docs" / "scenario-positioning.toml", "--out", tmp_path / "run")
    assert res.returncode == 0, res.stderr
    assert json.loads((tmp_path / "run" / "run.json").read_text())["compensation"] == {"active": False}


def test_what_linuxcnc_would_skip_is_printed(tmp_path: Path) -> None:
    table = tmp_path / "x.comp"
    table.write_text("100.0 0.001 0.001\n# later entries\n400.0 0.009 0.009\n", encoding="utf-8")
    res = guideway("acquire", "positioning", "--setup", setup_file(tmp_path, runs=1), "--out", tmp_path / "r",
                   "--simulate", "--auto", "--compensation", table, "--comp-file-type", "1")
    assert res.returncode == 0, res.stderr
    assert "note: LinuxCNC stops reading at line 2 (not three numbers): the 2 line(s) from there on are ignored" \
        in res.stdout
    rec = json.loads((tmp_path / "r" / "run.json").read_text())["compensation"]
    assert rec["entries"] == 1 and rec["notes"] == [
        "LinuxCNC stops reading at line 2 (not three numbers): the 2 line(s) from there on are ignored"]
