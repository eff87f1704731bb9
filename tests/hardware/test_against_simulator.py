"""The hardware checks themselves, run against the simulated devices so they
cannot rot: a nested pytest with the URLs a real rig would be given."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_hardware_checks_pass_against_the_simulated_rig(sim_rig, tmp_path: Path) -> None:
    # a separate pytest (the point: the options a real rig is given); its temporary files in this test's
    # tmp_path (--basetemp), not in the session's TMPDIR, which must be left as it was found
    res = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--basetemp", str(tmp_path / "basetemp"),
         "-m", "hardware",
         "tests/hardware/test_real_devices.py",
         "--sensor-url", f"{sim_rig.sensor_protocol}:{sim_rig.sensor_url}",
         "--controller-url", sim_rig.controller_url],
        cwd=ROOT, capture_output=True, text=True, timeout=110,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    assert "4 passed" in res.stdout
