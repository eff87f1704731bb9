"""``guideway certificate``: every field ISO/IEC 17025 7.8 asks for, read back from the PDF's text (pypdf) and
checked against the run (numbers computed here from the points and the ISO 230-2 definitions), the
byte-identical repeat, and the refusals (an instrument due before the run, a run that cannot be evaluated)."""

from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pypdf
import pytest

from tests.cli import guideway, one_line_error
from tests.test_export_end_to_end import ERR_DN_UM, ERR_UP_UM, SCATTER_UM, TARGETS_MM, write_run

V1_RUN = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"
MACHINE = "立式加工中心 VMC-850 «Halle 2»"  # CJK and a few characters typst markup would interpret
LEFT_FACTOR = 0.25  # the as-left run's systematic errors: a quarter of the as-found ones

LAB = '''name = "Precision Metrology Lab GmbH"
address = "Messweg 1, 12345 Musterstadt"
accreditation = "DAkkS D-K-99999-01-00"
place = "on site, customer's hall 2"
authoriser = "Dr. Erika Muster"
authoriser_role = "Head of laboratory"
'''
CUSTOMER = '''name = "Example Machining Ltd"
address = "1 Spindle Street, Toolton"
reference = "PO 4711"
[item]
serial = "SN-778899"
model = "VMC-850"
controller = "Fanuc 0i-MF"
condition = "in service, warmed up 1 h"
'''
INSTRUMENTS = [
    {"role": "laser interferometer", "model": "XL-80", "serial": "L123456", "certificate": "CAL-2026-0815",
     "calibrated": "2026-03-02", "due": "2027-03-02"},
    {"role": "environment sensors", "model": "XC-80", "serial": "E654321", "calibrated": "2026-03-02"},
]
TABLE_SHA = "ab" * 32


def edit(run: Path, change) -> None:  # noqa: ANN001
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    change(meta)
    (run / "run.json").write_text(json.dumps(meta, indent=2, ensure_ascii=False), encoding="utf-8")


def positioning(tmp_path: Path, name: str, factor: float = 1.0, tolerance: dict | None = None,
                instruments: list | None = None, compensation: dict | None = None) -> Path:
    run = tmp_path / name
    write_run(run, err_up_um=[factor * e for e in ERR_UP_UM], err_dn_um=[factor * e for e in ERR_DN_UM])

    def change(m: dict) -> None:
        m["machine"] = MACHINE
        m["setup"]["instruments"] = INSTRUMENTS if instruments is None else instruments
        if tolerance:
            m["setup"]["tolerance"] = tolerance
        m["compensation"] = compensation or {"active": False}
    edit(run, change)
    return run


def text_pages(pdf: Path) -> list[str]:
    return [" ".join(p.extract_text().split()) for p in pypdf.PdfReader(pdf).pages]


@pytest.fixture()
def files(tmp_path: Path) -> dict[str, Path]:
    (tmp_path / "lab.toml").write_text(LAB, encoding="utf-8")
    (tmp_path / "customer.toml").write_text(CUSTOMER, encoding="utf-8")
    return {"lab": tmp_path / "lab.toml", "customer": tmp_path / "customer.toml"}


def iso_by_hand(factor: float = 1.0) -> dict[str, float]:
    """ISO 230-2 values of :func:`write_run`'s axis: run j adds SCATTER_UM[j] everywhere, so the mean per
    target and direction is the error itself and s the sample standard deviation of SCATTER_UM."""
    s = float(np.std(SCATTER_UM, ddof=1))
    up, dn = factor * np.array(ERR_UP_UM), factor * np.array(ERR_DN_UM)
    b = up - dn
    both = np.r_[up, dn]
    return {
        "A_up": float((up + 2 * s).max() - (up - 2 * s).min()),
        "A_down": float((dn + 2 * s).max() - (dn - 2 * s).min()),
        "A": float((both + 2 * s).max() - (both - 2 * s).min()),
        "E_up": float(up.max() - up.min()), "E_down": float(dn.max() - dn.min()),
        "E": float(both.max() - both.min()),
        "R_up": 4 * s, "R_down": 4 * s, "R": float(max(4 * s, (4 * s + np.abs(b)).max())),
        "M": float(((up + dn) / 2).max() - ((up + dn) / 2).min()),
        "B": float(np.abs(b).max()),  # ISO 230-2: the largest |B_i|
    }


