"""``guideway catalog add|list|remove``: the catalogue of saved runs (docs/fleet.md).

    guideway catalog add RUN... | --scan DIR   [--catalog URL]
    guideway catalog list [--machine M] [--axis A] [--kind K] [--since DATE] [--json] [--catalog URL]
    guideway catalog remove RUN [--catalog URL]
    guideway catalog tolerance --machine M --axis A --value V --limit L | --list [--machine M] | --remove ...
    guideway catalog interval --machine M --axis A --days D | --list [--machine M] | --remove ...

``--catalog`` (or ``GUIDEWAY_CATALOG``) names the database: ``sqlite:///PATH`` or
``postgresql://USER@HOST/DB``; default a SQLite file in the user's data directory.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from saved_runs.errors import printable  # control characters escaped: one helper for every name shown


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
                print(printable(outcome.message), file=sys.stderr if outcome.action == "unreadable" else sys.stdout)
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


def _setting_args(args: argparse.Namespace, what: str, needed: tuple[str, ...]) -> None:
    """Refuse a set or remove that lacks one of ``needed`` (one line naming it)."""
    from saved_runs.errors import UserError

    missing = [f"--{n}" for n in needed if getattr(args, n) is None]
    if missing:
        raise UserError(f"catalog {what}: give {', '.join(missing)} (or --list to see what is kept)")


def run_tolerance(args: argparse.Namespace) -> int:
    """Set, list or remove the tolerances the catalogue keeps per machine axis (the fleet overview's limits)."""
    from fleet.catalog.settings import list_tolerances, remove_tolerance, set_tolerance

    with _open(args) as cat:
        if args.list:
            tols = list_tolerances(cat, args.machine)
            if args.json:
                json.dump({"tolerances": [t.to_dict() for t in tols]}, sys.stdout, allow_nan=False)
                sys.stdout.write("\n")
            for t in ([] if args.json else tols):
                print(printable(f"{t.machine or '-':<14} {t.axis or '-':<6} {t.value:<14} {t.limit_um:g}  "
                                f"(set {t.set_at})"))
            if not args.json:
                print(f"{len(tols)} tolerance(s) in {cat.url}", file=sys.stderr)
            return 0
        if args.remove:
            _setting_args(args, "tolerance --remove", ("machine", "axis", "value"))
            remove_tolerance(cat, args.machine, args.axis, args.value)
            print(printable(f"removed the tolerance of {args.value} on machine {args.machine} axis {args.axis}: "
                            "the runs' own [tolerance] applies again"))
            return 0
        _setting_args(args, "tolerance", ("machine", "axis", "value", "limit"))
        t = set_tolerance(cat, args.machine, args.axis, args.value, args.limit)
        print(printable(f"tolerance of {t.value} on machine {t.machine} axis {t.axis}: {t.limit_um:g} (um; arcsec "
                        f"on a rotary axis), kept in {cat.url}"))
    return 0


def run_interval(args: argparse.Namespace) -> int:
    """Set, list or remove the calibration intervals the catalogue keeps per machine axis."""
    from fleet.catalog.settings import list_intervals, remove_interval, set_interval

    with _open(args) as cat:
        if args.list:
            ivs = list_intervals(cat, args.machine)
            if args.json:
                json.dump({"intervals": [i.to_dict() for i in ivs]}, sys.stdout, allow_nan=False)
                sys.stdout.write("\n")
            for i in ([] if args.json else ivs):
                print(printable(f"{i.machine or '-':<14} {i.axis or '-':<6} every {i.days:g} days  (set {i.set_at})"))
            if not args.json:
                print(f"{len(ivs)} interval(s) in {cat.url}", file=sys.stderr)
            return 0
        if args.remove:
            _setting_args(args, "interval --remove", ("machine", "axis"))
            remove_interval(cat, args.machine, args.axis)
            print(printable(f"removed the calibration interval of machine {args.machine} axis {args.axis}"))
            return 0
        _setting_args(args, "interval", ("machine", "axis", "days"))
        i = set_interval(cat, args.machine, args.axis, args.days)
        print(printable(f"calibration interval of machine {i.machine} axis {i.axis}: {i.days:g} days, kept in "
                        f"{cat.url}"))
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
    tl = cs.add_parser("tolerance", help="keep the tolerance of a value per machine axis (the fleet overview's limit)")
    tl.add_argument("--machine", default=None)
    tl.add_argument("--axis", default=None)
    tl.add_argument("--value", default=None, metavar="NAME", help="minimum_zone, least_squares, endpoint, E, M, B, ...")
    tl.add_argument("--limit", type=float, default=None, metavar="L", help="limit in um (arcsec on a rotary axis)")
    what = tl.add_mutually_exclusive_group()
    what.add_argument("--list", action="store_true", help="list the tolerances kept (of --machine)")
    what.add_argument("--remove", action="store_true", help="forget the tolerance of --machine --axis --value")
    tl.add_argument("--json", action="store_true", help='with --list: print {"tolerances": [...]}')
    add_catalog_option(tl)
    tl.set_defaults(func=run_tolerance)
    iv = cs.add_parser("interval", help="keep the calibration interval of a machine axis (days between runs)")
    iv.add_argument("--machine", default=None)
    iv.add_argument("--axis", default=None)
    iv.add_argument("--days", type=float, default=None, metavar="D", help="a run is due D days after the last one")
    what = iv.add_mutually_exclusive_group()
    what.add_argument("--list", action="store_true", help="list the intervals kept (of --machine)")
    what.add_argument("--remove", action="store_true", help="forget the interval of --machine --axis")
    iv.add_argument("--json", action="store_true", help='with --list: print {"intervals": [...]}')
    add_catalog_option(iv)
    iv.set_defaults(func=run_interval)
