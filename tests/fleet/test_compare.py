"""``guideway compare``: two runs made by ``guideway simulate`` with a known difference between them.

Every expected number is computed here from first principles: positioning from the two points.csv files
(readings already compensated, so the deviation is reading - target) with the formulas of docs/compare.md;
straightness from each run's ``process --json`` profile (the evaluation compare promises to share) with
numpy's own least-squares fit.  The change must recover the effect put into run B within its U."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.cli import guideway, one_line_error

TARGETS = [0.0, 98.7, 203.4, 302.6, 398.4, 500.0, 603.1, 701.5, 797.3, 902.6, 1000.0]
SCALE_PPM = 8.0  # the linear error added to run B: e = ppm * P * 1e-3 um (P in mm)


def positioning_scenario(extra: str = "", targets: list[float] = TARGETS, axis: str = "X") -> str:
    return f"""kind = "positioning"
machine = "mill 7"
[axis]
name = "{axis}"
targets_mm = {targets}
runs = 5
cycle = "linear"
overrun_mm = 5.0
feed_mm_min = 2000.0
[trigger]
dwell_s = 2.0
[environment]
readings_compensated = true
[noise]
reading_um = 0.3
[[effect]]
type = "backlash"
reversal_um = -2.0
[[effect]]
type = "periodic"
amplitude_um = 0.9
wavelength_mm = 310.0
phase_rad = -0.4
{extra}"""


SCALE_EFFECT = f'[[effect]]\ntype = "linear_scale"\nppm = {SCALE_PPM}\n'


def simulate(tmp: Path, name: str, scenario: str, seed: int) -> Path:
    (tmp / f"{name}.toml").write_text(scenario)
    res = guideway("simulate", tmp / f"{name}.toml", "--out", tmp / name, "--seed", str(seed))
    assert res.returncode == 0, res.stderr
    return tmp / name


@pytest.fixture(scope="module")
def pos(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("compare-pos")
    return simulate(tmp, "before", positioning_scenario(), 1), simulate(tmp, "after",
                                                                        positioning_scenario(SCALE_EFFECT), 2)


def deviations_from_points(run: Path) -> dict[tuple[float, int], list[float]]:
    """(target mm, direction) -> the deviations reading - target (um) of every approach, from points.csv."""
    out: dict[tuple[float, int], list[float]] = {}
    with (run / "points.csv").open() as f:
        for row in csv.DictReader(f):
            key = (float(row["target_mm"]), int(row["direction"]))
            out.setdefault(key, []).append((float(row["reading_mm"]) - float(row["target_mm"])) * 1000.0)
    return out


def mean_s_n(x: list[float]) -> tuple[float, float, int]:
    n = len(x)
    m = sum(x) / n
    return m, math.sqrt(sum((v - m) ** 2 for v in x) / (n - 1)), n


def compare_json(*args: object) -> dict:
    res = guideway("compare", *args, "--json")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_positioning_change_and_its_uncertainty_from_the_points(pos: tuple[Path, Path]) -> None:
    a, b = pos
    out = compare_json(a, b)
    da, db = deviations_from_points(a), deviations_from_points(b)
    assert len(out["targets"]) == len(da) == 2 * len(TARGETS)
    for row in out["targets"]:
        key = (row["target_mm"], 1 if row["direction"] == "+" else -1)
        ma, sa, na = mean_s_n(da[key])
        mb, sb, nb = mean_s_n(db[key])
        big_u = 2.0 * math.sqrt(sa**2 / na + sb**2 / nb)  # k = 2, u of a mean = s / sqrt(n), in quadrature
        assert row["a_um"] == pytest.approx(ma, abs=1e-9)
        assert row["b_um"] == pytest.approx(mb, abs=1e-9)
        assert row["change_um"] == pytest.approx(mb - ma, abs=1e-9)
        assert row["u_um"] == pytest.approx(big_u, rel=1e-9)
        assert row["significant"] is (abs(mb - ma) > big_u)
        assert (row["n_a"], row["n_b"], row["only_in"]) == (5, 5, None)


def test_positioning_change_recovers_the_scale_error_added(pos: tuple[Path, Path]) -> None:
    out = compare_json(*pos)
    z = []
    for row in out["targets"]:
        expected = SCALE_PPM * row["target_mm"] * 1e-3
        z.append((row["change_um"] - expected) / (row["u_um"] / 2.0))
        if expected > 2.0 * row["u_um"]:  # the effect stands well clear of the uncertainty: it must be seen
            assert row["significant"] is True, row
    z = np.array(z)
    # (change - truth) / u is about N(0, 1) (t with ~8 degrees of freedom): none far out, the spread near 1
    assert np.all(np.abs(z) < 5.0), z
    assert 0.3 < np.mean(z**2) < 3.0, z
    assert sum(r["significant"] is False for r in out["targets"]) >= 2  # the targets near 0 mm hardly changed


def test_iso_values_side_by_side_from_the_points(pos: tuple[Path, Path]) -> None:
    a, b = pos
    out = compare_json(a, b)
    for name, run in (("a", a), ("b", b)):
        means = [mean_s_n(v)[0] for v in deviations_from_points(run).values()]
        e = max(means) - min(means)  # ISO 230-2 E: over both directions, max - min of the mean deviations
        assert out["values"]["E"][name] == pytest.approx(e, abs=1e-9)
    e_a, e_b = out["values"]["E"]["a"], out["values"]["E"]["b"]
    assert out["values"]["E"]["change_pct"] == pytest.approx(100.0 * (e_b - e_a) / e_a, rel=1e-12)
    assert e_b - e_a > 5.0  # 8 ppm over 1000 mm widens E by about 8 um


def test_json_schema(pos: tuple[Path, Path]) -> None:
    out = compare_json(*pos)
    assert {"a", "b", "targets", "values", "kind", "unit", "k", "notes"} <= set(out)
    assert out["kind"] == "positioning" and out["unit"] == "um" and out["k"] == 2.0
    assert {"path", "uid", "machine", "axis", "created", "status", "simulated"} <= set(out["a"])
    assert out["a"]["path"] == str(pos[0]) and out["b"]["axis"] == "X"
    assert {"target_mm", "direction", "a_um", "b_um", "change_um", "u_um", "significant"} <= set(out["targets"][0])
    assert {r["direction"] for r in out["targets"]} == {"+", "-"}
    assert set(out["values"]) == {"B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M", "A_up",
                                  "A_down", "A"}
    assert set(out["values"]["E"]) >= {"a", "b", "change_pct"}


def test_runs_are_not_written(pos: tuple[Path, Path]) -> None:
    before = {p: sorted(x.name for x in p.iterdir()) for p in pos}
    compare_json(*pos)
    assert {p: sorted(x.name for x in p.iterdir()) for p in pos} == before
    assert not (pos[0] / "results").exists()


def test_targets_in_one_run_only_are_listed(tmp_path: Path, pos: tuple[Path, Path]) -> None:
    b = simulate(tmp_path, "more", positioning_scenario(targets=[*TARGETS, 1100.0]), 3)
    out = compare_json(pos[0], b)
    extra = [r for r in out["targets"] if r["target_mm"] == 1100.0]
    assert [(r["direction"], r["only_in"], r["a_um"], r["change_um"], r["u_um"], r["significant"]) for r in extra] \
        == [("+", "b", None, None, None, None), ("-", "b", None, None, None, None)]
    assert extra[0]["b_um"] is not None
    assert len(out["targets"]) == 2 * len(TARGETS) + 2
    assert any("run B only" in n and "1100" in n for n in out["notes"])
    text = guideway("compare", pos[0], b)
    assert text.returncode == 0 and "only in B" in text.stdout


def test_runs_without_a_common_target_are_refused(tmp_path: Path, pos: tuple[Path, Path]) -> None:
    b = simulate(tmp_path, "shifted", positioning_scenario(targets=[t + 10.0 for t in TARGETS]), 3)
    one_line_error(guideway("compare", pos[0], b), "share no target", "0 … 1000 mm", "10 … 1010 mm")


def test_mismatched_kinds_are_refused(pos: tuple[Path, Path], straight: tuple[Path, Path]) -> None:
    one_line_error(guideway("compare", pos[0], straight[0]), str(pos[0]), "positioning", "straightness",
                   "same kind")


def test_different_axes_are_refused_unless_asked(tmp_path: Path, pos: tuple[Path, Path]) -> None:
    y = simulate(tmp_path, "y", positioning_scenario(axis="Y"), 1)
    one_line_error(guideway("compare", pos[0], y), "axis 'X'", "axis 'Y'", "--any-axis")
    out = compare_json(pos[0], y, "--any-axis")
    assert any("different axes" in n for n in out["notes"])


def test_an_option_of_the_other_kind_is_refused(pos: tuple[Path, Path]) -> None:
    one_line_error(guideway("compare", *pos, "--method", "patent"), "--method", "positioning")


def test_report_is_written_and_escaped(tmp_path: Path, pos: tuple[Path, Path]) -> None:
    a = tmp_path / "a"
    a.mkdir()
    for f in ("run.json", "points.csv"):
        (a / f).write_bytes((pos[0] / f).read_bytes())
    meta = json.loads((a / "run.json").read_text())
    meta["machine"] = "<script>alert(1)</script> & co"
    (a / "run.json").write_text(json.dumps(meta))
    report = tmp_path / "out" / "compare.html"
    res = guideway("compare", a, pos[1], "--report", report)
    assert res.returncode == 0, res.stderr
    html = report.read_text()
    assert "<script>" not in html and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; co" in html
    assert html.count("data:image/png;base64,") == 1  # the overlay
    assert "ISO 230-2 values" in html and "Per target and direction" in html and "SIMULATED" in html
    assert f"report written to {report}" in res.stdout
    one_line_error(guideway("compare", a, pos[1], "--report", tmp_path), "is a directory")


# -- straightness --------------------------------------------------------------------------------------------

SENSOR_X_MM = 150.0  # the sample point on the simulated block: the first station samples the surface here
ADDED_WAVE = (1.0, 300.0, 0.0)  # amplitude um, wavelength mm, phase rad: the change put into run B


def straightness_scenario(waves: list[tuple[float, float, float]]) -> str:
    return f"""kind = "straightness"
