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


def test_positioning_values_without_u_under_every_rule(tmp_path: Path) -> None:
    """ISO 230-2 values carry no U: simple decides them, guard-band and iso14253 cannot (all three front ends)."""
    from tests.saved_runs.test_certificate import iso_by_hand, positioning

    a = iso_by_hand()["A"]
    run = positioning(tmp_path, "run", tolerance={"A_um": round(a + 0.001, 6)})
    for rule in DECISION_RULES:
        expected = by_definition(a, round(a + 0.001, 6), None, rule)
        res = guideway("process", run, "--json", "--no-write", "--decision-rule", rule)
        assert json.loads(res.stdout)["verdict"]["result"] == expected
        html = build_report(run, out=tmp_path / "r.html", decision_rule=rule).read_text(encoding="utf-8")
        assert f"Verdict: {expected.upper()}<" in html
        pdf = tmp_path / "c.pdf"
        assert guideway("certificate", run, "--out", pdf, "--decision-rule", rule).returncode == 0
        doc = " ".join(" ".join(p.extract_text().split()) for p in pypdf.PdfReader(pdf).pages)
        assert f"Outcome: {WORDS[expected]} (verdict {expected.upper()})" in doc
    assert by_definition(a, a + 0.001, None, "iso14253") == "not decidable"