def certificate(run: Path, out: Path, *extra: str | Path) -> list[str]:
    res = guideway("certificate", run, "--out", out, *extra)
    assert res.returncode == 0, res.stderr
    return text_pages(out)


def test_every_field_of_a_positioning_certificate_with_as_left(tmp_path: Path, files: dict[str, Path]) -> None:
    found_tol = {"A_um": round(iso_by_hand()["A"] - 0.5, 3), "E_um": 10.0}
    found = positioning(tmp_path, "found", tolerance=found_tol)
    comp = {"active": True, "file": "xcomp.comp", "format": "linuxcnc", "sha256": TABLE_SHA, "bytes": 100}
    left = positioning(tmp_path, "left", LEFT_FACTOR, tolerance=found_tol, compensation=comp)
    out = tmp_path / "cert.pdf"
    pages = certificate(found, out, "--as-left", left, "--number", "C-2026/0042", "--issue-date", "2026-11-25",
                        "--lab", files["lab"], "--customer", files["customer"])
    n = len(pages)
    assert n >= 2
    for i, page in enumerate(pages, 1):  # number and "page n of N" on every page; no SIMULATED banner
        assert "Calibration certificate No. C-2026/0042" in page and f"page {i} of {n}" in page
        assert "SIMULATED" not in page
    doc = " ".join(pages)
    assert pages[-1].rstrip().endswith("— End of certificate —") or "— End of certificate —" in pages[-1]
    for field in ("Precision Metrology Lab GmbH", "Messweg 1, 12345 Musterstadt", "DAkkS D-K-99999-01-00",
                  "on site, customer's hall 2", "Example Machining Ltd", "1 Spindle Street, Toolton", "PO 4711",
                  "Date(s) of measurement 2026-11-22", "Date of issue 2026-11-25", "Dr. Erika Muster",
                  "Head of laboratory", "Signature", MACHINE, "SN-778899", "Fanuc 0i-MF", "VMC-850",
                  "in service, warmed up 1 h", "X (linear)", f"{min(TARGETS_MM):g} to {max(TARGETS_MM):g} mm",
                  "ISO 230-2:2014", "standard test cycle", f"{len(SCATTER_UM)} ↑ / {len(SCATTER_UM)} ↓",
                  "1000.0 mm/min", "1.0 s", "in-position", "The results relate only to the item calibrated."):
        assert field in doc, field
    assert "not issued under accreditation" not in doc
    for inst in INSTRUMENTS:  # every instrument with every field; the missing due date is stated, not invented
        for value in inst.values():
            assert value in doc, value
    assert "no due date stated" in doc and "traceable to the SI" in doc
    # environment min / mean / max from the points
    pts = np.genfromtxt(found / "points.csv", delimiter=",", names=True)
    t = pts["air_temp_c"]
    assert f"air temperature (°C) {t.min():.3f} {t.mean():.3f} {t.max():.3f}" in doc
    # ISO 230-2 values per direction, each with its U (k = 2; the budget itself: test_positioning_uncertainty.py)
    iso = iso_by_hand()
    big_u = {q: b["U"] for q, b in json.loads(guideway("process", found, "--json", "--no-write").stdout)
             ["uncertainty"].items()}
    left_u = {q: b["U"] for q, b in json.loads(guideway("process", left, "--json", "--no-write").stdout)
              ["uncertainty"].items()}
    rows = (("A (accuracy)", "A_up", "A_down", "A"), ("E (systematic deviation)", "E_up", "E_down", "E"),
            ("R (repeatability)", "R_up", "R_down", "R"))
    for row, up, dn, bi in rows:
        assert (f"{row} {iso[up]:.3f} {big_u[up]:.3f} {iso[dn]:.3f} {big_u[dn]:.3f} {iso[bi]:.3f} "
                f"{big_u[bi]:.3f}") in doc, row
    assert f"M (mean deviation) {iso['M']:.3f} {big_u['M']:.3f}" in doc
    assert f"B (reversal value) {iso['B']:.3f} {big_u['B']:.3f}" in doc
    assert "k = 2" in doc and "U of these values: not evaluated" not in doc
    # the budget table, columns E M A B R: the laser's 0.5 ppm of the 400 mm span; it cancels in B and R
    assert "contribution E M A B R" in doc
    assert "laser calibration 0.200 0.200 0.200 cancels / n.a. cancels / n.a." in doc
    assert f"expanded uncertainty U = k·u_c {big_u['E']:.3f} {big_u['M']:.3f} {big_u['A']:.3f}" in doc
    assert "E_VE: not included" in doc
    # as found / as left: delta, its U = √(U_found² + U_left²) and the reduction per value; the tables
    left_iso = iso_by_hand(LEFT_FACTOR)
    delta = left_iso["E"] - iso["E"]
    reduction = (iso["E"] - left_iso["E"]) / iso["E"] * 100
    u_delta = math.hypot(big_u["E"], left_u["E"])
    assert f"E µm {iso['E']:.3f} {left_iso['E']:.3f} {delta:.3f} {u_delta:.3f} {reduction:.1f} %" in doc
    assert f"xcomp.comp (linuxcnc), SHA-256 {TABLE_SHA}" in doc
    assert "As found: compensation table active none" in doc
    # statement of conformity: the rule by name and the outcome per value (A fails by 0.5 µm, E passes)
    assert "Decision rule: simple — ILAC-G8" in doc
    assert "As found: does not conform (verdict FAIL)" in doc and "As left: conforms (verdict PASS)" in doc
    assert f"A ≤ {found_tol['A_um']:g} µm {iso['A']:.3f} µm {big_u['A']:.3f} µm does not conform" in doc
    assert f"E ≤ 10 µm {iso['E']:.3f} µm {big_u['E']:.3f} µm conforms" in doc
    assert f"A ≤ {found_tol['A_um']:g} µm {left_iso['A']:.3f} µm {left_u['A']:.3f} µm conforms" in doc  # as left
    # the data it was made from
    sha = hashlib.sha256((found / "run.json").read_bytes() + (found / "points.csv").read_bytes()).hexdigest()
    assert sha in doc.replace(" ", "") or sha in doc