[block]
length_mm = 50.0
stations = 17
samples_per_reading = 5
return_pass = false
[geometry]
mirror_mm = [50.0, 110.0, 0.0]
sensor_mm = [150.0, 0.0, 40.0]
[surface]
waves = {[list(w) for w in waves]}
slope_urad = 6.0
"""


@pytest.fixture(scope="module")
def straight(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("compare-str")
    base = [(2.5, 380.0, 0.7)]
    return (simulate(tmp, "before", straightness_scenario(base), 1),
            simulate(tmp, "after", straightness_scenario([*base, ADDED_WAVE]), 2))


def residual_u(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """u of the residuals r = h - X beta (beta by least squares, X = [1, x]) of heights with independent
    uncertainties u: the covariance (I - P) diag(u^2) (I - P)^T with the projection P = X pinv(X)."""
    design = np.column_stack([np.ones_like(x), x])
    m = np.eye(len(x)) - design @ np.linalg.pinv(design)
    return np.sqrt(np.diag(m @ np.diag(u**2) @ m.T))


def processed(run: Path) -> dict:
    res = guideway("process", run, "--json", "--no-write", "--mc-trials", "2000")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_straightness_change_against_each_least_squares_line(straight: tuple[Path, Path]) -> None:
    out = compare_json(*straight, "--mc-trials", "2000")
    pa, pb = processed(straight[0]), processed(straight[1])
    x = np.array([p["x_mm"] for p in pa["profile"]])
    ha = np.array([p["height_um"] for p in pa["profile"]])
    hb = np.array([p["height_um"] for p in pb["profile"]])
    xb = np.array([p["x_mm"] for p in pb["profile"]])
    ra = ha - np.polyval(np.polyfit(x, ha, 1), x)
    rb = hb - np.polyval(np.polyfit(xb, hb, 1), xb)
    ua = residual_u(x, np.array(pa["uncertainty_um"]["per_station"]) / 2.0)  # process: U (k = 2) per station
    ub = residual_u(xb, np.array(pb["uncertainty_um"]["per_station"]) / 2.0)
    big_u = 2.0 * np.sqrt(ua**2 + ub**2)
    rows = out["stations"]
    assert [r["station"] for r in rows] == list(range(17))
    np.testing.assert_allclose([r["a_um"] for r in rows], ra, atol=1e-9)
    np.testing.assert_allclose([r["b_um"] for r in rows], rb, atol=1e-9)
    np.testing.assert_allclose([r["change_um"] for r in rows], rb - ra, atol=1e-9)
    np.testing.assert_allclose([r["u_um"] for r in rows], big_u, rtol=1e-9)
    assert [r["significant"] for r in rows] == [bool(v) for v in np.abs(rb - ra) > big_u]
    for line, v in out["values"].items():
        sa, sb = pa["straightness_um"][line], pb["straightness_um"][line]
        assert (v["a"], v["b"]) == (pytest.approx(sa, abs=1e-12), pytest.approx(sb, abs=1e-12))
        assert v["change_pct"] == pytest.approx(100.0 * (sb - sa) / sa, rel=1e-9)
    assert set(out["values"]) == {"endpoint", "least_squares", "minimum_zone"}
    assert {"station", "x_mm", "a_um", "b_um", "change_um", "u_um", "significant"} <= set(rows[0])
    assert "targets" not in out and out["reference_line"]["name"] == "least_squares"


def test_straightness_change_recovers_the_wave_added(straight: tuple[Path, Path]) -> None:
    out = compare_json(*straight, "--mc-trials", "0")
    x = np.array([r["x_mm"] for r in out["stations"]])
    amp, wavelength, phase = ADDED_WAVE
    added = amp * np.sin(2 * math.pi * (SENSOR_X_MM + x) / wavelength + phase)
    expected = added - np.polyval(np.polyfit(x, added, 1), x)  # its own least-squares line removed
    change = np.array([r["change_um"] for r in out["stations"]])
    big_u = np.array([r["u_um"] for r in out["stations"]])
    assert np.all(np.abs(change - expected) <= big_u), (change - expected, big_u)
    assert sum(r["significant"] for r in out["stations"]) >= 4  # a 1 um wave against U of about 0.4 um
    assert all(v["U"] is None for v in out["values"].values())  # Monte Carlo off: no U of the values


def test_straightness_report_and_text(tmp_path: Path, straight: tuple[Path, Path]) -> None:
    res = guideway("compare", *straight, "--mc-trials", "0", "--report", tmp_path / "s.html")
    assert res.returncode == 0, res.stderr
    assert "per station" in res.stdout and "minimum_zone" in res.stdout
    html = (tmp_path / "s.html").read_text()
    assert "Straightness values" in html and "Per station" in html and html.count("data:image/png") == 1


def test_straightness_runs_with_different_blocks_are_refused(tmp_path: Path, straight: tuple[Path, Path]) -> None:
    other = simulate(tmp_path, "long", straightness_scenario([]).replace("length_mm = 50.0", "length_mm = 100.0"), 1)
    one_line_error(guideway("compare", straight[0], other), "50 mm block", "100 mm block")


# -- hand data through guideway import: a rotary axis, a single run ------------------------------------------

def import_run(tmp: Path, name: str, rows: list[tuple[int, int, float, float]], *extra: str) -> Path:
    """A run imported from (run, direction, target, deviation) rows: rotary targets in deg, deviations in arcsec."""
    text = "run,direction,target_deg,reading_deg\n" + "".join(
        f"{r},{d},{t!r},{t + dev / 3600.0!r}\n" for r, d, t, dev in rows)
    (tmp / f"{name}.csv").write_text(text)
    res = guideway("import", "positioning", tmp / f"{name}.csv", "--out", tmp / name, "--axis-type", "rotary",
                   "--compensated", "--axis", "C", *extra)
    assert res.returncode == 0, res.stderr
    return tmp / name


def test_rotary_axis_in_arcsec(tmp_path: Path) -> None:
    # 3 approaches per direction at 0, 90, 180, 270 deg; B turns 1.5 arcsec further at 180 deg moving +
    dev_a = {1: [1.0, 2.0, 0.0], -1: [-1.0, -2.0, -1.5]}
    targets = (0.0, 90.0, 180.0, 270.0)
    rows_a = [(r + 1, d, t, dev_a[d][r]) for t in targets for d in (1, -1) for r in range(3)]
    rows_b = [(r, d, t, v + (1.5 if (t, d) == (180.0, 1) else 0.0)) for r, d, t, v in rows_a]
    out = compare_json(import_run(tmp_path, "a", rows_a), import_run(tmp_path, "b", rows_b))
    assert out["unit"] == "arcsec" and out["target_unit"] == "deg"
    row = next(r for r in out["targets"] if r["target_deg"] == 180.0 and r["direction"] == "+")
    assert {"a_arcsec", "b_arcsec", "change_arcsec", "u_arcsec"} <= set(row) and "a_um" not in row
    s = math.sqrt(((1.0 - 1.0) ** 2 + (2.0 - 1.0) ** 2 + (0.0 - 1.0) ** 2) / 2)  # s of 1, 2, 0 = 1
    assert row["change_arcsec"] == pytest.approx(1.5, abs=1e-6)
    assert row["u_arcsec"] == pytest.approx(2.0 * math.sqrt(2 * s**2 / 3), rel=1e-6)  # 1.633
    assert row["significant"] is False  # 1.5 < 1.633: the change is not proven by 3 approaches each
    other = [r for r in out["targets"] if r is not row]
    assert all(r["change_arcsec"] == pytest.approx(0.0, abs=1e-6) and r["significant"] is False for r in other)


def test_a_single_run_has_no_uncertainty_of_its_means(tmp_path: Path) -> None:
    rows = [(1, d, t, 0.5 * d) for t in (0.0, 120.0, 240.0) for d in (1, -1)]
    out = compare_json(import_run(tmp_path, "a", rows), import_run(tmp_path, "b", [(r, d, t, v + 3.0)
                                                                                    for r, d, t, v in rows]))
    assert all(r["change_arcsec"] == pytest.approx(3.0, abs=1e-6) for r in out["targets"])
    assert all(r["u_arcsec"] is None and r["significant"] is None for r in out["targets"])
    assert any("fewer than 2 approaches" in n for n in out["notes"])


def test_stations_of_one_run_only_are_listed_and_left_out_of_the_line(tmp_path: Path,
                                                                       straight: tuple[Path, Path]) -> None:
    short = simulate(tmp_path, "short", straightness_scenario([(2.5, 380.0, 0.7)]).replace("stations = 17",
                                                                                            "stations = 14"), 3)
    out = compare_json(straight[0], short, "--mc-trials", "0")
    rows = out["stations"]
    assert [(r["station"], r["only_in"]) for r in rows[13:]] == [(13, None), (14, "a"), (15, "a"), (16, "a")]
    assert all(r["change_um"] is None and r["b_um"] is None and r["significant"] is None for r in rows[14:])
    pa = processed(straight[0])
    x = np.array([p["x_mm"] for p in pa["profile"]])
    h = np.array([p["height_um"] for p in pa["profile"]])
    line = np.polyfit(x[:14], h[:14], 1)  # A's line over the 14 stations both runs measured
    np.testing.assert_allclose([r["a_um"] for r in rows], h - np.polyval(line, x), atol=1e-9)
    assert any("run A only: 14, 15, 16" in n for n in out["notes"])
