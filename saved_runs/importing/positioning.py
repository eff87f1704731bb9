"""Import a positioning measurement from a CSV file into a run directory (format version 2).

Input columns (header line, any order): ``run, direction, target_mm, reading_mm``
(rotary: ``target_deg, reading_deg``), optionally ``time_s``, the error channels
``stry_um, strz_um, pitch_urad, yaw_urad, roll_urad`` and the environment
``air_temp_c, air_pressure_hpa, humidity_pct, material_temp_c`` (names and units
of docs/run-format.md).  ``direction`` is +1 or -1, ``run`` counts approaches per
direction from 1.  ``target_index`` is derived: the distinct targets in ascending
order are numbered 1 … m.  The run directory is written at once (:func:`~saved_runs.store.whole.write_whole_run`).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from processing.air_index import DEFAULT_EQUATION, EQUATIONS
from processing.columns import ENVIRONMENT, ERROR_CHANNELS
from processing.iso230_2 import check_target_count

from ..errors import UserError
from ..store.whole import write_whole_run

MAX_PROBLEMS_SHOWN = 20


class ImportProblems(UserError):
    """Bad input rows; ``problems`` holds one ``FILE:LINE: what`` message per problem."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__(problems[0] if len(problems) == 1 else
                         f"{len(problems)} problems in the input, first: {problems[0]}")


@dataclass(frozen=True)
class PositioningImport:
    """Options of an import (the run's ``setup.environment`` and descriptive fields)."""

    axis_type: str = "linear"
    compensated: bool = False
    refractive_index_assumed: float = 1.0
    wavelength_nm: float | None = None
    co2_ppm: float | None = None
    expansion_ppm_per_k: float | None = None
    dead_path_mm: float | None = None
    index_equation: str = DEFAULT_EQUATION
    axis_name: str = ""
    machine: str = ""
    extra_notes: list[str] = field(default_factory=list)


def _columns(axis_type: str) -> tuple[str, str]:
    return ("target_deg", "reading_deg") if axis_type == "rotary" else ("target_mm", "reading_mm")


def parse_positioning_csv(text: str, name: str, opts: PositioningImport) -> list[dict[str, Any]]:
    """Validate the CSV text; return one points.csv record per data row (without target_index).

    Raises :class:`ImportProblems` listing every bad row with its line number.
    """
    if opts.axis_type not in ("linear", "rotary"):
        raise UserError(f"unknown axis type {opts.axis_type!r} (use linear or rotary)")
    if opts.index_equation not in EQUATIONS:
        raise UserError(f"unknown index equation {opts.index_equation!r} (use {' or '.join(EQUATIONS)})")
    target_col, reading_col = _columns(opts.axis_type)
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or not any(c.strip() for c in rows[0]):
        raise ImportProblems([f"{name}:1: empty file; expected a header line with run, direction, "
                              f"{target_col}, {reading_col}"])
    header = [h.strip() for h in rows[0]]
    required = ("run", "direction", target_col, reading_col)
    optional = ("time_s", *ERROR_CHANNELS, *ENVIRONMENT)
    problems: list[str] = []
    other_target, _ = _columns("linear" if opts.axis_type == "rotary" else "rotary")
    missing = [c for c in required if c not in header]
    if missing:
        hint = (f" (the file has {other_target}: use --axis-type "
                f"{'linear' if opts.axis_type == 'rotary' else 'rotary'})" if other_target in header else "")
        problems.append(f"{name}:1: missing column(s) {', '.join(missing)}{hint}")
    unknown = [c for c in header if c not in required and c not in optional]
    if unknown:
        problems.append(f"{name}:1: unknown column(s) {', '.join(unknown)}; allowed: "
                        f"{', '.join(required + optional)}")
    dupes = sorted({c for c in header if header.count(c) > 1})
    if dupes:
        problems.append(f"{name}:1: column(s) {', '.join(dupes)} appear twice")
    needs_air = opts.axis_type == "linear" and not opts.compensated
    needed = list(ENVIRONMENT[:3]) if needs_air else []
    if needs_air and opts.expansion_ppm_per_k is not None:
        needed.append("material_temp_c")
    absent = [c for c in needed if c not in header]
    if absent:
        problems.append(f"{name}:1: column(s) {', '.join(absent)} needed to compensate the readings; "
                        "add them or pass --compensated if the readings are already compensated")
    if problems:
        raise ImportProblems(problems)

    col = {c: header.index(c) for c in header}
    records: list[dict[str, Any]] = []
    seen: dict[tuple[int, int, float], int] = {}
    for lineno, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            problems.append(f"{name}:{lineno}: expected {len(header)} fields, found {len(row)}")
            continue
        rec: dict[str, Any] = {}
        row_ok = True

        def bad(msg: str, lineno: int = lineno) -> None:
            nonlocal row_ok
            row_ok = False
            problems.append(f"{name}:{lineno}: {msg}")

        run_txt = row[col["run"]].strip()
        try:
            run = int(run_txt)
            if run < 1:
                bad(f"run must be a positive integer (counted from 1), found {run_txt!r}")
            rec["run"] = run
        except ValueError:
            bad(f"run must be a positive integer, found {run_txt!r}")
        dir_txt = row[col["direction"]].strip()
        if dir_txt in ("1", "+1", "-1"):
            rec["direction"] = int(dir_txt)
        else:
            bad(f"direction must be +1 or -1, found {dir_txt!r}")
        for c in (target_col, reading_col):
            txt = row[col[c]].strip()
            try:
                v = float(txt)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                bad(f"{c} must be a finite number, found {txt!r}")
            rec[c] = v
        for c in optional:
            if c not in col:
                rec[c] = math.nan
                continue
            txt = row[col[c]].strip()
            if txt == "" or txt.lower() == "nan":
                v = math.nan
            else:
                try:
                    v = float(txt)
                except ValueError:
                    bad(f"{c} is not a number: {txt!r}")
                    v = math.nan
                if math.isinf(v):
                    bad(f"{c} must be finite, found {txt!r}")
            rec[c] = v
        if row_ok:
            for c in needed:
                if not math.isfinite(rec[c]):
                    bad(f"{c} is empty; needed to compensate the readings (or pass --compensated)")
        if row_ok:
            key = (rec["run"], rec["direction"], rec[target_col])
            if key in seen:
                bad(f"duplicate point: run {key[0]}, direction {key[1]:+d}, {target_col} {key[2]:g} "
                    f"already on line {seen[key]}")
            else:
                seen[key] = lineno
        if row_ok:
            records.append(rec)
    if not problems and not records:
        problems.append(f"{name}:2: no data rows")
    if problems:
        raise ImportProblems(problems)
    return records


