"""The decision rules (``--decision-rule``): ILAC-G8 simple acceptance, guarded acceptance with w = U, and
ISO 14253-1 with its three outcomes, at their boundaries; and the CLI verdict, the HTML report and the
certificate showing the same outcome for every value (one function decides: tolerance.decide)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pypdf
import pytest

from saved_runs.evaluation.options import DECISION_RULES as CLI_RULES
from saved_runs.evaluation.tolerance import DECISION_RULES, decide
from saved_runs.report.build import build_report
from tests.cli import guideway

V1_RUN = Path(__file__).resolve().parents[1] / "data" / "runs" / "v1-straightness"
WORDS = {"pass": "conforms", "fail": "does not conform", "not decidable": "not decidable"}


def by_definition(value: float, limit: float, u: float | None, rule: str) -> str:
    """The outcome from the rules' texts (ILAC-G8:09/2019 4.2.1 and 4.2.2; ISO 14253-1:2017 8.2, 8.3)."""
    if rule == "simple":
        return "pass" if value <= limit else "fail"
    if u is None:
        return "not decidable"
    if rule == "guard-band":
        return "pass" if value <= limit - u else "fail"
    if value + u <= limit:
        return "pass"
    return "fail" if value - u > limit else "not decidable"


def test_the_command_line_offers_the_rules_tolerance_knows() -> None:
    assert CLI_RULES == DECISION_RULES


# limit 10, U 0.5: every boundary exactly representable in binary
@pytest.mark.parametrize(("value", "u", "expected"), [
    (10.0, 0.5, {"simple": "pass", "guard-band": "fail", "iso14253": "not decidable"}),
    (10.0 + 2**-20, 0.5, {"simple": "fail", "guard-band": "fail", "iso14253": "not decidable"}),
    (9.5, 0.5, {"simple": "pass", "guard-band": "pass", "iso14253": "pass"}),
    (9.5 + 2**-20, 0.5, {"simple": "pass", "guard-band": "fail", "iso14253": "not decidable"}),
    (10.5, 0.5, {"simple": "fail", "guard-band": "fail", "iso14253": "not decidable"}),
    (10.5 + 2**-20, 0.5, {"simple": "fail", "guard-band": "fail", "iso14253": "fail"}),
    (3.0, None, {"simple": "pass", "guard-band": "not decidable", "iso14253": "not decidable"}),
    (float("nan"), 0.5, {"simple": "not evaluated", "guard-band": "not evaluated", "iso14253": "not evaluated"}),
])
def test_decide_at_the_boundaries(value: float, u: float | None, expected: dict[str, str]) -> None:
    for rule in DECISION_RULES:
        assert decide(value, 10.0, u, rule) == expected[rule], rule
        if value == value:  # noqa: PLR0124 - not NaN
            assert by_definition(value, 10.0, u, rule) == expected[rule]
    with pytest.raises(ValueError, match="decision rule"):
        decide(1.0, 10.0, 0.5, "strict")


def set_limit(run: Path, limit_um: float) -> None:
    meta = json.loads((run / "run.json").read_text(encoding="utf-8"))
    meta["setup"]["tolerance"] = {"straightness_um": limit_um, "reference_line": "minimum_zone"}
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")


