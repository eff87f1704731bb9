"""``guideway simulate SCENARIO.toml --out RUN_DIR [--seed S]``: a synthetic run of a scenario."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import seed as seed_arg


def run(args: argparse.Namespace) -> int:
    from acquisition.simulated.synthetic import simulate_run

    out, n = simulate_run(args.scenario, args.out, seed=args.seed, noise=not args.no_noise)
    print(f"simulated run: {n} points in {out}")
    print(f"process it with: guideway process {out}; diagnose it with: guideway diagnose {out} --model MODEL.toml")
    return 0


def register(sub) -> None:  # noqa: ANN001
    p = sub.add_parser("simulate", help="write a synthetic run of a scenario (effects hidden in simulated data)",
                       description="Simulate the run a scenario file describes (test cycle, timing, noise and "
                                   "physical effects, docs/diagnosis.md) and write it in the run-directory format "
                                   "of a measured run.")
    p.add_argument("scenario", type=Path, help="scenario file (TOML)")
    p.add_argument("--out", type=Path, required=True, help="run directory to write (new or empty)")
    p.add_argument("--seed", type=seed_arg, default=None, help="noise seed (default: the scenario's seed, else 0)")
    p.add_argument("--no-noise", action="store_true", help="switch the simulated noise off")
    p.set_defaults(func=run)
