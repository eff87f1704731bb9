"""A run's history in the catalogue: the earlier runs of the same machine, axis and kind.

``guideway diagnose RUN --noise-history N`` estimates the serial correlation of the machine's errors
from them as well as from RUN (docs/diagnosis.md, "Under correlated noise"): one run of a few hundred
points fixes it too loosely for the tests of a slow effect.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from saved_runs.errors import UserError, printable

from .clock import is_future
from .database import Catalog
from .entry import identity, read_run_files
from .runs import list_entries, still_holds


@dataclass(frozen=True)
class History:
    """The earlier runs found for a run (newest first), and what the search said."""

    runs: tuple[Path, ...]
    note: str  # one line: what was found, or why fewer than asked


def earlier_runs(cat: Catalog, run_dir: Path | str, count: int) -> History:
    """Up to ``count`` complete runs of ``run_dir``'s machine, axis and kind catalogued as created before it,
    newest first, whose directories still hold them.  A run that records no machine, axis or creation time
    has no history the catalogue can tell (refused: name the runs instead)."""
    if count < 1:
        raise UserError(f"--noise-history {count}: give the number of earlier runs to use (1 or more)")
    files = read_run_files(run_dir)
    me = identity(files.meta)
    missing = [key for key in ("machine", "axis", "created") if not me[key]]
    if missing:
        raise UserError(f"{run_dir}: run.json records no {' or '.join(missing)}, so the catalogue cannot tell "
                        "the same machine's earlier runs; name them with --noise-from RUN...")
    found: list[Path] = []
    future: list[str] = []  # dated in the future (a rig clock ahead): left out, named in the note
    for entry in list_entries(cat, machine=me["machine"], axis=me["axis"], kind=me["kind"]):
        if len(found) == count:
            break
        if (entry.uid != files.uid and entry.status == "complete" and entry.created < me["created"]
                and still_holds(entry.path, entry.uid)):
            if is_future(entry.created):  # "earlier" only by a wrong clock (RUN's is wrong too): not its history
                future.append(f"{Path(entry.path).name} (created {entry.created})")
                continue
            found.append(Path(entry.path))
    what = f"machine {me['machine']!r}, axis {me['axis']!r}"
    if not found:
        note = f"no earlier complete run of {what} in the catalogue {cat.url}: the run's own estimate is used"
    else:
        note = (f"{len(found)} earlier run(s) of {what} from the catalogue {cat.url}"
                + (f" (asked for {count})" if len(found) < count else ""))
    if future:
        note += (f"; left out {len(future)} run(s) dated in the future (check the rig's clock): "
                 + ", ".join(future))
    return History(tuple(found), printable(note))
