"""One resume path: the set-up an interrupted run continues with is rebuilt from its run.json by
``acquisition.setup.stored.resumed_setup``, for ``guideway acquire --resume`` and for the TUI's
runs browser alike (the TUI test below fails on a refusal the CLI gives only if both go through it)."""

from __future__ import annotations

import asyncio
import json
import shutil
import tomllib
from dataclasses import replace
from pathlib import Path

import pytest

from acquisition.setup.positioning import positioning_setup_from_dict
from acquisition.setup.shared_tables import DeviceSetup
from acquisition.setup.stored import resumed_setup
from acquisition.setup.straightness import load_straightness_setup
from saved_runs.errors import SetupError
from tests.cli import guideway
from tests.tui.frozen import RUNS
from tests.waiting import wait_for_app
from tui.app import GuidewayApp

ROOT = Path(__file__).resolve().parents[2]
STRAIGHTNESS = ROOT / "docs" / "setup-straightness.toml"
POSITIONING = ROOT / "docs" / "setup-positioning.toml"


def straightness_meta() -> dict:
    s = load_straightness_setup(STRAIGHTNESS)
    return {"kind": "straightness", **s.header()}


def positioning_meta() -> tuple[dict, dict]:
    source = tomllib.loads(POSITIONING.read_text())
    s = positioning_setup_from_dict(source, str(POSITIONING))
    return {"kind": "positioning", **s.header(), "setup_source": source}, source


def test_straightness_set_up_is_rebuilt_from_run_json() -> None:
    assert resumed_setup(straightness_meta(), "run") == load_straightness_setup(STRAIGHTNESS)


def test_a_given_straightness_set_up_changes_only_the_device_endpoints() -> None:
    given = load_straightness_setup(STRAIGHTNESS)
    moved = replace(given, devices=DeviceSetup(sensor_url="/dev/ttyUSB3", controller_url="modbus-tcp://10.0.0.9:502"))
    back = resumed_setup(straightness_meta(), "run", moved)
    assert back.devices.sensor_url == "/dev/ttyUSB3" and back == moved
    with pytest.raises(SetupError, match=r"^runs/a: --setup differs from the set-up the run was started with"):
        resumed_setup(straightness_meta(), "runs/a", replace(given, stations=given.stations + 1))


def test_positioning_set_up_is_rebuilt_from_its_setup_source() -> None:
    meta, source = positioning_meta()
    back = resumed_setup(meta, "run")
    assert back == positioning_setup_from_dict(source, "elsewhere")
    given = positioning_setup_from_dict({**source, "machine": "another"})
    assert resumed_setup(meta, "run", given) is given  # --setup replaces it


def test_positioning_run_without_setup_source_is_refused_in_one_line() -> None:
    meta, _ = positioning_meta()
    del meta["setup_source"]
    with pytest.raises(SetupError, match=r"^runs/p: run.json holds no setup_source; resume with --setup$"):
        resumed_setup(meta, "runs/p")


def broken_positioning_run(tmp_path: Path) -> Path:
    """A stopped positioning run whose run.json lost its setup_source."""
    run = tmp_path / "runs" / "positioning-x"
    shutil.copytree(ROOT / RUNS / "positioning-x", run)
    meta = json.loads((run / "run.json").read_text())
    del meta["setup_source"]
    meta["status"] = "aborted"
    (run / "run.json").write_text(json.dumps(meta))
    return run


def test_command_line_and_tui_give_the_same_refusal(tmp_path: Path) -> None:
    run = broken_positioning_run(tmp_path)
    res = guideway("acquire", "--resume", str(run), "--simulate", "--auto")
    assert res.returncode == 2
    assert res.stderr == f"guideway: error: {run}: run.json holds no setup_source; resume with --setup\n"

    async def main() -> list[str]:
        app = GuidewayApp(runs_dir=run.parent, start="runs", simulate=True, noise=False)
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.pause()
            await pilot.press("c")
            await wait_for_app(pilot, lambda: len(app._notifications) > 0, what="the refusal")
            return [n.message for n in app._notifications]

    assert asyncio.run(main()) == [f"cannot resume {run}: {run}: run.json holds no setup_source; resume with --setup"]
