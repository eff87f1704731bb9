"""As-found / as-left pairs among saved runs (the TUI's runs browser and Results screen; docs/tui.md).

A run measured with a compensation table active (run.json ``compensation.sha256``) is the **as-left** of
the run whose ``results/exports.json`` records an export of those bytes from that run (its uid): that run
is its **as-found**.  ``guideway verify FOUND LEFT`` checks the same link (fleet/verify/verify.py); here it
is only looked up, from run.json and exports.json, with no numerical library: the runs browser lists at
once.  A record copied with ``results/`` from another run (another uid) does not count.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from saved_runs.catalog.folder import files_stamp
from saved_runs.errors import RunFormatError
from saved_runs.export.provenance import find_export, read_exports
from saved_runs.store.files import read_run_file


@dataclass(frozen=True)
class RunLink:
    """What pairing needs of one run: its uid, the SHA-256 of the table it was measured with (None: none or
    not recorded) and the SHA-256s of the tables exported from it (exports.json records naming its uid)."""

    path: Path
    uid: str | None
    table_sha256: str | None
    exported: frozenset[str]


def _meta(run_dir: Path) -> dict[str, Any]:
    try:  # read_run_file: a FIFO or device planted at run.json is not read (it would wait forever)
        meta = json.loads(read_run_file(run_dir / "run.json").decode("utf-8"))
    except (OSError, RunFormatError, UnicodeDecodeError, json.JSONDecodeError):
        return {}
    return meta if isinstance(meta, dict) else {}


def table_sha256(meta: dict[str, Any]) -> str | None:
    """The SHA-256 of the compensation table active while the run was measured (run.json ``compensation``),
    None when none was, or the run does not record it."""
    rec = meta.get("compensation")
    if isinstance(rec, dict) and rec.get("active") and isinstance(rec.get("sha256"), str):
        return rec["sha256"]
    return None


_CACHE: dict[Path, tuple[tuple[int, ...], RunLink]] = {}


def run_link(run_dir: Path) -> RunLink:
    """:class:`RunLink` of ``run_dir`` (kept while its run.json and exports.json stay the same)."""
    stamp = files_stamp(run_dir, ("run.json", "results/exports.json"))
    cached = _CACHE.get(run_dir)
    if cached is not None and cached[0] == stamp:
        return cached[1]
    meta = _meta(run_dir)
    uid = meta.get("uid") if isinstance(meta.get("uid"), str) else None
    exported = frozenset(r["sha256"] for r in read_exports(run_dir)
                         if isinstance(r.get("sha256"), str) and (uid is None or r.get("run_uid") in (None, uid)))
    link = RunLink(run_dir, uid, table_sha256(meta), exported)
    _CACHE[run_dir] = (stamp, link)
    return link


@dataclass(frozen=True)
class Pairs:
    """``found_of[left] = found`` and ``lefts_of[found] = [left, ...]`` (newest first, as listed)."""

    found_of: dict[Path, Path]
    lefts_of: dict[Path, list[Path]]


def found_left_pairs(runs: list[Path]) -> Pairs:
    """The as-found / as-left pairs among ``runs``: a run measured with a table that another of them exported
    is that run's as-left (a run is never its own as-found)."""
    links = [run_link(p) for p in runs]
    exporter: dict[str, Path] = {}
    for link in links:
        for sha in link.exported:
            exporter.setdefault(sha, link.path)
    found_of: dict[Path, Path] = {}
    lefts_of: dict[Path, list[Path]] = {}
    for link in links:
        found = exporter.get(link.table_sha256 or "")
        if found is not None and found != link.path:
            found_of[link.path] = found
            lefts_of.setdefault(found, []).append(link.path)
    return Pairs(found_of, lefts_of)


def found_run_of(left: Path, search: list[Path]) -> Path | None:
    """The as-found run of the run at ``left``: first the run where the table lies (``FOUND/results/...``) when
    its results/ holds it (exports.json, else the table's own bytes among ``results/compensation-*``, as verify
    finds it), then a run in the folders ``search`` whose exports.json records it; None when ``left`` was
    measured with no table or none is found."""
    meta = _meta(left)
    sha = table_sha256(meta)
    if sha is None:
        return None
    left_resolved = left.resolve()
    path = (meta.get("compensation") or {}).get("path")
    if isinstance(path, str) and Path(path).parent.name == "results":  # FOUND/results/compensation-*
        owner = Path(path).parent.parent
        if (owner / "run.json").is_file() and owner.resolve() != left_resolved and \
                find_export(owner, sha, run_link(owner).uid) is not None:
            return owner
    # elsewhere (export --out): the exports.json records of the runs in the folders (no file is hashed)
    for folder in search:
        try:
            runs = sorted(d for d in Path(folder).iterdir() if (d / "run.json").is_file())
        except OSError:
            continue
        for cand in runs:
            if sha in run_link(cand).exported and cand.resolve() != left_resolved:
                return cand
    return None
