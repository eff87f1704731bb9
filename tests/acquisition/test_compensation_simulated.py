"""The simulated controller's compensation stage inside the simulated machine axis: the correction
is added on the command side (the axis meets its error at the corrected position), a resumed run
picks up the controller's state where the program stopped, and the table it started with."""

from __future__ import annotations

import io
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from acquisition import messages as m
from acquisition.acquire import SimOptions, run_positioning
from acquisition.operators import AutoOperator
from acquisition.setup.compensation import COMPENSATION_FORMATS
from acquisition.setup.positioning import positioning_setup_from_dict
from mocks.machine_axis import AxisErrors, MachineAxis, MachineStop
from processing.compensation import stage
from saved_runs.errors import SetupError
from saved_runs.store.reader import load_run

ROOT = Path(__file__).resolve().parents[2]


class ConstantStage:
    """A compensation stage that adds ``c`` mm to every command and records what it was told."""

    def __init__(self, c: float) -> None:
        self.c, self.told = c, []

    def move_to(self, commanded: float) -> float:
        self.told.append(commanded)
        return self.c


def test_the_axis_meets_its_error_at_the_corrected_position() -> None:
    # an error of 1 um per mm of position (slope 1000 um/m), nothing else: at 100 mm commanded with a
    # +0.1 mm correction the axis goes to 100.1 mm and its error there is 100.1 um (not 100 um)
    errors = AxisErrors(pitch=(), slope_per_m=1000.0, backlash=0.0, periodic=0.0, thermal_per_m_per_h=0.0, noise=0.0)
    stops = [MachineStop(100.0, 1, 1, 1), MachineStop(50.0, 0, 1, -1)]
    comp = ConstantStage(0.1)
    axis = MachineAxis(stops, errors=errors, compensator=comp)
    axis.cycle_start()
    assert axis.actual() == pytest.approx(100.1 + 0.1001, abs=1e-12)
    plain = MachineAxis(stops, errors=errors)
    plain.cycle_start()
    assert plain.actual() == pytest.approx(100.1, abs=1e-12)
    assert comp.told == [100.0]  # told every commanded position as the program reaches it


def example(**over: dict[str, Any]) -> dict[str, Any]:
    d = tomllib.loads((ROOT / "docs" / "setup-positioning.toml").read_text())
    for table, values in over.items():
        d.setdefault(table, {}).update(values)
    return d


class AbortAtEighth(AutoOperator):
    def __init__(self) -> None:
        super().__init__()
        self.targets = 0

    def instruct(self, msg: m.Instruct) -> str:
        if msg.key == "target":
            self.targets += 1
            if self.targets == 8:
                return "abort"
        return super().instruct(msg)


def test_a_resumed_run_keeps_the_controller_state_and_its_table(tmp_path: Path) -> None:
    table = tmp_path / "x.comp"
    # direction-dependent constant trims: +2 um moving +, -3 um moving -
    table.write_text("0.0 0.002 -0.003\n600.0 0.002 -0.003\n", encoding="utf-8")
    comp = {"file": str(table), "format": "linuxcnc", "comp_file_type": 1}
    src = example(axis={"end_mm": 500.0, "runs": 2}, trigger={"mode": "manual"}, compensation=comp,
                  environment={"readings_compensated": True})
    plain_src = {k: v for k, v in src.items() if k != "compensation"}
    s, plain = positioning_setup_from_dict(src), positioning_setup_from_dict(plain_src)
    quiet = {"stream": io.StringIO()}
    ref = run_positioning(s, tmp_path / "ref", simulate=SimOptions(seed=4, noise=False), auto=True,
                          setup_source=src, **quiet)
    base = run_positioning(plain, tmp_path / "base", simulate=SimOptions(seed=4, noise=False), auto=True,
                           setup_source=plain_src, **quiet)
    assert ref.outcome.exit_status == base.outcome.exit_status == "success"
    a, b = load_run(tmp_path / "ref").points, load_run(tmp_path / "base").points
    shift_um = (a["reading_mm"] - b["reading_mm"]).to_numpy() * 1000.0
    np.testing.assert_allclose(shift_um, np.where(a["direction"] > 0, 2.0, -3.0), atol=0.01)  # float32 registers

    out = tmp_path / "run"
    aborted = run_positioning(s, out, simulate=SimOptions(seed=4, noise=False), setup_source=src,
                              operator=AbortAtEighth(), **quiet)
    assert aborted.outcome.exit_status == "abort"
    # the table changed on disk: the run cannot go on with another table than it started with
    table.write_text("0.0 0.002 -0.004\n600.0 0.002 -0.003\n", encoding="utf-8")
    with pytest.raises(SetupError, match="no longer there as it was"):
        run_positioning(None, out, simulate=SimOptions(), auto=True, resume=True, **quiet)
    table.write_text("0.0 0.002 -0.003\n600.0 0.002 -0.003\n", encoding="utf-8")
    resumed = run_positioning(None, out, simulate=SimOptions(), auto=True, resume=True, **quiet)
    assert resumed.outcome.exit_status == "success", resumed.outcome.reason
    c = load_run(out).points
    cols = ["run", "direction", "target_index", "target_mm", "reading_mm"]
    np.testing.assert_allclose(c[cols].to_numpy(), a[cols].to_numpy(), atol=1e-9)
    assert load_run(out).meta["compensation"]["sha256"] == load_run(tmp_path / "ref").meta["compensation"]["sha256"]


def test_the_command_line_offers_the_stage_formats() -> None:
    assert COMPENSATION_FORMATS == stage.FORMATS
