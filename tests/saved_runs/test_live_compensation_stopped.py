"""run.json ``live_compensation`` of a run whose compensator stopped: which runs are no as-left measurement."""

from __future__ import annotations

from saved_runs.store.compensation import compensation_text, live_compensation_stopped, run_compensation

LIVE = {"active": True, "format": "live", "file": "live spline", "sha256": "ab" * 32,
        "applied_by": "simulated controller"}


def meta(status: str, points: int, live: dict) -> dict:
    return {"status": status, "points": points, "compensation": LIVE, "live_compensation": live}


def test_a_run_stopped_at_the_compensators_death_is_flagged() -> None:
    m = meta("aborted", 58, {"error": "link lost", "last_compensated_point": 58})
    assert live_compensation_stopped(m).startswith("live compensation stopped after point 58 (link lost): the run "
                                                   "was stopped there")
    assert run_compensation(m)["live_stopped"] == live_compensation_stopped(m)
    assert compensation_text(run_compensation(m)).endswith("; " + live_compensation_stopped(m))


def test_an_older_run_that_went_on_uncompensated_is_flagged() -> None:
    # written before the run stopped (no last_compensated_point): complete, but its later points uncompensated
    m = meta("complete", 180, {"error": "link lost"})
    assert "the points after it were measured uncompensated" in live_compensation_stopped(m)


def test_valid_live_runs_are_not_flagged() -> None:
    assert live_compensation_stopped(meta("complete", 180, {"cycles": 900})) == ""
    # stopped after the run's last point: every point was compensated
    assert live_compensation_stopped(meta("complete", 180, {"error": "x", "last_compensated_point": 180})) == ""
    assert "live_stopped" not in run_compensation(meta("complete", 180, {"cycles": 900}))
    assert live_compensation_stopped({"status": "complete"}) == ""
