"""NOT EVALUATED says why in plain words (issue 25), on the Results screen and in ``guideway process``.

The reason is derived here from the run itself: a positioning run with one approach per direction has no
standard deviation, so ISO 230-2 gives no R and no A (s needs 2 or more approaches)."""

from __future__ import annotations

import asyncio
import csv
import json
from pathlib import Path
from typing import Any

from tests.cli import guideway
from tests.tui.sessions import widget_text
from tests.tui.test_results_screen import copy_run, on_results, set_tolerance


def keep_run_one(run: Path) -> int:
    """Drop every approach but run 1 from points.csv (and say so in run.json); returns the approaches kept
    per direction at each target (counted from the file)."""
    path = run / "points.csv"
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    head, data = rows[0], [r for r in rows[1:] if r[0] == "1"]
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows([head, *data])
    meta = json.loads((run / "run.json").read_text())
    meta["setup"]["runs"] = 1
    meta["points"] = len(data)
    (run / "run.json").write_text(json.dumps(meta, indent=2))
    per = {}
    for r in data:
        key = (r[head.index("direction")], r[head.index("target_index")])
        per[key] = per.get(key, 0) + 1
    return max(per.values())


def test_one_run_per_direction_says_a_and_r_need_two(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "positioning-x")
    runs = keep_run_one(run)
    assert runs == 1
    set_tolerance(run, {"A_um": 50.0, "R_um": 50.0})
    reason = f"{runs} run per direction, A and R need 2+"
    res = guideway("process", run, "--no-write")
    assert res.returncode == 0, res.stderr
    assert f"verdict: NOT EVALUATED: {reason}" in res.stdout
    obj = json.loads(guideway("process", run, "--no-write", "--json").stdout)
    assert obj["verdict"]["result"] == "not evaluated" and obj["verdict"]["reason"] == reason
    text = on_results(run, lambda app, pilot: asyncio.sleep(0, widget_text(app, "#verdict-text")))
    assert text.splitlines()[0] == f"NOT EVALUATED: {reason}"


def test_an_incomplete_straightness_run_says_so(tmp_path: Path) -> None:
    run = copy_run(tmp_path, "straightness-bed")
    set_tolerance(run, {"straightness_um": 1000.0, "reference_line": "minimum_zone"})
    path = run / "points.csv"
    rows = path.read_text().splitlines()
    station = 4
    head = rows[0].split(",")
    kept = [r for r in rows[1:] if r.split(",")[head.index("station")] != str(station)]
    path.write_text("\n".join([rows[0], *kept]) + "\n")
    res = guideway("process", run, "--no-write", "--mc-trials", "0")
    assert res.returncode == 0, res.stderr
    verdict = next(ln for ln in res.stdout.splitlines() if "verdict:" in ln)
    # (the run has a return pass: station 4 is missing in both passes)
    assert verdict.startswith(f"verdict: NOT EVALUATED: run incomplete: stations {station}, {station} (return pass)")

    async def check(app: Any, pilot: Any) -> str:
        return widget_text(app, "#verdict-text")

    first = on_results(run, check).splitlines()[0]
    assert first.startswith(f"NOT EVALUATED: run incomplete: stations {station}, {station} (return pass)")
