"""One run as the catalogue holds it: identity and place from run.json, a content hash of run.json and
points.csv, and the headline values with their uncertainties from the same evaluation as
``guideway process`` (its results/summary.json when that is newer than the run's files, else a fresh
evaluation, written nowhere: the catalogue never changes a run directory).

Headline values (``values``), each ``{"value_um": v, "u_um": u}`` with ``u`` the standard uncertainty
(k = 1) or None when the evaluation gives none; a rotary axis' values are ``value_arcsec``/``u_arcsec``;
``limit_um`` (``limit_arcsec``) when the run's ``[tolerance]`` sets a limit on that value:

* straightness: ``endpoint``, ``least_squares``, ``minimum_zone`` (straightness against each reference
  line; u = the Monte Carlo expanded uncertainty U divided by its k);
* positioning: the ISO 230-2 values ``A``, ``A_up``, ``A_down``, ``E``, ``E_up``, ``E_down``, ``M``, ``R``,
  ``R_up``, ``R_down``, ``B`` (a magnitude, the largest |B_i|) and ``B_mean`` (the signed mean reversal, for
  a trend that sees its sign change); u = u_c of the value's ISO 230-2 Annex A budget (summary ``uncertainty``).

The verdict is the evaluation's, however the run was evaluated; the evaluation options of the values
(``options``: ``method``, ``mc_trials`` of a straightness run, ``k``, ``edition`` of a positioning run,
``accept_out_of_range``) are kept with the defaults of ``guideway process`` (``option_defaults``), so that a
run processed with other options (a 20-trial first-order evaluation) is told from one evaluated as usual.

A positioning run's compensation state (``compensation``): the table active in the controller while it was
measured, from run.json ``compensation`` — ``{"active": false}`` (none), ``{"active": true, "file", "format",
"sha256"}``, or ``{"active": null}`` (not recorded: a run from before the record); None for a straightness
run and for an entry catalogued before the catalogue kept it (schema 1 and 2).  It is one of the run's
``facts`` (:func:`run_facts`, the ``facts_json`` column of schema 3).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from saved_runs.errors import UserError
from saved_runs.evaluation.tolerance import POSITIONING_QUANTITIES, REFERENCE_LINES
from saved_runs.store.compensation import run_compensation
from saved_runs.store.files import read_run_file
from saved_runs.store.format import FORMAT, run_axis

HASHED_FILES = ("run.json", "points.csv")
# Headline values with a sign, catalogued for their trend; no [tolerance] key names them (B_um bounds |B_i|).
SIGNED_QUANTITIES = ("B_mean",)


class RunUnreadable(UserError):
    """A run directory whose run.json cannot be read or is not a guideway run."""


@dataclass(frozen=True)
class Entry:
    """A catalogue entry (one row of ``guideway_runs``); ``note`` says why ``values`` is empty."""

    uid: str
    path: str
    machine: str
    axis: str
    kind: str
    created: str
    status: str
    content_hash: str
    values: dict[str, dict[str, float | None]] = field(default_factory=dict)
    verdict: str | None = None
    note: str = ""
    options: dict[str, Any] | None = None  # the evaluation options of ``values`` (None: not known, schema 1)
    option_defaults: dict[str, Any] = field(default_factory=dict)  # those of guideway process for this run
    facts: dict[str, Any] | None = None  # run_facts() of run.json (None: not known, an entry of schema 1 or 2)

    def non_default_options(self) -> dict[str, Any]:
        """The options of the evaluation that differ from process' defaults (name -> value used; one the
        summary does not state, None, is not known to differ)."""
        return {k: v for k, v in (self.options or {}).items() if k in self.option_defaults
                and v is not None and v != self.option_defaults[k]}

    def to_dict(self) -> dict[str, Any]:
        """The object of ``guideway catalog list --json``."""
        return {"uid": self.uid, "path": self.path, "machine": self.machine, "axis": self.axis, "kind": self.kind,
                "created": self.created, "status": self.status, "values": self.values, "verdict": self.verdict,
                "options": self.options, "option_defaults": self.option_defaults,
                "non_default_options": self.non_default_options(),
                "compensation": self.compensation}

    @property
    def compensation(self) -> dict[str, Any] | None:
        """The run's compensation state (module docstring), from its facts."""
        if self.kind != "positioning" or self.facts is None:
            return None
        return self.facts.get("compensation")

    def compensation_text(self) -> str:
        """The compensation state in a few words: ``none``, ``x.comp 6c0211989feb``, ``not recorded``, or ``-``
        (a straightness run, or an entry catalogued before the catalogue kept it)."""
        c = self.compensation
        if c is None:
            return "-"
        if c.get("active") is None:
            return "not recorded"
        return f"{c.get('file')} {str(c.get('sha256'))[:12]}" if c["active"] else "none"


