"""The warm-up shows its drift against the limits after every reading (a Log line the terminal
and the TUI both get), so the technician sees it settle instead of a silent wait."""

from __future__ import annotations

from acquisition import messages as m
from acquisition.plans.straightness import straightness_plan
from acquisition.setup.straightness import WarmupSetup

from .test_straightness_workflow import Bench, drive, setup


def test_each_warmup_reading_logs_the_drift_so_far_against_the_limits() -> None:
    drifting = [0.0, 3.0, 5.0, 5.1, 5.2]  # straightness Y of the readings (um); sensor constant
    w = WarmupSetup(window=3, interval_s=10.0, max_drift_ifm_um=0.5, max_drift_sensor_um=0.5, timeout_s=1e6)
    bench = Bench(stry=lambda k, n: drifting[n] if n < len(drifting) else 0.0)
    b = drive(straightness_plan(setup(3, warmup=w), {}), bench)
    lines = [x.text for x in b.msgs if isinstance(x, m.Log) and x.text.startswith("warm-up ")]
    # peak-to-peak over the last (up to) 3 readings, by hand: -, 3, 5, 2.1, 0.2 um
    assert lines[0] == "warm-up 0 s: reading 1 of at least 3"
    assert lines[1] == ("warm-up 10 s: drift over the last 2 of 3 readings: interferometer 3.00 / 0.5 um, "
                        "sensor 0.00 / 0.5 um (above the limits)")
    assert "last 3 of 3 readings: interferometer 5.00 / 0.5 um" in lines[2]
    assert "interferometer 2.10 / 0.5 um" in lines[3] and lines[3].endswith("(above the limits)")
    assert "interferometer 0.20 / 0.5 um" in lines[4] and lines[4].endswith("(within the limits)")
    assert lines[5] == "warm-up stable after 40 s"