def import_positioning(csv_path: Path | str, out: Path | str, opts: PositioningImport,
                       warn: Callable[[str], None] | None = None) -> tuple[Path, int]:
    """Read ``csv_path`` and write the run directory ``out``; return (out, points written).

    Fewer than 2 targets are refused (no E, M or A); fewer than the ISO 230-2 target rule asks
    for are imported, with the rule passed to ``warn`` (and noted again when evaluated).
    """
    csv_path = Path(csv_path)
    try:
        text = csv_path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise UserError(f"{csv_path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{csv_path}: cannot read it as UTF-8 text ({exc})") from None
    records = parse_positioning_csv(text, str(csv_path), opts)
    target_col, reading_col = _columns(opts.axis_type)
    targets = sorted({r[target_col] for r in records})
    try:
        note = check_target_count(targets, opts.axis_type)
    except ValueError as exc:
        raise UserError(f"{csv_path}: {exc}") from None
    if note and warn is not None:
        warn(f"{csv_path}: {note}")
    index = {t: i for i, t in enumerate(targets, start=1)}
    for r in records:
        r["target_index"] = index[r[target_col]]

    env: dict[str, Any] = {"readings_compensated": bool(opts.compensated)}
    if not opts.compensated:
        env["refractive_index_assumed"] = opts.refractive_index_assumed
        env["index_equation"] = opts.index_equation
    for key in ("wavelength_nm", "co2_ppm", "expansion_ppm_per_k", "dead_path_mm"):
        v = getattr(opts, key)
        if v is not None:
            env[key] = v
    unit = "deg" if opts.axis_type == "rotary" else "mm"
    header = {
        "axis_type": opts.axis_type,
        "machine": opts.machine,
        "axis": opts.axis_name,
        "operator": "",
        "notes": "; ".join([f"imported from {csv_path.name}", *opts.extra_notes]),
        "setup": {
            "axis_name": opts.axis_name,
            f"targets_{unit}": targets,
            "runs": max(r["run"] for r in records),
            "environment": env,
        },
    }
    # written into a temporary directory and renamed into place when complete: a killed import leaves
    # no partial run at ``out`` (saved_runs/store/whole.py)
    return write_whole_run(out, header, "positioning", records, f"imported from {csv_path}")
