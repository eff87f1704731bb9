"""The stillness rule shared by hands-free capture (acquire --auto), the positioning stability trigger and the
TUI's stability light (acquisition.stillness)."""

from __future__ import annotations

import dataclasses

from acquisition.setup.files import setup_from_dict
from acquisition.stillness import MOVING, SETTLING, STABLE, LiveStability, StabilityRule, StillnessWindow
from tests.tui.frozen import ifm as frozen_ifm
from tests.tui.sessions import POSITIONING, STRAIGHTNESS

POLL_S = 0.25


def test_a_steady_reading_settles_then_is_stable_once_the_window_spans_the_time() -> None:
    w = StillnessWindow(tolerance=2.0, duration_s=2.0)
    states = [w.add(i * POLL_S, (0.0, 1.0, -1.0)) for i in range(10)]
    # one reading: nothing to compare with; stable once (n - 1) * 0.25 s >= 2 s, i.e. from the 9th reading
    assert states == [MOVING] + [SETTLING] * 7 + [STABLE] * 2


def test_a_move_beyond_the_tolerance_restarts_the_window_and_leaving_the_target_clears_it() -> None:
    w = StillnessWindow(tolerance=2.0, duration_s=1.0)
    for i in range(5):
        w.add(i * POLL_S, (0.0,))
    assert w.state == STABLE
    assert w.add(5 * POLL_S, (1.5,)) == STABLE  # within 2 um of every reading in the window: still
    # 2.5 um from the first readings: they are dropped, the window starts at the 1.5 um reading
    assert w.add(6 * POLL_S, (2.5,)) == SETTLING and len(w.readings) == 2
    assert w.add(7 * POLL_S, (9.0,)) == MOVING  # a real move: only the newest reading is left
    assert w.clear() == MOVING and w.readings == []


def test_the_straightness_rule_is_the_auto_table_and_the_positioning_rule_the_trigger() -> None:
    s = setup_from_dict({**STRAIGHTNESS, "auto": {"still_um": 3.0, "still_s": 1.5},
                         "validation": {"max_lin_um": 40.0}})
    assert StabilityRule.of(s) == StabilityRule(40.0, 3.0, 1.5, "um", "um", "straightness")
    trigger = {**POSITIONING["trigger"], "stability_window_um": 0.8, "dwell_s": 3.0, "near_mm": 0.2}
    p = setup_from_dict({**POSITIONING, "trigger": trigger})
    assert StabilityRule.of(p) == StabilityRule(0.2, 0.8, 1.5, "mm", "um", "positioning")


def test_live_stability_ignores_a_repeated_capture_and_a_block_off_the_station() -> None:
    live = LiveStability(StabilityRule(50.0, 2.0, 0.5, "um", "um", "straightness"))
    live.retarget(200.0)  # station at x = 200 mm
    off = frozen_ifm(position_mm=200.2)  # 200 um away: beyond 50 um
    assert live.update(off, off.position_mm) == MOVING
    states = []
    for i in range(4):
        r = dataclasses.replace(frozen_ifm(position_mm=200.0021), timestamp_s=i * POLL_S)
        states.append(live.update(r, r.position_mm))
        states.append(live.update(r, r.position_mm))  # the monitor hands the same capture on: not a new reading
    assert states == [MOVING, MOVING, SETTLING, SETTLING, STABLE, STABLE, STABLE, STABLE]
    assert len(live.window.readings) == 4
    live.retarget(300.0)  # the next station: the window starts again
    assert live.state == MOVING and live.window.readings == []


def test_the_live_light_turns_stable_at_the_reading_where_acquire_auto_captures() -> None:
    """The same readings through plans.straightness.arrival (acquire --auto) and the TUI's LiveStability: the
    light is STABLE exactly from the reading after which the hands-free plan captures."""
    from acquisition.messages import Log, TriggerInterferometer, Wait
    from acquisition.plans.straightness import arrival

    s = setup_from_dict({**STRAIGHTNESS, "auto": {"still_s": 1.0, "still_um": 2.0, "poll_s": 0.25}})
    # the block slides in (100 um steps), overshoots, settles with 1 um of noise
    positions_um = [-400, -300, -200, -100, 0, 60, 10, 11, 10, 12, 11, 10, 11, 10, 12, 11]
    readings = [dataclasses.replace(frozen_ifm(position_mm=300.0 + p / 1000.0, stry_um=0.0), timestamp_s=i * POLL_S)
                for i, p in enumerate(positions_um)]
    plan = arrival(s, 0, 3, 300.0)
    msg, used = next(plan), 0
    try:
        while True:
            if isinstance(msg, TriggerInterferometer):
                used += 1  # (counted before the send: the plan may return on this reading)
                msg = plan.send(readings[used - 1])
            elif isinstance(msg, Wait):
                msg = plan.send(POLL_S)
            else:
                assert isinstance(msg, Log)
                msg = plan.send(None)
    except StopIteration as stop:
        assert stop.value is True
    live = LiveStability(StabilityRule.of(s))
    live.retarget(300.0)
    states = [live.update(r, r.position_mm) for r in readings]
    # still from the 10 um reading (index 6) on: 1 s later (4 polls) is index 10, the 11th reading
    assert used == 11 and states.index(STABLE) == used - 1
    assert states[:6] == [MOVING] * 6  # sliding in, the overshoot: each reading moved
