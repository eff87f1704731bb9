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
    or whose record is not an object."""
    rec = meta.get("compensation")
    if not isinstance(rec, dict) or "active" not in rec:
        return dict(NOT_RECORDED)
    return {**rec, "recorded": True}


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
    return f"controller compensation: {record.get('file', '?')} ({fmt}, sha256 {sha}…){by}"
