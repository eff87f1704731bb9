"""Two processes adding runs to the same catalogue at once (both starting on an empty database, with
overlapping runs): one entry per run, none lost, and each run said "added" by one process only."""

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
    # each process says what it wrote: every run added once, by one of them (the other: a copy, or unchanged)
    added = [line for out, _ in outs for line in out.splitlines() if line.startswith("added: ")]
    assert len(added) == RUNS, (len(added), outs[0][0][-300:], outs[1][0][-300:])


def test_a_run_written_by_another_process_after_our_look_is_not_said_added(catalog_url: str, tmp_path: Path,
                                                                          monkeypatch) -> None:  # noqa: ANN001
    """The race made certain: process B looks (finds nothing), process A adds the runs, B writes.  B inserted
    nothing and says so: the same directories are unchanged, copies elsewhere are copies."""
    from fleet.catalog import runs as catalog_runs
    from fleet.catalog.database import open_catalog

    a, b = tmp_path / "a", tmp_path / "b"
    for i in range(5):
        write_run(a, f"run{i}", summary=straightness_summary(5.0, 0.2))
    shutil.copytree(a / "run0", b / "run0")
    real_known = catalog_runs._known
    looks = []

    def looked_before_the_other_wrote(cat, uids):  # noqa: ANN001, ANN202
        looks.append(1)
        return {} if len(looks) == 1 else real_known(cat, uids)

    with open_catalog(catalog_url) as cat:
        assert [o.action for o in catalog_runs.add_runs(cat, sorted(a.iterdir()))] == ["added"] * 5  # process A
        monkeypatch.setattr(catalog_runs, "_known", looked_before_the_other_wrote)
        again = list(catalog_runs.add_runs(cat, sorted(a.iterdir())))  # process B, the same directories
        looks.clear()
        (copy,) = catalog_runs.add_runs(cat, [b / "run0"])  # process C, a copy of run0 elsewhere
    assert [o.action for o in again] == ["unchanged"] * 5, [o.message for o in again]
    assert all(o.message.endswith("(catalogued at the same time by another process)") for o in again)
    assert copy.action == "copy" and f"at the same time by another process at {(a / 'run0').resolve()}" in copy.message
