"""run.json ``compensation``: the compensation table that was active in the controller while a
positioning run was measured (docs/run-format.md, docs/compensation.md "Applying a table").

Written by ``guideway acquire positioning`` for every new run: ``{"active": false}`` or
``{"active": true, "file", "path", "format", "sha256", "bytes", "entries", "table", "applied_by", ...}``.
A run written before the key existed does not say: it reads as **not recorded** (``"active": null``),
which is *unknown*, not *none* — a table may well have been active.
"""

from __future__ import annotations

from typing import Any

NOT_RECORDED: dict[str, Any] = {"active": None, "recorded": False}


def run_compensation(meta: dict[str, Any]) -> dict[str, Any]:
    """The run's compensation record; :data:`NOT_RECORDED` for a run that has none (older runs),
    or whose record is not an object.  ``live_stopped``: :func:`live_compensation_stopped`'s line, for a run
    whose live compensation stopped while it went on."""
    rec = meta.get("compensation")
    if not isinstance(rec, dict) or "active" not in rec:
        return dict(NOT_RECORDED)
    stopped = live_compensation_stopped(meta)
    return {**rec, "recorded": True, **({"live_stopped": stopped} if stopped else {})}


def compensation_text(record: dict[str, Any]) -> str:
    """One line for the terminal and the report."""
    if not record.get("recorded", True) or record.get("active") is None:
        return "controller compensation: not recorded (a run from before the tool recorded it: unknown)"
    if not record.get("active"):
        return "controller compensation: none"
    fmt = str(record.get("format", "?"))
    if fmt == "linuxcnc" and record.get("comp_file_type") is not None:
        fmt += f" COMP_FILE_TYPE {record['comp_file_type']}"
    sha = str(record.get("sha256", ""))[:12]
    by = f", applied by the {record['applied_by']}" if record.get("applied_by") == "simulated controller" else ""
    stopped = f"; {record['live_stopped']}" if record.get("live_stopped") else ""
    return f"controller compensation: {record.get('file', '?')} ({fmt}, sha256 {sha}…){by}{stopped}"


def live_compensation_stopped(meta: dict[str, Any]) -> str:
    """One line when run.json ``live_compensation`` says the live compensator stopped while the run went on
    ("" otherwise): such a run is no as-left measurement (docs/compensation.md, "Live compensation in
    simulation").  Since the acquisition stops the run before its next point, the points recorded were
    compensated but the run is incomplete; a run written before that (no ``last_compensated_point``) went on
    uncompensated.  A compensator that stopped after the run's last point leaves a complete, valid run."""
    live = meta.get("live_compensation")
    if not isinstance(live, dict) or not live.get("error"):
        return ""
    last = live.get("last_compensated_point")
    if not isinstance(last, int) or isinstance(last, bool):
        return (f"live compensation stopped during the run ({live['error']}): the points after it were measured "
                "uncompensated, the run is no as-left measurement; measure again")
    if meta.get("status") == "complete" and last == meta.get("points"):
        return ""
    return (f"live compensation stopped after point {last} ({live['error']}): the run was stopped there, it is no "
            "complete as-left measurement; measure again")
