"""``guideway acquire straightness|positioning``: acquire a run from a set-up file.

    guideway acquire straightness --setup SETUP.toml --out RUN_DIR [--simulate] [--auto]
    guideway acquire positioning --setup SETUP.toml --out RUN_DIR [--simulate] [--auto]
        [--compensation FILE [--compensation-format F] [--comp-file-type 0|1]] [--shift-targets S]
        [--simulate --live-compensation AS_FOUND_RUN [--live-model spline|linear|polynomial|bidirectional-table]]
    guideway acquire [KIND] --resume RUN_DIR [--simulate] [--auto]     (or: KIND --out RUN_DIR --resume)

The plain-terminal operator asks on stdin/stdout (Enter = capture) unless
``--auto`` (the simulated technician).  ``--resume`` continues an interrupted
run in RUN_DIR after its last completed step.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from acquisition.setup.compensation import COMPENSATION_FORMATS

from . import seed as seed_arg
from .compensate import LIVE_MODELS

KINDS = ("straightness", "positioning")


def run(args: argparse.Namespace) -> int:
    from acquisition.acquire import SimOptions, acquire
    from saved_runs.errors import SetupError, UserError
    from saved_runs.toml_file import read_toml

    resume = args.resume is not None
    compensation = args.compensation is not None or args.compensation_format is not None or (
        args.comp_file_type is not None)
    if compensation and resume:
        raise SetupError("--compensation applies to a new run; a resumed run keeps the table it started with")
    if isinstance(args.resume, Path):
        if args.out is not None and args.out != args.resume:
            raise SetupError("--resume RUN_DIR and --out name different directories; give one of them")
        args.out = args.resume
    if args.out is None:
        raise SetupError("give the run directory: --out RUN_DIR (or --resume RUN_DIR)")
    if args.kind is None:
        if not resume:
            raise SetupError("give the run kind: guideway acquire straightness|positioning ...")
        from saved_runs.store.reader import load_run

        args.kind = load_run(args.out).kind
    if args.setup is None and not resume:
        raise SetupError(f"a new run needs --setup SETUP.toml (see docs/setup-{args.kind}.toml)")
    if args.faults and not args.simulate:
        raise SetupError("--faults needs --simulate (faults are injected into the simulated devices)")
    if args.scenario is not None and not args.simulate:
        raise SetupError("--scenario needs --simulate (the scenario's effects are put behind the simulated devices)")
    sim = SimOptions(args.seed, not args.no_noise, args.faults,
                     scenario=str(args.scenario.resolve()) if args.scenario else None) if args.simulate else None
    source = read_toml(args.setup) if args.setup is not None else None
    if compensation:
        source = _with_compensation(args, source)
    if args.shift_targets is not None:
        source = _with_shift(args, source, resume)
    live = {}
    if args.live_compensation is not None:
        if args.kind != "positioning":
            raise SetupError("--live-compensation is for positioning runs")
        live = {"live_compensation": args.live_compensation, "live_model": args.live_model}
    elif args.live_model is not None:
        raise SetupError("--live-model needs --live-compensation AS_FOUND_RUN")
    res = acquire(args.kind, source, str(args.setup), args.out, simulate=sim, auto=args.auto, resume=resume,
                  stream=sys.stdout, stdin=sys.stdin, **live)  # this call's streams, not import time's
    status = res.outcome.exit_status
    stopped = getattr(res, "live_stopped", "")
    if status == "fail" and stopped:  # not to be resumed: its later points would be measured uncompensated
        raise UserError(f"{stopped}; the {res.outcome.num_events} point(s) captured before are kept in {args.out}")
    if status == "fail":
        raise UserError(f"run failed ({res.outcome.reason}); the points captured are in {args.out}; "
                        f"continue with: guideway acquire --resume {args.out}")
    if status == "abort":
        print(f"guideway: run aborted ({res.outcome.reason}); the points are kept in {args.out}; "
              f"continue with: guideway acquire --resume {args.out}", file=sys.stderr)
        return 1
    print(f"process it with: guideway process {args.out}")
    return 0


def _with_shift(args: argparse.Namespace, source: dict | None, resume: bool) -> dict:
    """The set-up with ``[axis] shift_targets_mm`` (``_deg``) = ``--shift-targets`` (docs/compensation.md)."""
    from saved_runs.errors import SetupError

    if resume or source is None:
        raise SetupError("--shift-targets applies to a new run with --setup; a resumed run keeps its targets")
    if args.kind != "positioning":
        raise SetupError("--shift-targets is for positioning runs")
    axis = dict(source.get("axis") or {})
    unit = "deg" if axis.get("type") == "rotary" else "mm"
    axis[f"shift_targets_{unit}"] = args.shift_targets
    return {**source, "axis": axis}


def _with_compensation(args: argparse.Namespace, source: dict | None) -> dict:
    """The set-up with ``[compensation]`` from ``--compensation FILE`` (replacing the set-up's own);
    ``--compensation-format`` / ``--comp-file-type`` alone complete the set-up's table."""
    from saved_runs.errors import SetupError

    if source is None:
        raise SetupError("--compensation needs --setup SETUP.toml")
    if args.kind != "positioning":
        raise SetupError("--compensation is for positioning runs (the controller's compensation table)")
    table = dict(source.get("compensation") or {})
    if args.compensation is not None:
        table = {"file": str(args.compensation.resolve())}
    elif not table:
        raise SetupError("--compensation-format / --comp-file-type need --compensation FILE (or a [compensation] "
                         "table in the set-up)")
    if args.compensation_format is not None:
        table["format"] = args.compensation_format
    if args.comp_file_type is not None:
        table["comp_file_type"] = args.comp_file_type
    return {**source, "compensation": table}


def register(sub) -> None:  # noqa: ANN001
    a = sub.add_parser("acquire", help="acquire a straightness or positioning run from a set-up file, or resume one")
    a.add_argument("kind", nargs="?", choices=KINDS, default=None,
                   help="run kind (with --resume: read from the run)")
    a.add_argument("--setup", type=Path, default=None, help="set-up file (TOML); optional with --resume")
    a.add_argument("--out", type=Path, default=None, help="run directory (new, or the run to resume)")
    a.add_argument("--simulate", action="store_true", help="simulated devices on real transports")
    a.add_argument("--auto", action="store_true", help="automatic operator (simulated technician)")
    a.add_argument("--resume", nargs="?", type=Path, const=True, default=None, metavar="RUN_DIR",
                   help="continue the interrupted run in RUN_DIR (or in --out)")
    a.add_argument("--seed", type=seed_arg, default=0, help="--simulate: seed of the simulated world (default 0)")
    a.add_argument("--no-noise", action="store_true", help="--simulate: switch the instrument noise off")
    a.add_argument("--faults", default=None, metavar="SPEC",
                   help="--simulate: inject device faults (DEVICE:KIND@N[xCOUNT][=ARG]), e.g. sensor:drop@9x1")
    a.add_argument("--scenario", type=Path, default=None, metavar="FILE",
                   help="--simulate: scenario file whose effects the simulated devices apply (docs/diagnosis.md; "
                        "default: the set-up's [simulation] scenario)")
    a.add_argument("--shift-targets", type=float, default=None, metavar="S",
                   help="positioning: measure at the set-up's targets moved by S mm (deg), those within the first … "
                        "last target: an as-left run between a table's points (guideway verify compares it with the "
                        "leave-one-target-out prediction)")
    a.add_argument("--compensation", type=Path, default=None, metavar="FILE",
                   help="positioning: the compensation table active in the controller (recorded in run.json; with "
                        "--simulate the simulated controller applies it as that controller does); replaces the "
                        "set-up's [compensation]")
    a.add_argument("--compensation-format", choices=COMPENSATION_FORMATS, default=None,
                   help="the table's controller (default: from the file's content)")
    a.add_argument("--comp-file-type", type=int, choices=(0, 1), default=None,
                   help="LinuxCNC COMP_FILE_TYPE of the table (0: actual positions, 1: trims); needed for linuxcnc")
    a.add_argument("--live-compensation", type=Path, default=None, metavar="AS_FOUND_RUN",
                   help="positioning, --simulate: the simulated controller takes a live external offset from a "
                        "compensator running in this process over Modbus TCP, modelling AS_FOUND_RUN "
                        "(docs/compensation.md, live compensation)")
    a.add_argument("--live-model", choices=LIVE_MODELS, default=None,
                   help="--live-compensation: the error model (default spline)")
    a.set_defaults(func=run)