def test_same_run_and_options_give_the_same_bytes(tmp_path: Path, files: dict[str, Path]) -> None:
    run = positioning(tmp_path, "run")
    a, b = tmp_path / "a.pdf", tmp_path / "b.pdf"
    certificate(run, a, "--lab", files["lab"])
    certificate(run, b, "--lab", files["lab"])
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes().startswith(b"%PDF-")
    # PDF/A-2b, dated the issue date (the run's date by default), not the clock
    assert b"<pdfaid:part>2</pdfaid:part><pdfaid:conformance>B</pdfaid:conformance>" in a.read_bytes()
    assert b"/CreationDate(D:20261122000000Z)" in a.read_bytes()
    c = tmp_path / "c.pdf"  # another issue date: other bytes (the date is in the text)
    assert "Date of issue 2026-12-01" in " ".join(certificate(run, c, "--lab", files["lab"], "--issue-date",
                                                              "2026-12-01"))
    assert c.read_bytes() != a.read_bytes()


def test_default_number_issue_date_and_not_accredited(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")
    doc = " ".join(certificate(run, tmp_path / "c.pdf"))
    sha = hashlib.sha256((run / "run.json").read_bytes() + (run / "points.csv").read_bytes()).hexdigest()
    assert f"No. GW-{sha[:10].upper()}" in doc
    assert "Date of issue 2026-11-22" in doc  # the run's (last) date of measurement
    assert "This certificate is not issued under accreditation" in doc


def test_the_evaluation_options_of_process(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")
    doc = " ".join(certificate(run, tmp_path / "c.pdf", "--edition", "ISO 230-2:2006", "--k", "3"))
    s = float(np.std(SCATTER_UM, ddof=1))
    up = np.array(ERR_UP_UM)
    assert "ISO 230-2:2006, Test code" in doc and "k = 3" in doc
    assert f"A (accuracy) {(up + 3 * s).max() - (up - 3 * s).min():.3f}" in doc
    one_line_error(guideway("certificate", run, "--out", tmp_path / "d.pdf", "--method", "patent"),
                   "--method: not an option for positioning runs")


def test_an_instrument_due_before_the_run_refuses_the_certificate(tmp_path: Path) -> None:
    late = [{**INSTRUMENTS[0], "due": "2026-11-21"}, INSTRUMENTS[1]]  # the run is of 2026-11-22
    run = positioning(tmp_path, "run", instruments=late)
    out = tmp_path / "c.pdf"
    res = guideway("certificate", run, "--out", out)
    one_line_error(res, "'laser interferometer'", "XL-80", "L123456", "2026-11-21", "2026-11-22")
    assert not out.exists()
    on_the_day = positioning(tmp_path, "run2", instruments=[{**INSTRUMENTS[0], "due": "2026-11-22"}])
    assert guideway("certificate", on_the_day, "--out", out).returncode == 0


@pytest.mark.parametrize("damage", ["in-progress", "aborted", "points", "gap"])
def test_a_run_that_cannot_be_evaluated_is_refused(tmp_path: Path, damage: str) -> None:
    run = positioning(tmp_path, "run")
    if damage in ("in-progress", "aborted"):
        edit(run, lambda m: m.update(status=damage))
        expected = f"status is {damage!r}"
    elif damage == "points":
        lines = (run / "points.csv").read_text().splitlines()
        lines[3] = lines[3].replace(",", ";")
        (run / "points.csv").write_text("\n".join(lines) + "\n")
        expected = "cannot"
    else:
        run = Path(shutil.copytree(V1_RUN, tmp_path / "gap"))
        lines = (run / "points.csv").read_text().splitlines()
        (run / "points.csv").write_text("\n".join(lines[:4] + lines[5:]) + "\n")  # station 3 missing
        expected = "incomplete run"
    out = tmp_path / "c.pdf"
    one_line_error(guideway("certificate", run, "--out", out), "cannot issue a certificate", expected)
    assert not out.exists()


def test_simulated_run_has_the_banner_on_every_page(tmp_path: Path) -> None:
    run = Path(shutil.copytree(V1_RUN, tmp_path / "run"))
    pages = certificate(run, tmp_path / "c.pdf")
    assert len(pages) >= 2
    for i, page in enumerate(pages, 1):
        assert page.startswith("SIMULATED RUN — not a measurement of a machine"), page[:80]
        assert f"page {i} of {len(pages)}" in page


def test_straightness_certificate_results_and_gum_monte_carlo(tmp_path: Path) -> None:
    run = Path(shutil.copytree(V1_RUN, tmp_path / "run"))
    res = guideway("process", run, "--json", "--no-write")
    summary = json.loads(res.stdout)
    doc = " ".join(certificate(run, tmp_path / "c.pdf"))
    mc = summary["uncertainty_um"]["straightness"]
    values = summary["straightness_um"]
    for line, name in (("minimum_zone", "minimum-zone line"), ("least_squares", "least-squares line"),
                       ("endpoint", "end-point line")):
        assert f"{name} {values[line]:.3f} {mc[line]:.3f} 2" in doc
    # GUM-S1 §8: per-station U of both methods, numerical tolerance from two significant digits of u
    u_gum = np.array(summary["uncertainty_um"]["per_station"]) / 2
    m = re.search(r"GUM and Monte Carlo (agree|do not agree) \(GUM-S1 §8\): largest difference of the per-station "
                  r"U \(k = 2\) ([0-9.]+) µm, numerical tolerance δ = ([0-9.e-]+) µm", doc)
    assert m, doc
    delta = 0.5 * 10 ** (np.floor(np.log10(u_gum.max())) - 1)
    assert float(m.group(3)) == pytest.approx(delta)
    assert (m.group(1) == "agree") == (float(m.group(2)) <= delta + 5e-5)
    assert "Gauge-block step method" in doc and "minimum zone (ISO 1101)" in doc
    assert "No calibrated instruments are recorded for this run" in doc  # a v1 run: none recorded
    assert "SIM-6DOF-IFM" in doc  # the identity the controller reported


def test_lab_and_customer_files_are_checked(tmp_path: Path) -> None:
    run = positioning(tmp_path, "run")
    (tmp_path / "lab.toml").write_text('name = "x"\nphone = "1"\n', encoding="utf-8")
    one_line_error(guideway("certificate", run, "--out", tmp_path / "c.pdf", "--lab", tmp_path / "lab.toml"),
                   "unknown key 'phone'")
    one_line_error(guideway("certificate", run, "--out", tmp_path / "c.pdf", "--issue-date", "2026-11-21"),
                   "before the measurement")
    one_line_error(guideway("certificate", run, "--out", tmp_path / "c.txt"), "*.pdf")


def test_instrument_tables_in_a_set_up(tmp_path: Path) -> None:
    import datetime
    import tomllib

    from acquisition.setup.positioning import positioning_setup_from_dict
    from acquisition.setup.straightness import straightness_setup_from_dict
    from saved_runs.errors import SetupError
    from saved_runs.store.files import write_json_atomic
    from saved_runs.store.instruments import run_instruments
    from tests.setups import straightness_setup_text

    tables = '''
[[instrument]]
role = "laser interferometer"
model = "XL-80"
serial = "L123456"
calibrated = 2026-03-02
due = 2027-03-02
'''
    data = tomllib.loads("kind = \"positioning\"\n[axis]\nend_mm = 1000.0\n" + tables)
    setup = positioning_setup_from_dict(data, "s.toml")
    recorded = [{"role": "laser interferometer", "model": "XL-80", "serial": "L123456",
                 "calibrated": "2026-03-02", "due": "2027-03-02"}]
    assert setup.to_run_setup()["instruments"] == recorded
    # run.json keeps the set-up's TOML (setup_source) with its dates as ISO text; a resume reads it back
    write_json_atomic(tmp_path / "run.json", {"setup_source": data})
    stored = json.loads((tmp_path / "run.json").read_text())["setup_source"]
    assert positioning_setup_from_dict(stored, "run.json", stored=True).instruments == recorded
    straight = tomllib.loads(straightness_setup_text(stations=5) + tables)
    assert straightness_setup_from_dict(straight, "s.toml").to_run_setup()["instruments"] == recorded
    assert run_instruments(json.loads((V1_RUN / "run.json").read_text())) == []  # an older run: none
    bad = {
        'role = "x"\ncalibrated = 2026-03-02': "model is missing",
        'role = "x"\nmodel = "y"\ndue = "2027-03-02"': "must be a TOML date",
        'role = "x"\nmodel = "y"\ndue = 2027-03-02T10:00:00': "must be a TOML date",
        'role = "x"\nmodel = "y"\nexpires = 2027-03-02': "unknown key 'expires'",
        'role = "x"\nmodel = "y"\ncalibrated = 2027-03-02\ndue = 2026-03-02': "is before calibrated",
    }
    for body, message in bad.items():
        doc = tomllib.loads("kind = \"positioning\"\n[axis]\nend_mm = 1000.0\n[[instrument]]\n" + body)
        with pytest.raises(SetupError, match=message) as exc:
            positioning_setup_from_dict(doc, "s.toml")
        assert "\n" not in str(exc.value) and str(exc.value).startswith("s.toml: [[instrument]] #1")
    assert datetime.date(2027, 3, 2).isoformat() == recorded[0]["due"]


def test_a_simulated_run_records_the_scenario_instruments(tmp_path: Path) -> None:
    docs = Path(__file__).resolve().parents[2] / "docs"
    scenario = tmp_path / "s.toml"
    scenario.write_text((docs / "scenario-positioning.toml").read_text(encoding="utf-8") + '''
[[instrument]]
role = "laser interferometer"
model = "XL-80"
due = 2020-01-01
''', encoding="utf-8")
    assert guideway("simulate", scenario, "--out", tmp_path / "run").returncode == 0
    meta = json.loads((tmp_path / "run" / "run.json").read_text(encoding="utf-8"))
    assert meta["setup"]["instruments"] == [{"role": "laser interferometer", "model": "XL-80", "due": "2020-01-01"}]
    one_line_error(guideway("certificate", tmp_path / "run", "--out", tmp_path / "c.pdf"), "due for calibration on "
                   "2020-01-01", meta["created"][:10])
