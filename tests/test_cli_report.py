"""``guideway report``: writes the HTML file and says where; bad input is a one-line error, exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tui.cli import main

from .cli import guideway, one_line_error
from .saved_runs.html_report import assert_self_contained

V1_RUN = Path(__file__).resolve().parent / "data" / "runs" / "v1-straightness"


def test_report_default_and_out(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = Path(shutil.copytree(V1_RUN, tmp_path / "run"))
    res = guideway("report", str(run), "--mc-trials", "0")  # the whole command line, stdout included
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"report written to {run / 'results' / 'report.html'}"
    out = tmp_path / "printed" / "axis-x.html"
    assert main(["report", str(run), "--out", str(out), "--method", "patent", "--mc-trials", "0"]) == 0
    assert capsys.readouterr().out.strip() == f"report written to {out}"
    doc = out.read_text(encoding="utf-8")
    assert assert_self_contained(doc) == 1
    assert "patent formula" in doc and f"guideway report {run} --out {out} --method patent --mc-trials 0" in doc


def test_report_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    one_line_error(guideway("report", str(tmp_path / "nope")), "no such run directory")
    run = Path(shutil.copytree(V1_RUN, tmp_path / "run"))
    one_line_error(guideway("report", str(run), "--out", str(tmp_path)), "is a directory")
    one_line_error(guideway("report", str(run), "--mc-trials", "1"), "--mc-trials")
    csv = tmp_path / "pos.csv"
    csv.write_text("run,direction,target_mm,reading_mm\n1,+1,0,0\n1,+1,10,10.001\n1,-1,10,10.002\n1,-1,0,0.001\n")
    pos = tmp_path / "pos"
    assert main(["import", "positioning", str(csv), "--out", str(pos), "--compensated"]) == 0
    one_line_error(guideway("report", str(pos), "--method", "exact"), "--method", "positioning run")
    assert not (pos / "results" / "report.html").exists()
