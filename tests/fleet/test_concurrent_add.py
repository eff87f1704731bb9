"""Two processes adding runs to the same catalogue at once (both starting on an empty database, with
overlapping runs): one entry per run, none lost."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

from tests.cli import spawn

from .runs import straightness_summary, write_run

RUNS = 240
OVERLAP = 80


def test_two_processes_add_at_once(catalog_url: str, tmp_path: Path) -> None:
    a, b = tmp_path / "rig-a", tmp_path / "rig-b"
    uids = []
    for i in range(RUNS):
        run = write_run(a if i < RUNS - OVERLAP // 2 else b, f"run{i:04d}", created=f"2026-01-01T00:{i // 60:02d}:"
                        f"{i % 60:02d}Z", summary=straightness_summary(5.0 + i / 100, 0.2))
        uids.append(json.loads((run / "run.json").read_text())["uid"])
    # the same runs in both folders (a rig that copied another's runs): the overlap
    for run in sorted(a.iterdir())[-OVERLAP // 2:]:
        shutil.copytree(run, b / run.name)
    procs = [spawn("catalog", "add", "--scan", folder, "--catalog", catalog_url, tmp_dir=tmp_path / f"tmp{i}",
                   stdout=subprocess.PIPE, stderr=subprocess.PIPE) for i, folder in enumerate((a, b))]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    import sqlalchemy as sa

    engine = sa.create_engine(catalog_url.replace("postgresql://", "postgresql+psycopg://"))
    with engine.connect() as conn:
        rows = conn.execute(sa.text("SELECT uid FROM guideway_runs")).scalars().all()
    engine.dispose()
    assert len(rows) == len(set(rows)) == RUNS
    assert sorted(rows) == sorted(uids)
