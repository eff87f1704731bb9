"""Before a capture the operator asked for, the plan asks when the block or axis is not still (issue 25):
the operator's view (messages.Stillness), a question (key ``still``), the mark in the point."""

from __future__ import annotations

from typing import Any

import pytest

from acquisition import messages as m
from acquisition.plans.straightness import straightness_plan

from .test_straightness_workflow import Bench, reading, setup


class Watching(Bench):
    """A bench whose operator answers Stillness with ``seen`` (per station) and whose readings carry time: a
    reading every poll, the block at the station it was asked to."""

    def __init__(self, seen: dict[int, Any], shaking: int | None = None, **kw: Any) -> None:
        super().__init__(**kw)
        self.seen = seen
        self.shaking = shaking  # at this station every reading moves 5 um (beyond [auto] still_um, 2 um)
        self.t = 0.0

    def __call__(self, msg: Any) -> Any:
        if isinstance(msg, m.Stillness):
            self.msgs.append(msg)
            return self.seen.get(self.station)
        if isinstance(msg, m.TriggerInterferometer):
            self.msgs.append(msg)
            self.t += 0.25
            shake = 5.0 * (round(self.t / 0.25) % 2) if self.station == self.shaking else 0.0
            return reading(100.0 * self.station, 0.1 * self.station + shake, t=self.t)
        return super().__call__(msg)


def run(seen: dict[int, Any], answers: dict[tuple[str, int], list[str]] | None = None,
        shaking: int | None = None) -> Watching:
    bench = Watching(seen, shaking, answers=answers)
    plan = straightness_plan(setup(4), {})
    reply = None
    while True:
        try:
            msg = plan.send(reply)
        except StopIteration:
            return bench
        reply = bench(msg)


def prompts(bench: Watching) -> list[m.Prompt]:
    return [x for x in bench.msgs if isinstance(x, m.Prompt) and x.key == "still"]


def test_a_station_seen_moving_is_a_question_and_capture_now_marks_the_point() -> None:
    bench = run({2: "moving"}, answers={("still", 2): ["capture"]})
    (q,) = prompts(bench)
    assert "not still at station 2" in q.text and q.choices == ("wait", "capture", "abort") and q.default == "wait"
    assert [(p["station"], p["not_still"]) for p in bench.points] == [(0, 0), (1, 0), (2, 1), (3, 0)]


def test_wait_captures_once_the_block_rests_and_does_not_mark_it() -> None:
    bench = run({2: "settling"})  # the default answer: wait
    assert len(prompts(bench)) == 1
    assert [p["not_still"] for p in bench.points] == [0, 0, 0, 0]
    # waited: readings at the station spanning [auto] still_s (2 s at 0.25 s) before the capture
    at2 = [x for x in bench.msgs if isinstance(x, m.TriggerInterferometer)]
    assert len(at2) >= 4 + 8


@pytest.mark.parametrize("seen", [None, "stable"])
def test_a_still_block_or_no_judge_is_not_asked(seen: Any) -> None:
    bench = run(dict.fromkeys(range(4), seen))
    assert not prompts(bench) and [p["not_still"] for p in bench.points] == [0, 0, 0, 0]


def test_no_live_view_the_plan_looks_and_a_resting_block_is_captured_unasked() -> None:
    bench = run(dict.fromkeys(range(4), "look"))  # the plain terminal: the readings here rest at the station
    assert not prompts(bench) and [p["not_still"] for p in bench.points] == [0, 0, 0, 0]


def test_no_live_view_and_a_block_that_does_not_rest_is_a_question() -> None:
    bench = run(dict.fromkeys(range(4), "look"), answers={("still", 3): ["capture"]}, shaking=3)
    (q,) = prompts(bench)
    assert "not still at station 3 (x = 300 mm): not at rest" in q.text
    assert [p["not_still"] for p in bench.points] == [0, 0, 0, 1]


def test_manual_positioning_target_seen_moving_asks_and_marks_or_waits() -> None:
    from acquisition.plans.positioning import positioning_plan

    from .plan_driver import drive
    from .test_positioning_workflow import Machine, psetup

    s = psetup("manual")
    mach = Machine([], s.targets)
    placed = iter([0.0, 100.0, 200.0, 200.0, 100.0, 0.0])
    clock = [0.0]
    answers = {2: "capture", 3: "wait"}  # target 2 up: capture now; target 3 up: wait until still
    asked: list[m.Prompt] = []
    where: list[int] = []

    def respond(msg: Any) -> Any:
        if isinstance(msg, m.Instruct) and msg.key == "target":
            mach.at = next(placed)
            where.append(msg.params["target_index"] * msg.params["direction"])
        if isinstance(msg, m.Stillness):
            return "moving" if where[-1] in (2, 3) else "stable"
        if isinstance(msg, m.Prompt) and msg.key == "still":
            asked.append(msg)
            return answers[where[-1]]
        if isinstance(msg, m.TriggerInterferometer):
            clock[0] += 0.1
            return ifm_at(mach.at + mach.offset, clock[0])
        if isinstance(msg, m.Wait):
            mach.msgs.append(msg)
            return msg.seconds
        return mach(msg)

    drive(positioning_plan(s, {}), respond)
    rows = [x.data for x in mach.msgs if isinstance(x, m.Record)]
    assert len(asked) == 2 and "not still at target 2" in asked[0].text
    assert [(r["target_index"], r["direction"], r["not_still"]) for r in rows] == [
        (1, 1, 0), (2, 1, 1), (3, 1, 0), (3, -1, 0), (2, -1, 0), (1, -1, 0)]
    # waited at target 3: polled readings spanning half the dwell (0.5 s at 0.1 s) before the capture
    assert sum(isinstance(x, m.Wait) for x in mach.msgs) >= 5


def ifm_at(position_mm: float, t: float) -> Any:
    from .test_positioning_workflow import ifm

    return ifm(position_mm, t)
