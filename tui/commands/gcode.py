"""``guideway gcode``: the part program of a positioning set-up's cycle.

    guideway gcode --setup SETUP.toml [--out PROGRAM.nc] [--dialect fanuc|linuxcnc]

The machine then runs exactly the stops ``guideway acquire positioning`` expects.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path


def run(args: argparse.Namespace) -> int:
    from acquisition.gcode import part_program
    from acquisition.setup.positioning import load_positioning_setup
    from saved_runs.store.files import write_text_atomic

    setup = load_positioning_setup(args.setup)
    if args.dialect:
        setup = dataclasses.replace(setup, dialect=args.dialect)
    text = part_program(setup)
    if args.out is None:
        sys.stdout.write(text)
    else:
        # as every file the tool writes: a temporary file renamed over --out (a symlink there is
        # replaced, not written through; a reader never sees half a program)
        write_text_atomic(args.out, text)
        print(f"{setup.dialect} program, {len(setup.measured_stops())} measured stops: {args.out}", file=sys.stderr)
    return 0


def register(sub) -> None:  # noqa: ANN001
    g = sub.add_parser("gcode", help="part program of a positioning set-up's ISO 230-2 cycle")
    g.add_argument("--setup", type=Path, required=True, help="positioning set-up file (TOML)")
    g.add_argument("--out", type=Path, default=None, help="write the program here (default: stdout)")
    g.add_argument("--dialect", choices=("fanuc", "linuxcnc"), default=None, help="override [gcode] dialect")
    g.set_defaults(func=run)
