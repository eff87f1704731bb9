"""``guideway trend --machine M --axis A --value NAME [--limit L] [--json] [--report FILE]``: one headline
value over every catalogued run of a machine axis, its slope per year, the date it reaches the limit and
the steps between runs (docs/fleet.md)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .catalog import add_catalog_option


def run(args: argparse.Namespace) -> int:
    from fleet.catalog.database import open_catalog
    from fleet.trend.of_catalog import axis_trend

    with open_catalog(args.catalog, create=False) as cat:  # a mistyped URL is said, not created
        at = axis_trend(cat, args.machine, args.axis, args.value, args.limit)
    if args.report is not None:
        from fleet.trend.report import write_trend_report

        write_trend_report(at, args.report)
    if args.json:
        json.dump(at.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        at.print_text(sys.stdout)
        if args.report is not None:
            print(f"report written to {args.report}")
    return 0


def register(sub) -> None:  # noqa: ANN001
    t = sub.add_parser("trend", help="a value over every catalogued run of a machine axis: slope per year, limit date")
    t.add_argument("--machine", required=True, help="machine name as in run.json (\"\" for none)")
    t.add_argument("--axis", required=True, help="axis name as in run.json")
    t.add_argument("--value", required=True, metavar="NAME",
                   help="E, M, B, B_mean, A, R, ... (positioning) or endpoint, least_squares, minimum_zone "
                        "(straightness); B is a magnitude (largest |B_i|), B_mean the signed mean reversal")
    t.add_argument("--limit", type=float, default=None, metavar="L",
                   help="limit in um (arcsec on a rotary axis); default the newest run's [tolerance]")
    t.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    t.add_argument("--report", type=Path, default=None, metavar="FILE", help="write an HTML report with a plot")
    add_catalog_option(t)
    t.set_defaults(func=run)