# the limit relative to the value v and its U: just outside v + U (every rule conforms), just inside it (simple:
# conforms, guard band: not, ISO 14253-1: not decidable), just below v, just below v − U (all: not)
@pytest.mark.parametrize("where", ["v+U+e", "v+U-e", "v-e", "v-U-e"])
def test_cli_report_and_certificate_never_disagree(tmp_path: Path, where: str) -> None:
    run = Path(shutil.copytree(V1_RUN, tmp_path / "run"))
    first = json.loads(guideway("process", run, "--json", "--no-write").stdout)
    v = first["straightness_um"]["minimum_zone"]
    u = first["uncertainty_um"]["straightness"]["minimum_zone"]
    eps = 0.002  # above the rounding of the printed values, far below U
    limit = round({"v+U+e": v + u + eps, "v+U-e": v + u - eps, "v-e": v - eps, "v-U-e": v - u - eps}[where], 6)
    set_limit(run, limit)
    for rule in DECISION_RULES:
        expected = by_definition(v, limit, u, rule)
        res = guideway("process", run, "--json", "--no-write", "--decision-rule", rule)
        verdict = json.loads(res.stdout)["verdict"]
        assert (verdict["result"], verdict["decision_rule"]) == (expected, rule), rule
        text = guideway("process", run, "--no-write", "--decision-rule", rule).stdout
        assert f"verdict: {expected.upper()} (" in text and f"decision rule: {rule})" in text
        html = build_report(run, out=tmp_path / "r.html", decision_rule=rule).read_text(encoding="utf-8")
        assert f"Verdict: {expected.upper()}<" in html and f"Decision rule: {rule} —" in html
        pdf = tmp_path / "c.pdf"
        assert guideway("certificate", run, "--out", pdf, "--decision-rule", rule).returncode == 0
        doc = " ".join(" ".join(p.extract_text().split()) for p in pypdf.PdfReader(pdf).pages)
        assert f"Outcome: {WORDS[expected]} (verdict {expected.upper()})" in doc, rule
        assert f"{v:.3f} µm {u:.3f} µm {WORDS[expected]}" in doc and f"Decision rule: {rule} —" in doc


# the same four limits for the ISO 230-2 value A of a positioning run, its U from the ISO 230-2 Annex A budget
@pytest.mark.parametrize("where", ["v+U+e", "v+U-e", "v-e", "v-U-e"])
def test_positioning_values_with_their_u_under_every_rule(tmp_path: Path, where: str) -> None:
    """ISO 230-2 values carry U (processing.positioning_budget): guard-band and iso14253 decide them, and the
    CLI verdict, the HTML report and the certificate agree on every outcome."""
    from tests.saved_runs.test_certificate import iso_by_hand, positioning

    a = iso_by_hand()["A"]
    probe = positioning(tmp_path, "probe", tolerance={"A_um": 100.0})
    u = json.loads(guideway("process", probe, "--json", "--no-write").stdout)["uncertainty"]["A"]["U"]
    assert 0.5 < u < 2.0  # 2·√(0.2² + 0.46² + ...) µm over L = 400 mm (test_positioning_budget_of_a_run)
    eps = 0.002
    limit = round({"v+U+e": a + u + eps, "v+U-e": a + u - eps, "v-e": a - eps, "v-U-e": a - u - eps}[where], 6)
    run = positioning(tmp_path, "run", tolerance={"A_um": limit})
    outcomes = set()
    for rule in DECISION_RULES:
        expected = by_definition(a, limit, u, rule)
        outcomes.add(expected)
        res = guideway("process", run, "--json", "--no-write", "--decision-rule", rule)
        verdict = json.loads(res.stdout)["verdict"]
        assert (verdict["result"], verdict["checks"][0]["uncertainty"]) == (expected, pytest.approx(u)), rule
        text = guideway("process", run, "--no-write", "--decision-rule", rule).stdout
        assert f"verdict: {expected.upper()} (" in text and f"U {u:.3f} um" in text
        html = build_report(run, out=tmp_path / "r.html", decision_rule=rule).read_text(encoding="utf-8")
        assert f"Verdict: {expected.upper()}<" in html and f"<td>{u:.3f}</td>" in html
        pdf = tmp_path / "c.pdf"
        assert guideway("certificate", run, "--out", pdf, "--decision-rule", rule).returncode == 0
        doc = " ".join(" ".join(p.extract_text().split()) for p in pypdf.PdfReader(pdf).pages)
        assert f"Outcome: {WORDS[expected]} (verdict {expected.upper()})" in doc
        assert f"{a:.3f} µm {u:.3f} µm {WORDS[expected]}" in doc, rule
    assert outcomes == {"v+U+e": {"pass"}, "v+U-e": {"pass", "fail", "not decidable"},
                        "v-e": {"fail", "not decidable"}, "v-U-e": {"fail"}}[where]
