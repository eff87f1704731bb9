"""``guideway demo``: a complete simulated gauge-block straightness run."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import seed as seed_arg
from . import sized


def run(args: argparse.Namespace) -> int:
    from acquisition.demo import run_demo

    run_demo(args.out, stations=args.stations, seed=args.seed, noise=not args.no_noise,
             samples=args.samples, faults=args.faults, sensor=args.sensor, stream=sys.stdout)
    return 0


def register(sub) -> None:  # noqa: ANN001
    d = sub.add_parser("demo", help="complete simulated gauge-block straightness run")
    d.add_argument("--out", type=Path, default=None, help="new run directory (default runs/demo-<UTC time>)")
    d.add_argument("--stations", type=sized("stations", 2), default=20,
                   help="stations including the datum (default 20, at most 100000)")
    d.add_argument("--seed", type=seed_arg, default=0, help="seed of the simulated world (default 0)")
    d.add_argument("--samples", type=sized("samples_per_reading", 1), default=5,
                   help="sensor samples averaged per station (default 5, at most 10000)")
    d.add_argument("--sensor", default="keyence-lkg", metavar="PROTOCOL",
                   help="simulated sensor family: keyence-lkg (default), panasonic-hlg1 or me-ild1420")
    d.add_argument("--no-noise", action="store_true", help="switch the simulated instrument noise off")
    d.add_argument("--faults", default=None, metavar="SPEC",
                   help="inject device faults, e.g. sensor:garbage@12 (DEVICE:KIND@N[xCOUNT][=ARG])")
    d.set_defaults(func=run)
