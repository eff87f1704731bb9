"""A one-off controller fault on the very first request (while the devices are opened) is retried the
way the same fault later in the run is: the run pauses, the (simulated) technician retries, the run
completes and run.json ``faults`` lists it (issue 18)."""

from __future__ import annotations

from pathlib import Path

import pytest

from saved_runs.store.reader import load_run

from ..cli import guideway
from ..reliability import setup_text

PLANNED = {"straightness": 12, "positioning": 5 * 2 * 2}  # 12 stations; 5 targets x 2 runs x 2 directions


# request 1: the status read while the devices are opened; request 5: during the run (as before)
@pytest.mark.parametrize(("kind", "at"), [("straightness", 1), ("positioning", 1), ("straightness", 5)])
def test_a_one_off_controller_fault_is_retried_at_any_request(tmp_path: Path, kind: str, at: int) -> None:
    setup = tmp_path / "setup.toml"
    setup.write_text(setup_text(kind))
    out = tmp_path / "run"
    res = guideway("acquire", kind, "--setup", setup, "--out", out, "--simulate", "--auto", "--no-noise",
                   "--faults", f"controller:exception@{at}x1")
    assert res.returncode == 0, res.stderr
    run = load_run(out)
    assert run.meta["status"] == "complete" and len(run.points) == PLANNED[kind]
    assert len(run.meta["faults"]) == 1 and "Modbus exception 4" in run.meta["faults"][0]
