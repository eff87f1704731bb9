"""``guideway catalog add|list|remove``: the catalogue of saved runs (docs/fleet.md).

    guideway catalog add RUN... | --scan DIR   [--catalog URL]
    guideway catalog list [--machine M] [--axis A] [--kind K] [--since DATE] [--json] [--catalog URL]
    guideway catalog remove RUN [--catalog URL]

``--catalog`` (or ``GUIDEWAY_CATALOG``) names the database: ``sqlite:///PATH`` or
``postgresql://USER@HOST/DB``; default a SQLite file in the user's data directory.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any


def _open(args: argparse.Namespace, create: bool = False) -> Any:
    """The catalogue of ``--catalog``; only ``add`` makes a new one (a mistyped URL to list or
    remove from is said, not created)."""
    from fleet.catalog.database import open_catalog

    return open_catalog(args.catalog, create=create)


def run_add(args: argparse.Namespace) -> int:
    from fleet.catalog.runs import add_runs, scan_run_dirs
    from saved_runs.errors import UserError

    from .progress import progress_display, short

    if bool(args.runs) == (args.scan is not None):
        raise UserError("give run directories (guideway catalog add RUN...) or --scan DIR, not both or neither")
    counts: dict[str, int] = {}
    with progress_display() as stages:
        if args.scan is not None:
            stages.stage(f"scanning {short(args.scan)}")
        dirs = scan_run_dirs(args.scan) if args.scan is not None else list(args.runs)
        with _open(args, create=True) as cat:
            for outcome in add_runs(cat, dirs, progress=stages.stage(f"adding {len(dirs)} run(s)")):
                counts[outcome.action] = counts.get(outcome.action, 0) + 1
                print(outcome.message, file=sys.stderr if outcome.action == "unreadable" else sys.stdout)
            print(f"catalogue {cat.url}: " + (", ".join(f"{n} {a}" for a, n in sorted(counts.items()))
                                              or "no run found"))
    if counts.get("unreadable"):
        raise UserError(f"{counts['unreadable']} run director{'y' if counts['unreadable'] == 1 else 'ies'} could not "
                        "be read (listed above; the others were added): fix or remove them and add again")
    return 0


def headline(values: dict[str, Any]) -> str:
    """The first headline value of an entry as text (minimum zone straightness, or E)."""
    for name in ("minimum_zone", "E", *values):
        v = values.get(name)
        if v:
            unit = "arcsec" if "value_arcsec" in v else "um"
            u = v.get(f"u_{unit}")
            return f"{name} {v[f'value_{unit}']:.3f}" + (f"±{u:.3f}" if u is not None else "") + f" {unit}"
    return "-"


def printable(text: str) -> str:
    """``text`` with its control characters escaped (a newline as ``\\n``, ESC as ``\\x1b``): a machine name
    holding a terminal escape code must not drive the terminal, nor a newline forge a line of the list."""
    escapes = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
    return "".join(ch if ch.isprintable() else escapes.get(ch) or (f"\\x{ord(ch):02x}" if ord(ch) < 0x100 else
                                                                    f"\\u{ord(ch):04x}") for ch in text)


def printable_entry(e: Any) -> Any:
    """An entry with the text it is listed with made :func:`printable`."""
    from dataclasses import replace

    return replace(e, **{k: printable(getattr(e, k)) for k in ("machine", "axis", "kind", "status", "created",
                                                               "path")}, verdict=printable(e.verdict or "") or None)


def options_line(e: Any) -> str:
    """The line under an entry whose values were evaluated with other options than ``guideway process``'s
    defaults ("" when with the defaults), or whose options are not known (an entry of an older guideway)."""
    if e.options is None:
        return "    evaluation options not recorded (an entry of an older guideway): add the run again"
    other = e.non_default_options()
    if not other:
        return ""
    used = ", ".join(f"{k} {v}" for k, v in other.items())
    defaults = ", ".join(f"{k} {e.option_defaults[k]}" for k in other)
    return printable(f"    evaluated with {used}, not the defaults of guideway process ({defaults})")


def run_list(args: argparse.Namespace) -> int:
    from fleet.catalog.clock import future_cutoff, is_future
    from fleet.catalog.runs import list_entries

    with _open(args) as cat:
        entries = list_entries(cat, machine=args.machine, axis=args.axis, kind=args.kind, since=args.since)
        future = {e.uid for e in entries if is_future(e.created)}  # a rig clock ahead: flagged, left out of trends
        if args.json:
            json.dump({"runs": [e.to_dict() for e in entries],
                       "future_dated": [e.uid for e in entries if e.uid in future]}, sys.stdout, allow_nan=False)
            sys.stdout.write("\n")
            return 0
        for e in map(printable_entry, entries):
            print(f"{e.created:<20} {e.machine or '-':<14} {e.axis or '-':<6} {e.kind:<12} {e.status:<11} "
                  f"{e.verdict or '-':<6} {headline(e.values):<28} {e.compensation_text():<25} {e.path}")
            if e.uid in future:
                print(f"  ^ dated in the future (created {e.created}): check the rig's clock; left out of trends")
            if options_line(e):
                print(options_line(e))
        print(f"{len(entries)} run(s) in {cat.url}", file=sys.stderr)
        if future:
            print(f"note: {len(future)} run(s) created later than {future_cutoff():%Y-%m-%dT%H:%M:%SZ} (now + 1 day), "
                  "marked ^: their rig's clock was wrong; trends leave them out", file=sys.stderr)
    return 0


def run_remove(args: argparse.Namespace) -> int:
    from fleet.catalog.runs import remove_run

    with _open(args) as cat:
        gone = remove_run(cat, args.run)
        print(f"removed {gone.uid} ({gone.path}) from {cat.url}; the run directory is untouched")
    return 0


def add_catalog_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--catalog", default=None, metavar="URL",
                        help="catalogue database: sqlite:///PATH or postgresql://USER@HOST/DB (default: "
                             "$GUIDEWAY_CATALOG, else a SQLite file in your data directory)")


def register(sub) -> None:  # noqa: ANN001
    c = sub.add_parser("catalog", help="the catalogue of saved runs across machines and years (add, list, remove)")
    cs = c.add_subparsers(dest="catalog_command", required=True, parser_class=type(c))
    a = cs.add_parser("add", help="add run directories (again: no change; edited or moved: said and updated)")
    a.add_argument("runs", nargs="*", type=Path, metavar="RUN")
    a.add_argument("--scan", type=Path, default=None, metavar="DIR", help="add every run directory under DIR")
    add_catalog_option(a)
    a.set_defaults(func=run_add)
    ls = cs.add_parser("list", help="list catalogued runs, newest first")
    ls.add_argument("--machine", default=None)
    ls.add_argument("--axis", default=None)
    ls.add_argument("--kind", default=None, choices=("straightness", "positioning"))
    ls.add_argument("--since", default=None, metavar="DATE", help="runs created at or after DATE (YYYY-MM-DD, UTC)")
    ls.add_argument("--json", action="store_true", help='print {"runs": [...]} on stdout')
    add_catalog_option(ls)
    ls.set_defaults(func=run_list)
    r = cs.add_parser("remove", help="remove a run from the catalogue (its directory stays)")
    r.add_argument("run", metavar="RUN", help="run directory or uid")
    add_catalog_option(r)
    r.set_defaults(func=run_remove)
