"""Which tables were exported from a run: ``RUN/results/exports.json`` (docs/compensation.md, "The loop").

A LinuxCNC comp file holds no comment (its loader stops at the first line that is not three numbers), so a
table cannot say where it came from.  Every ``guideway export`` that writes a file therefore records it in
the *source* run's results/: the file's name and path, the SHA-256 of its bytes, the run's uid, the format,
model and mode, when it was written and the export's "as written" figures.  ``guideway verify`` finds the
table an as-left run was measured with (run.json ``compensation.sha256``) there; a run whose results/ holds
the table itself (``compensation-*.*``, the export's default name) is found by hashing those files too.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from ..errors import FileWriteError, RunFormatError
from ..store.files import read_run_file, write_json_atomic

EXPORTS_FILE = "exports.json"


def sha256_of(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def export_record(run_meta: dict[str, Any], path: Path, export: Any, options: Any) -> dict[str, Any]:
    """The record of one written table (``export``: saved_runs.export.build.Export)."""
    rec: dict[str, Any] = {
        "file": path.name, "path": str(path.resolve()), "sha256": sha256_of(path), "run_uid": run_meta.get("uid"),
        "format": options.fmt, "model": options.model, "mode": export.table.mode,
        "written": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "unit": export.error_unit,
        "combined_with": None if export.combined_with is None else export.combined_with.get("sha256"),
    }
    if options.fmt == "linuxcnc":
        rec["comp_file_type"] = options.linuxcnc_type
    if export.scores is not None:
        rec["as_written"] = {k: v for k, v in export.scores.written.items() if k in ("E", "M", "range", "rms")}
    # what the model leaves between its points (refitted without each target, scored there): an as-left run
    # on shifted targets is held against it
    loto = (export.residuals.get(options.model) or {}).get("leave_one_target_out")
    if loto is not None:
        rec["leave_one_target_out"] = ({"unavailable": loto.reason} if not hasattr(loto, "rms")
                                       else {"rms": loto.rms, "max": loto.max_abs, "points": loto.points})
    return rec


def read_exports(run_dir: Path) -> list[dict[str, Any]]:
    """The records of ``run_dir``'s results/exports.json ([] when there is none or it cannot be read: the
    record is a help for verify, never a reason to refuse an export)."""
    try:  # read_run_file: a FIFO or device planted there is not read (it would wait forever)
        data = json.loads(read_run_file(run_dir / "results" / EXPORTS_FILE).decode("utf-8"))
    except (OSError, RunFormatError, UnicodeDecodeError, json.JSONDecodeError):
        return []
    rows = data.get("exports") if isinstance(data, dict) else None
    return [r for r in rows if isinstance(r, dict)] if isinstance(rows, list) else []


def record_export(run_dir: Path, record: dict[str, Any]) -> str:
    """Add ``record`` to ``run_dir``/results/exports.json (replacing a record of the same file and SHA-256),
    atomically; '' or a one-line note when it cannot be written (the table itself is written)."""
    rows = [r for r in read_exports(run_dir)
            if not (r.get("sha256") == record["sha256"] and r.get("path") == record["path"])]
    rows.append(record)
    try:
        (run_dir / "results").mkdir(exist_ok=True)  # a table written elsewhere (--out) from a run not processed yet
        write_json_atomic(run_dir / "results" / EXPORTS_FILE, {"exports": rows})
    except (OSError, FileWriteError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        return (f"the export is not recorded in {run_dir / 'results' / EXPORTS_FILE} ({why}): "
                "guideway verify will find the table only under results/compensation-*")
    return ""


@dataclass(frozen=True)
class Provenance:
    """Where a table with a given SHA-256 comes from, as far as a run's results/ says: ``record`` (its
    exports.json entry, or a minimal one for a file found by hashing) and ``how`` it was found."""

    record: dict[str, Any]
    how: str  # "exports.json" or "results/<file name>"


def find_export(run_dir: Path, sha256: str, uid: str | None) -> Provenance | None:
    """The table of ``sha256`` exported from the run at ``run_dir`` (uid ``uid``): a record of its
    exports.json naming that run (a record copied with results/ from another run does not count), else a
    ``results/compensation-*.*`` file with those bytes; None when neither."""
    for rec in reversed(read_exports(run_dir)):
        if rec.get("sha256") == sha256 and (uid is None or rec.get("run_uid") in (None, uid)):
            return Provenance(rec, EXPORTS_FILE)
    for path in sorted((run_dir / "results").glob("compensation-*.*")):
        try:
            if path.is_file() and sha256_of(path) == sha256:
                return Provenance({"file": path.name, "path": str(path.resolve()), "sha256": sha256},
                                  f"results/{path.name}")
        except OSError:
            continue
    return None
