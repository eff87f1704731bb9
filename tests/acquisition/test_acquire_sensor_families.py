"""``acquire straightness --simulate`` with a set-up naming each sensor family:
the simulated run uses that family at the set-up's line rate (or the family's
own when the set-up gives none), with the set-up's sign, and the profile comes
out right."""

from __future__ import annotations

import io
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from acquisition.acquire import SimOptions, run_straightness
from acquisition.setup.straightness import straightness_setup_from_dict
from saved_runs.evaluation.evaluate import process_run_dir

from ..setups import straightness_setup_text
from ..test_demo_end_to_end import ls_residual, truth_heights_um
from ..test_demo_sensor_families import OTHER_CHANNELS_UM, STEP_MM, residual_gain


def setup_text(protocol: str, baud: int | None, sign: str) -> str:
    text = straightness_setup_text(stations=5, samples=1)
    text = text.replace('protocol = "keyence-lkg"', f'protocol = "{protocol}"')
    text = text.replace('sensor_sign = "height"', f'sensor_sign = "{sign}"')
    assert f'protocol = "{protocol}"' in text and f'"{sign}"' in text
    text, n = re.subn(r"(?m)^baud = 115200.*\n", f"baud = {baud}\n" if baud else "", text)
    assert n == 1
    return text


@pytest.mark.parametrize(
    ("protocol", "baud", "sign", "line_rate"),
    [("me-ild1420", None, "gap", 921600),  # no baud in the set-up: the family's own rate
     ("me-ild1420", None, "height", 921600),  # a set-up with the other sign is honoured
     ("panasonic-hlg1", 57600, "height", 57600)],  # the set-up's rate on both sides
)
def test_simulated_run_uses_the_set_up_family(tmp_path: Path, protocol: str, baud: int | None, sign: str,
                                              line_rate: int) -> None:
    setup = straightness_setup_from_dict(tomllib.loads(setup_text(protocol, baud, sign)), "setup.toml")
    out = io.StringIO()
    res = run_straightness(setup, tmp_path / "run", simulate=SimOptions(seed=3, noise=False), auto=True, stream=out)
    assert res.outcome.exit_status == "success"
    assert res.sim is not None
    assert (res.sim.sensor_protocol, res.sim.sensor_baudrate) == (protocol, line_rate)
    assert res.sim.geometry().sensor_sign == sign
    assert ("note: a me-ild1420 gives gap-type values" in out.getvalue()) == (protocol == "me-ild1420"
                                                                            and sign == "height")
    meta = json.loads((res.run_dir / "run.json").read_text())
    assert meta["instruments"]["sensor"]["protocol"] == protocol

    _, evaluation = process_run_dir(res.run_dir)
    prof = evaluation.result.profile
    x_true, h_true = truth_heights_um(res.sim.world)
    x = prof["x_mm"].to_numpy()
    err = ls_residual(x, prof["height_um"].to_numpy()) - ls_residual(x_true, h_true)
    tol_um = residual_gain(x) * STEP_MM[protocol] * 1000.0 / 2 + OTHER_CHANNELS_UM
    assert np.max(np.abs(err)) < tol_um
    assert np.ptp(ls_residual(x_true, h_true)) > 10 * tol_um
