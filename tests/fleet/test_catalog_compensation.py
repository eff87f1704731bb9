"""The catalogue keeps a positioning run's compensation state (run.json ``compensation``): none, the table
file with its SHA-256, or not recorded; ``catalog list`` shows it (docs/fleet.md)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from tests.cli import guideway

from .runs import positioning_summary, straightness_summary, write_run


def with_compensation(run: Path, record: dict | None) -> Path:
    """Put ``record`` into run.json ``compensation`` (None: no key, an older run) and keep the summary fresh."""
    meta = json.loads((run / "run.json").read_text())
    if record is not None:
        meta["compensation"] = record
    (run / "run.json").write_text(json.dumps(meta), encoding="utf-8")
    later = (run / "run.json").stat().st_mtime_ns + 1_000_000
    os.utime(run / "results" / "summary.json", ns=(later, later))
    return run


def test_compensation_state_in_the_catalogue(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'cat.sqlite'}"
    sha = hashlib.sha256(b"0 0 0\n1 0 0\n").hexdigest()
    summary = positioning_summary({"E": 4.5})
    runs = {
        "none": with_compensation(write_run(tmp_path, "none", kind="positioning", created="2026-03-04T10:00:00Z",
                                            summary=summary), {"active": False}),
        "table": with_compensation(write_run(tmp_path, "table", kind="positioning", created="2026-03-03T10:00:00Z",
                                             summary=summary),
                                   {"active": True, "file": "x.comp", "path": "/t/x.comp", "format": "linuxcnc",
                                    "sha256": sha, "comp_file_type": 1}),
        "old": with_compensation(write_run(tmp_path, "old", kind="positioning", created="2026-03-02T10:00:00Z",
                                           summary=summary), None),
        "straight": write_run(tmp_path, "straight", created="2026-03-01T10:00:00Z",
                              summary=straightness_summary(6.0, 0.25)),
    }
    res = guideway("catalog", "add", *runs.values(), "--catalog", url)
    assert res.returncode == 0 and "4 added" in res.stdout, res.stdout + res.stderr
    listed = json.loads(guideway("catalog", "list", "--json", "--catalog", url).stdout)["runs"]
    by_name = {Path(r["path"]).name: r for r in listed}
    assert by_name["none"]["compensation"] == {"active": False}
    assert by_name["table"]["compensation"] == {"active": True, "file": "x.comp", "format": "linuxcnc", "sha256": sha}
    assert by_name["old"]["compensation"] == {"active": None}
    assert by_name["straight"]["compensation"] is None
    # the state is not a value (no trend of it, no column of the runs browser)
    assert all("_compensation" not in r["values"] for r in listed)
    assert set(by_name["table"]["values"]) == {"E"}
    lines = guideway("catalog", "list", "--catalog", url).stdout.splitlines()
    text = {Path(ln.split()[-1]).name: ln for ln in lines}
    assert f" x.comp {sha[:12]} " in text["table"]
    assert " none " in text["none"] and " not recorded " in text["old"]
    assert text["straight"].split()[-2] == "-"
