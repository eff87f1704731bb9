"""``guideway fleet``: every machine, axis and tolerance value of the catalogue at a glance, most urgent first;
``guideway fleet check --within DAYS`` for a scheduled job (docs/fleet.md, "Fleet overview").

    guideway fleet [--machine M] [--json | --csv] [--report FILE] [--catalog URL]
    guideway fleet check --within DAYS [--machine M] [--catalog URL]

``fleet check`` exits 0 when nothing needs attention within DAYS, 1 when something does (one line each,
most urgent first), 2 on an error.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from .catalog import add_catalog_option

EXIT_ATTENTION = 1


def _overview(args: argparse.Namespace):  # noqa: ANN202 - fleet.overview is imported lazily
    from fleet.catalog.database import open_catalog
    from fleet.overview.overview import fleet_overview

    with open_catalog(args.catalog, create=False) as cat:  # a mistyped URL is said, not created
        return fleet_overview(cat, args.machine)


def run(args: argparse.Namespace) -> int:
    ov = _overview(args)
    if args.report is not None:
        from fleet.overview.output import write_report

        write_report(ov, args.report)
    if args.json:
        json.dump(ov.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    elif args.csv:
        from fleet.overview.output import csv_text

        sys.stdout.write(csv_text(ov))
    else:
        from fleet.overview.output import print_text

        print_text(ov, sys.stdout)
        if args.report is not None:
            print(f"report written to {args.report}")
    return 0


def run_check(args: argparse.Namespace) -> int:
    from fleet.overview.output import printable
    from saved_runs.errors import UserError

    if not (math.isfinite(args.within) and args.within >= 0):
        raise UserError(f"--within must be a number of days >= 0, got {args.within}")
    ov = _overview(args)
    items = ov.attention(args.within)
    for a in items:
        print(printable(a.line))
    if not items:
        print(f"nothing needs attention within {args.within:g} days ({len(ov.rows)} row(s), {len(ov.instruments)} "
              f"instrument(s) in {ov.url})", file=sys.stderr)
        return 0
    print(f"{len(items)} item(s) need attention within {args.within:g} days", file=sys.stderr)
    return EXIT_ATTENTION


def register(sub) -> None:  # noqa: ANN001
    f = sub.add_parser("fleet", help="every machine axis of the catalogue at a glance, most urgent first")
    f.add_argument("--machine", default=None, help="only this machine")
    out = f.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    out.add_argument("--csv", action="store_true", help="print CSV (one header line) on stdout")
    f.add_argument("--report", type=Path, default=None, metavar="FILE",
                   help="write a printable HTML page with a small trend plot per row")
    add_catalog_option(f)
    f.set_defaults(func=run)
    fs = f.add_subparsers(dest="fleet_command", parser_class=type(f))
    c = fs.add_parser("check", help="exit 1 (one line each) when something needs attention within DAYS, else 0")
    c.add_argument("--within", type=float, required=True, metavar="DAYS",
                   help="crossing dates and calibrations due within DAYS count (0: only what is due now)")
    # SUPPRESS: not given here, `fleet --machine M check` keeps the M given before `check`
    c.add_argument("--machine", default=argparse.SUPPRESS, help="only this machine")
    c.add_argument("--catalog", default=argparse.SUPPRESS, metavar="URL", help="as for guideway fleet")
    c.set_defaults(func=run_check)
