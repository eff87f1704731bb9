"""The ``guideway`` command line.

Every expected failure (bad input, bad file, unreachable or misbehaving
device) ends with a one-line ``guideway: error: ...`` on stderr and exit code 2;
never a traceback.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from acquisition.errors import UserError
from drivers.errors import DriverError

EXIT_USAGE = 2

Handler = Callable[[argparse.Namespace], int]


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse prints usage too)
        self.print_usage(sys.stderr)
        print(f"guideway: error: {message}", file=sys.stderr)
        raise SystemExit(EXIT_USAGE)


def cmd_demo(args: argparse.Namespace) -> int:
    from acquisition.demo import run_demo

    run_demo(args.out, stations=args.stations, seed=args.seed, noise=not args.no_noise,
             samples=args.samples, faults=args.faults)
    return 0


def cmd_process(args: argparse.Namespace) -> int:
    from acquisition.demo import print_summary
    from acquisition.evaluate import process_run_dir
    from acquisition.results import write_straightness_results

    run, result = process_run_dir(args.run_dir)
    for w in run.warnings:
        print(f"guideway: warning: {w}", file=sys.stderr)
    if run.meta.get("status") != "complete":
        print(f"guideway: warning: run status is {run.meta.get('status')!r}; processing the "
              f"{len(run.points)} point(s) recorded", file=sys.stderr)
    if not args.no_write:
        write_straightness_results(run.path, result)
    if args.json:
        json.dump(result.to_dict(), sys.stdout, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print_summary(result, sys.stdout)
        if not args.no_write:
            print(f"results written to {run.path / 'results'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="guideway", description="Guideway straightness and machine-axis calibration.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    d = sub.add_parser("demo", help="complete simulated gauge-block straightness run")
    d.add_argument("--out", type=Path, default=None, help="new run directory (default runs/demo-<UTC time>)")
    d.add_argument("--stations", type=int, default=20, help="stations including the datum (default 20)")
    d.add_argument("--seed", type=int, default=0, help="seed of the simulated world (default 0)")
    d.add_argument("--samples", type=int, default=5, help="sensor samples averaged per station (default 5)")
    d.add_argument("--no-noise", action="store_true", help="switch the simulated instrument noise off")
    d.add_argument("--faults", default=None, metavar="SPEC",
                   help="inject device faults, e.g. sensor:garbage@12 (DEVICE:KIND@N[xCOUNT][=ARG])")
    d.set_defaults(func=cmd_demo)

    pr = sub.add_parser("process", help="evaluate a saved run and write its results")
    pr.add_argument("run_dir", type=Path)
    pr.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    pr.add_argument("--no-write", action="store_true", help="do not write results/")
    pr.set_defaults(func=cmd_process)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (UserError, DriverError) as exc:
        print(f"guideway: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("guideway: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