@dataclass(frozen=True)
class RunFiles:
    """What the catalogue reads of a run directory before deciding whether to evaluate it."""

    path: Path
    meta: dict[str, Any]
    content_hash: str
    points: int = 0  # complete rows of points.csv (what an evaluation reads)

    @property
    def uid(self) -> str:
        return str(self.meta["uid"])


def read_run_files(run_dir: Path | str) -> RunFiles:
    """run.json and the content hash (SHA-256 of run.json, a NUL byte, points.csv) of ``run_dir``."""
    path = Path(run_dir).resolve()
    digest = hashlib.sha256()
    try:
        raw = read_run_file(path / "run.json")  # O_NONBLOCK, a regular file only: a planted FIFO never hangs
        meta = json.loads(raw)
    except FileNotFoundError:
        raise RunUnreadable(f"{path}: no run.json (not a run directory)") from None
    except UserError as exc:  # not a regular file
        raise RunUnreadable(str(exc)) from None
    except OSError as exc:
        raise RunUnreadable(f"{path}: run.json cannot be read ({exc.strerror or exc.__class__.__name__})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RunUnreadable(f"{path}: run.json is not valid JSON ({exc.__class__.__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise RunUnreadable(f"{path}: run.json is not a guideway run")
    if not isinstance(meta.get("uid"), str) or not meta["uid"]:
        raise RunUnreadable(f"{path}: run.json has no uid")
    digest.update(raw)
    digest.update(b"\0")
    points = b""
    try:
        points = read_run_file(path / "points.csv")
        digest.update(points)
    except FileNotFoundError:
        pass  # a run that failed before its first point: hashed as empty
    except UserError as exc:  # not a regular file
        raise RunUnreadable(str(exc)) from None
    except OSError as exc:
        raise RunUnreadable(f"{path}: points.csv cannot be read ({exc.strerror or exc.__class__.__name__})") from None
    # the rows under the header ended by a newline (the reader drops a partial last line)
    return RunFiles(path, meta, digest.hexdigest(), max(points.count(b"\n") - 1, 0))


def _mtime_ns(path: Path) -> int:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return 0


def fresh_summary(run_dir: Path) -> dict[str, Any] | None:
    """results/summary.json when it was written after run.json and points.csv last changed (else None:
    missing or stale)."""
    summary = run_dir / "results" / "summary.json"
    written = _mtime_ns(summary)
    if not written or written < max(_mtime_ns(run_dir / name) for name in HASHED_FILES):
        return None
    try:
        data = json.loads(read_run_file(summary).decode("utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, UserError):  # UserError: not a regular file
        return None
    return data if isinstance(data, dict) else None


def _number(v: Any) -> float | None:
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) else None


def headline_values(summary: dict[str, Any], meta: dict[str, Any]) -> dict[str, dict[str, float | None]]:
    """The headline values of an evaluation (``process --json`` object ``summary``) with their standard
    uncertainties, and the run's tolerance limits (run.json ``setup.tolerance``)."""
    tolerance = (meta.get("setup") or {}).get("tolerance") or {}
    out: dict[str, dict[str, float | None]] = {}
    if summary.get("kind") == "straightness":
        unc = summary.get("uncertainty_um") or {}
        k = _number(unc.get("k")) or 2.0
        expanded = unc.get("straightness") or {}
        for line in REFERENCE_LINES:
            value = _number((summary.get("straightness_um") or {}).get(line))
            if value is None:
                continue
            big_u = _number(expanded.get(line))
            entry: dict[str, float | None] = {"value_um": value, "u_um": None if big_u is None else big_u / k}
            if tolerance.get("reference_line", "minimum_zone") == line and _number(tolerance.get("straightness_um")):
                entry["limit_um"] = float(tolerance["straightness_um"])
            out[line] = entry
    elif summary.get("kind") == "positioning":
        unit = "arcsec" if summary.get("unit") == "arcsec" else "um"
        iso = summary.get("iso230_2") or {}
        budget = summary.get("uncertainty") or {}  # the ISO 230-2 Annex A budget per value (u_c: standard)
        for q in (*POSITIONING_QUANTITIES, *SIGNED_QUANTITIES):
            value = _number(iso.get(q))
            if value is None:
                continue
            u_c = _number((budget.get(q) or {}).get("u_c")) if isinstance(budget.get(q), dict) else None
            entry = {f"value_{unit}": value, f"u_{unit}": u_c}
            limit = _number(tolerance.get(f"{q}_{unit}"))
            if limit is not None:
                entry[f"limit_{unit}"] = limit
            out[q] = entry
    return out


def has_tolerance(meta: dict[str, Any]) -> bool:
    return bool((meta.get("setup") or {}).get("tolerance"))


def evaluated_summary(run_dir: Path, meta: dict[str, Any] | None = None) -> tuple[dict[str, Any] | None, str]:
    """The ``process --json`` object of ``run_dir``: from results/summary.json if fresh (and holding the verdict
    of a run with a ``[tolerance]``: a straightness summary.json of an older guideway had none), else evaluated
    now with process' defaults; (None, why) when the run cannot be evaluated."""
    summary = fresh_summary(run_dir)
    if summary is not None and ("verdict" in summary or not has_tolerance(meta or {})):
        return summary, ""
    from saved_runs.evaluation.evaluate import process_run_dir  # pandas and friends only when something is evaluated

    try:
        _, evaluation = process_run_dir(run_dir)
        return evaluation.to_dict(), ""
    except UserError as exc:
        return None, f"not evaluated: {exc}"
    except (ValueError, ArithmeticError) as exc:  # too few points for a line, and the like
        return None, f"not evaluated: {exc.__class__.__name__}: {exc}"


def utc_created(text: str) -> str:
    """run.json ``created`` as the catalogue stores it: UTC, ``YYYY-MM-DDTHH:MM:SSZ`` (a time with another
    offset is converted, one without is UTC), so that the text sorts and compares as time does (``list``
    newest first, ``--since``, the trend's order); text that is not an ISO 8601 time is kept as it is."""
    try:
        when = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        return text
    if when.tzinfo is not None:
        when = when.astimezone(UTC)
    return when.strftime("%Y-%m-%dT%H:%M:%SZ")


_TRIALS = re.compile(r"(\d+) trials")


def evaluation_options(summary: dict[str, Any], points: int) -> tuple[dict[str, Any], dict[str, Any]]:
    """The options a ``process --json`` object was evaluated with, and process' defaults for the run
    (``points``: its rows, on which the default number of Monte Carlo trials depends)."""
    from saved_runs.evaluation.options import DEFAULT_EDITION, DEFAULT_K, DEFAULT_METHOD, default_mc_trials

    accepted = bool(summary.get("out_of_range_accepted"))
    if summary.get("kind") == "straightness":
        unc = summary.get("uncertainty_um") or {}
        trials: int | None = 0  # no Monte Carlo: --mc-trials 0
        if "straightness" in unc:
            found = _TRIALS.search(str(unc.get("straightness_method") or ""))
            trials = int(found[1]) if found else None
        used = {"method": summary.get("method"), "mc_trials": trials, "accept_out_of_range": accepted}
        return used, {"method": DEFAULT_METHOD, "mc_trials": default_mc_trials(points), "accept_out_of_range": False}
    if summary.get("kind") == "positioning":
        used = {"k": _number(summary.get("k")), "edition": summary.get("edition"), "accept_out_of_range": accepted}
        return used, {"k": DEFAULT_K, "edition": DEFAULT_EDITION, "accept_out_of_range": False}
    return {}, {}


INSTRUMENT_KEYS = ("role", "model", "serial", "certificate", "calibrated", "due")


def instrument_records(meta: dict[str, Any]) -> list[dict[str, str]]:
    """The calibration records of the instruments of a run, each with the keys ``role, model, serial,
    certificate, calibrated, due`` (those it has): run.json ``setup.instruments``, the list the set-up's
    ``[[instrument]]`` tables are recorded as; else a top-level ``instruments`` list of such records, or an
    ``instruments`` object whose members carry a ``due`` date (the devices' identities, which carry none, are
    no calibration records).  A run without them gives []."""
    raw = (meta.get("setup") or {}).get("instruments") if isinstance(meta.get("setup"), dict) else None
    if not isinstance(raw, list):
        raw = meta.get("instruments")
    if isinstance(raw, dict):
        items = [{"role": k, **v} for k, v in raw.items() if isinstance(v, dict) and v.get("due")]
    elif isinstance(raw, list):
        items = [v for v in raw if isinstance(v, dict)]
    else:
        items = []
    return [{k: str(v[k]) for k in INSTRUMENT_KEYS if v.get(k) not in (None, "")} for v in items]


def run_facts(meta: dict[str, Any], summary: dict[str, Any] | None = None) -> dict[str, Any]:
    """What the fleet overview shows of a run besides its values: ``operator``, the controller
    ``compensation`` state (``{"active": true, "file", "sha256"}``, ``{"active": false}``, or
    ``{"active": null}``: not recorded), the ``instruments`` calibration records and the ``decision_rule``
    of the verdict as the evaluation names it (None: not named)."""
    comp = run_compensation(meta)
    state: dict[str, Any] = {"active": comp.get("active") if comp.get("recorded") else None}
    if state["active"]:
        state.update({"file": str(comp.get("file") or ""), "format": str(comp.get("format") or ""),
                      "sha256": str(comp.get("sha256") or "")})
    verdict = (summary or {}).get("verdict")
    rule = None
    if isinstance(verdict, dict):
        rule = verdict.get("decision_rule") or verdict.get("rule")
    return {"operator": str(meta.get("operator") or ""), "compensation": state,
            "instruments": instrument_records(meta), "decision_rule": None if rule is None else str(rule)}


def make_entry(files: RunFiles) -> Entry:
    """The catalogue entry of a run read by :func:`read_run_files` (evaluating it if its results are missing
    or stale)."""
    meta = files.meta
    summary, note = evaluated_summary(files.path, meta)
    values = headline_values(summary, meta) if summary is not None else {}
    verdict = (summary or {}).get("verdict")
    options, defaults = evaluation_options(summary, files.points) if summary is not None else ({}, {})
    return Entry(uid=files.uid, path=str(files.path), **identity(meta), content_hash=files.content_hash,
                 values=values, verdict=verdict.get("result") if isinstance(verdict, dict) else None, note=note,
                 options=options, option_defaults=defaults, facts=run_facts(meta, summary))


def identity(meta: dict[str, Any]) -> dict[str, str]:
    """What an entry holds of run.json besides its uid: machine, axis, kind, created (UTC) and status."""
    return {"machine": str(meta.get("machine") or ""), "axis": run_axis(meta), "kind": str(meta.get("kind") or ""),
            "created": utc_created(str(meta.get("created") or "")), "status": str(meta.get("status") or "")}
