"""Injected device faults of a simulated run (``--faults``, docs/faults.md): the plan from its spec,
entries refused before the run when they cannot fire, and run.json's ``fault_plan`` afterwards."""

from __future__ import annotations

from typing import Any

from mocks.faults import FaultPlan, FaultSpecError
from saved_runs.errors import UserError


def parse_faults(spec: str | None) -> FaultPlan:
    """A fault plan from a ``--faults`` spec; a one-line :class:`UserError` when malformed."""
    try:
        return FaultPlan.parse(spec)
    except FaultSpecError as exc:
        raise UserError(str(exc)) from exc


def refuse_faults_that_cannot_fire(plan: FaultPlan | None, *, sensor: bool, sensor_requests: int | None = None,
                                   live: bool = False) -> None:
    """A one-line :class:`UserError` for fault entries that certainly cannot fire.

    ``sensor`` False: the run has no displacement sensor, so no sensor entry can fire.
    ``sensor_requests``: how many requests the sensor gets in a fault-free run (None: not known,
    e.g. an operator may redo stations).  Requests beyond it come only from retries after a fault,
    so when every entry is a sensor entry past it, none can fire.  Anything less certain is left
    to :func:`fault_report` at the end of the run.
    ``live`` False: no live-compensation interface is served, so no ``live`` entry can fire."""
    if plan is None or not plan.faults:
        return
    f = next((f for f in plan.faults if f.device == "live"), None)
    if f is not None and not live:
        raise UserError(f"--faults {f.spec()} cannot fire: this run has no live compensation; add "
                        "--live-compensation AS_FOUND_RUN (a positioning run) or inject controller faults")
    if not sensor:
        f = next((f for f in plan.faults if f.device == "sensor"), None)
        if f is not None:
            raise UserError(f"--faults {f.spec()} cannot fire: this run has no displacement sensor; "
                            "inject controller faults")
        return
    if sensor_requests is not None and all(f.device == "sensor" and f.at > sensor_requests for f in plan.faults):
        f = plan.faults[0]
        raise UserError(f"--faults {f.spec()} cannot fire: a run of this set-up asks the sensor {sensor_requests} "
                        f"times; give N <= {sensor_requests}")


def fault_report(plan: FaultPlan | None) -> dict[str, Any] | None:
    """run.json ``fault_plan``: the spec, the requests each device got and the entries that did
    not fire (None without faults)."""
    if plan is None or not plan.faults:
        return None
    return {"spec": ",".join(f.spec() for f in plan.faults),
            "requests": {d: plan.requests(d) for d in ("sensor", "controller", "live")
                         if d != "live" or any(f.device == "live" for f in plan.faults)},
            "not_fired": [f.spec() for f in plan.unfired()]}
