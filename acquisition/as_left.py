"""The as-left run of an as-found run: measured again on the same set-up with the table exported from it
active in the controller (docs/compensation.md "The loop"; the TUI's Results screen starts it, docs/tui.md).

Its set-up is the as-found run's own (run.json ``setup_source``: the same targets, trigger and devices) with
``[compensation]`` naming the table, as ``acquire positioning --compensation FILE`` builds it; its folder is
named after the as-found run (``FOUND-left``, ``FOUND-left-2``, ...: never an existing one).  A simulated
as-found run is measured again in the same simulated world (its scenario and noise setting) with the next
seed: the same machine errors, other noise, as two real runs have.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import TYPE_CHECKING, Any

from saved_runs.errors import SetupError

from .setup.compensation import COMPENSATION_FORMATS

if TYPE_CHECKING:
    from .acquire import SimOptions


def as_left_dir(found: Path) -> Path:
    """``FOUND-left`` beside the as-found run, or ``FOUND-left-2``, ``-3`` ... when that exists."""
    found = Path(found)
    out = found.parent / f"{found.name}-left"
    n = 2
    while out.exists():
        out = found.parent / f"{found.name}-left-{n}"
        n += 1
    return out


def as_left_source(found_meta: dict[str, Any], found_dir: Path, table: Path, fmt: str, *,
                   comp_file_type: int | None = None, backlash: float | None = None) -> dict[str, Any]:
    """The as-found run's set-up (its run.json ``setup_source``) with ``[compensation]`` = ``table`` (an
    absolute path), its controller format ``fmt``, the LinuxCNC ``comp_file_type`` and the backlash
    parameter entered with it (``backlash``, the lost motion in um or arcsec: Siemens MD32450); one-line
    :class:`SetupError` when the run cannot be measured again."""
    if found_meta.get("kind") != "positioning":
        raise SetupError(f"{found_dir.name} is a {found_meta.get('kind')} run; only positioning runs are measured "
                         "again with a compensation table")
    if fmt not in COMPENSATION_FORMATS:
        raise SetupError(f"a {fmt} table is for other software: the simulated and real controllers load "
                         f"{', '.join(COMPENSATION_FORMATS)} tables; write one of those (keys 1-3)")
    source = found_meta.get("setup_source")
    if not isinstance(source, dict):
        raise SetupError(f"{found_dir.name}: run.json holds no set-up (setup_source) to measure again with; start "
                         "the as-left run from the set-up file: guideway acquire positioning --setup S "
                         f"--compensation {table}")
    source = copy.deepcopy(source)
    table_cfg: dict[str, Any] = {"file": str(Path(table).resolve()), "format": fmt}
    if fmt == "linuxcnc":
        table_cfg["comp_file_type"] = 1 if comp_file_type is None else comp_file_type
    if backlash is not None:
        rotary = (source.get("axis") or {}).get("type") == "rotary"
        table_cfg["backlash_arcsec" if rotary else "backlash_um"] = backlash
    source["compensation"] = table_cfg
    axis = source.get("axis")
    if isinstance(axis, dict):  # measured on the same targets (the table's points), not shifted ones
        source["axis"] = {k: v for k, v in axis.items() if k not in ("shift_targets_mm", "shift_targets_deg")}
    return source


def as_left_simulation(found_meta: dict[str, Any], default: SimOptions) -> SimOptions:
    """The simulated world of the as-left run: the as-found run's (run.json ``simulation``: scenario, noise)
    with the next seed (the same machine errors, other noise); ``default`` when the run records none."""
    from dataclasses import replace

    stored = found_meta.get("simulation")
    if not isinstance(stored, dict) or "seed" not in stored:
        return replace(default, faults=None)
    try:
        sim = default.resumed(stored)
    except (KeyError, TypeError, ValueError):
        return replace(default, faults=None)
    return replace(sim, seed=sim.seed + 1, faults=None)
