"""The U of each ISO 230-2 value of a positioning run (``process --json`` "uncertainty"), against the budget's
formulas written out here with the run's own numbers (ISO 230-2 Annex A, ISO/TR 230-9, standards.md §1.7, §3.5)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from acquisition.setup.positioning import positioning_setup_from_dict
from saved_runs.errors import SetupError
from tests.cli import guideway, one_line_error
from tests.saved_runs.test_certificate import edit, positioning
from tests.test_export_end_to_end import SCATTER_UM, TARGETS_MM

ROOT = Path(__file__).resolve().parents[2]


def budget_of(run: Path) -> dict:
    import json

    res = guideway("process", run, "--json", "--no-write")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)["uncertainty"]


def test_the_budget_of_a_run_with_the_default_figures(tmp_path: Path) -> None:
    # the run: 20 °C, 1013.25 hPa, 50 %RH, material 20 °C, α = 11.5 ppm/K, targets 0 … 400 mm, 5 runs
    b = budget_of(positioning(tmp_path, "run"))
    L_um = (max(TARGETS_MM) - min(TARGETS_MM)) * 1000.0  # noqa: N806
    e = b["E"]["contributions"]
    assert b["E"]["length_mm"] == 400.0
    assert e["laser calibration"] == pytest.approx(0.5e-6 * L_um)                     # 0.2 µm
    assert e["material temperature"] == pytest.approx(11.5e-6 * 0.1 * L_um)           # 0.46 µm
    assert e["expansion coefficient"] == 0.0                                            # |T − 20 °C| = 0
    assert e["air index (air temperature)"] == pytest.approx(0.955e-6 * 0.1 * L_um, rel=0.01)
    assert e["air index (pressure)"] == pytest.approx(0.268e-6 * 0.5 * L_um, rel=0.01)
    assert e["air index (humidity)"] == pytest.approx(0.0085e-6 * 3.0 * L_um, rel=0.04)
    assert e["misalignment (cosine)"] == pytest.approx(L_um * 1e-4**2 / (2 * math.sqrt(12)))
    # E = max − min of the means: x̄↓ at 302.5 mm (4.0 µm) and x̄↑ at 400 mm (−1.5 µm), each mean with
    # u = s/√5, s the sample standard deviation of the runs' scatter: u(E) = √2 s/√5 (Monte Carlo, ±15 %)
    s = float(np.std(SCATTER_UM, ddof=1))
    assert e["repeatability of the value"] == pytest.approx(math.sqrt(2) * s / math.sqrt(5), rel=0.15)
    assert "environmental variation E_VE" not in e
    assert any("E_VE: not included" in n for n in b["E"]["notes"])
    u_c = math.sqrt(sum(v**2 for v in e.values()))
    assert (b["E"]["u_c"], b["E"]["U"], b["E"]["k"]) == (pytest.approx(u_c), pytest.approx(2 * u_c), 2.0)
    # B and R: laser, index, temperature and cosine are common to both directions and cancel
    for q in ("B", "R", "R_up", "R_down"):
        assert set(b[q]["contributions"]) == {"repeatability of the value"}, q
        assert b[q]["U"] == pytest.approx(2 * b[q]["contributions"]["repeatability of the value"])
    for q in ("A", "A_up", "A_down", "E_up", "E_down", "M"):
        assert b[q]["contributions"]["laser calibration"] == pytest.approx(0.2), q


def test_the_set_up_figures_and_a_drift_check_and_k(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")

    def change(m: dict) -> None:
        m["setup"]["uncertainty"] = {"laser_ppm": 1.0, "material_temp_k": 0.2, "drift": 0.6}
    edit(run, change)
    import json

    res = guideway("process", run, "--json", "--no-write", "--k", "3")
    b = json.loads(res.stdout)["uncertainty"]
    e = b["E"]["contributions"]
    assert e["laser calibration"] == pytest.approx(1.0e-6 * 400e3)
    assert e["material temperature"] == pytest.approx(11.5e-6 * 0.2 * 400e3)
    assert e["environmental variation E_VE"] == pytest.approx(0.6 / (2 * math.sqrt(3)))
    assert b["B"]["contributions"]["environmental variation E_VE"] == pytest.approx(0.6 / (2 * math.sqrt(3)))
    assert b["E"]["U"] == pytest.approx(3 * math.sqrt(sum(v**2 for v in e.values()))) and b["E"]["k"] == 3.0


def test_a_material_away_from_20_c_adds_the_u_of_alpha(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")
    pts = (run / "points.csv").read_text(encoding="utf-8").splitlines()
    head = pts[0].split(",")
    col = head.index("material_temp_c")
    rows = [pts[0]] + [",".join(c if i != col else "21.5" for i, c in enumerate(r.split(","))) for r in pts[1:]]
    (run / "points.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    e = budget_of(run)["E"]["contributions"]
    assert e["expansion coefficient"] == pytest.approx(400e3 * 1.5 * 1.0e-6)  # L ΔT u(α) = 0.6 µm


def test_a_bad_uncertainty_table_is_refused_with_one_line(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")
    edit(run, lambda m: m["setup"].__setitem__("uncertainty", {"laser_ppm": -1}))
    one_line_error(guideway("process", run, "--json", "--no-write"), "laser_ppm must be a number >= 0")
    d = tomllib.loads((ROOT / "docs" / "setup-positioning.toml").read_text(encoding="utf-8"))
    d["uncertainty"] = {"laser": 0.5}
    with pytest.raises(SetupError, match="unknown key 'laser' in \\[uncertainty\\]"):
        positioning_setup_from_dict(d)
    d["uncertainty"] = {"laser_ppm": 0.3}
    assert positioning_setup_from_dict(d).to_run_setup()["uncertainty"] == {"laser_ppm": 0.3}


def test_a_rotary_run_has_only_its_repeatability_in_arcsec(tmp_path: Path) -> None:
    # two runs, 0° and 90°, deviations (arcsec) up 0°: 1, 2; 90°: 3, 4; down 0°: 0, 1; 90°: 5, 6
    devs = {(1, 1, 0): 1, (2, 1, 0): 2, (1, 1, 90): 3, (2, 1, 90): 4,
            (1, -1, 0): 0, (2, -1, 0): 1, (1, -1, 90): 5, (2, -1, 90): 6}
    lines = ["run,direction,target_deg,reading_deg"]
    lines += [f"{r},{d:+d},{t},{t + dev / 3600.0:.10f}" for (r, d, t), dev in devs.items()]
    csv = tmp_path / "rot.csv"
    csv.write_text("\n".join(lines) + "\n", encoding="utf-8")
    run = tmp_path / "run"
    res = guideway("import", "positioning", csv, "--out", run, "--axis-type", "rotary", "--axis", "C")
    assert res.returncode == 0, res.stderr
    b = budget_of(run)
    for q in ("E", "A", "B", "R"):
        assert b[q]["unit"] == "arcsec" and b[q]["length_mm"] is None, q
        assert set(b[q]["contributions"]) == {"repeatability of the value"}, q
        assert b[q]["U"] == pytest.approx(2 * b[q]["contributions"]["repeatability of the value"]), q
