"""``guideway tui``: the Textual TUI (set-up, guided capture, results, saved runs).

    guideway tui [--simulate] [--setup SETUP.toml] [--out RUN_DIR] [--runs DIR] [--catalog URL]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from . import seed as seed_arg


def run(args: argparse.Namespace) -> int:
    from saved_runs.errors import SetupError

    if args.faults and not args.simulate:
        raise SetupError("--faults needs --simulate (faults are injected into the simulated devices)")
    if args.faults:
        from acquisition.simulated.faults import parse_faults

        parse_faults(args.faults)  # a bad spec fails here, not in the middle of the screen
    source = None
    if args.setup is not None:  # (the loaders are imported only with a file: the first frame comes sooner)
        from acquisition.setup.files import setup_kind
        from saved_runs.toml_file import read_toml

        source = read_toml(args.setup)
        setup_kind(source)
    from tui.app import GuidewayApp  # Textual only now: the rest of the command line never loads it

    app = GuidewayApp(setup_source=source, setup_path=args.setup, out=args.out, runs_dir=args.runs,
                      simulate=args.simulate, seed=args.seed, noise=not args.no_noise, faults=args.faults,
                      catalog_url=args.catalog)
    app.run()
    return 0


def register(sub) -> None:  # noqa: ANN001
    t = sub.add_parser("tui", help="technician-guided measurement sessions and saved runs in a full-screen terminal UI")
    t.add_argument("--simulate", action="store_true", help="simulated devices on real transports (rehearse a session)")
    t.add_argument("--setup", type=Path, default=None, help="open with this set-up file (TOML) loaded")
    t.add_argument("--out", type=Path, default=None, help="run directory of the next run (default RUNS/KIND-<time>)")
    t.add_argument("--runs", type=Path, default=Path("runs"), help="folder the run browser lists (default runs/)")
    t.add_argument("--catalog", default=None, metavar="URL",
                   help="the runs browser lists this catalogue (default GUIDEWAY_CATALOG, if set; docs/fleet.md)")
    t.add_argument("--seed", type=seed_arg, default=0, help="--simulate: seed of the simulated world (default 0)")
    t.add_argument("--no-noise", action="store_true", help="--simulate: switch the instrument noise off")
    t.add_argument("--faults", default=None, metavar="SPEC",
                   help="--simulate: inject device faults (DEVICE:KIND@N[xCOUNT][=ARG], docs/faults.md)")
    t.set_defaults(func=run)
