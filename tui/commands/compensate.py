"""``guideway compensate live``: live compensation through the controller's external offset (seed 003;
docs/compensation.md, "Live compensation").

    guideway compensate live RUN --controller URL [--model spline|linear|polynomial|bidirectional-table]
        [--cycle-ms 8] [--max-jump-um 5] [--word-order ABCD|CDAB] [--cycles N] [--quiet]

    guideway compensate linuxcnc-config --axis C --server IP[:PORT] [--device-id N] [--timeout-ms 500]
        [--av-ratio 0.1] [--via mb2hal|component] --out DIR

Exit codes (live): 0 switched off at the controller or ``--cycles`` done, 130 Ctrl+C (offset 0 written first),
3 connection lost (the controller drops the offset after its heartbeat timeout), 2 usage / data errors.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: the choices, written out so that ``--help`` loads no numerics (acquisition.live_compensation.LIVE_MODELS)
LIVE_MODELS = ("spline", "linear", "polynomial", "bidirectional-table")
EXIT_LINK_LOST = 3


def run(args: argparse.Namespace) -> int:
    from acquisition.live_compensation import LiveCompensator, LiveLinkLost, predictor_from_run

    from .signals import ctrl_c_raises

    predictor = predictor_from_run(args.run, args.model)
    comp = LiveCompensator(predictor, args.controller, cycle_ms=args.cycle_ms, max_jump=args.max_jump_um,
                           word_order=args.word_order, stream=None if args.quiet else sys.stdout)
    if not args.quiet:
        print(f"live compensation: {predictor.model} model of {predictor.run} ({predictor.first:g} … "
              f"{predictor.last:g} {predictor.position_unit}, {predictor.unit}) -> {args.controller}, cycle "
              f"{args.cycle_ms:g} ms, jump limit {args.max_jump_um:g} {predictor.unit}; Ctrl+C stops (offset 0)",
              flush=True)
    try:
        with ctrl_c_raises():  # Ctrl-C (SIGINT) writes offset 0 and ends it, even in a job started with SIGINT ignored
            stats = comp.run(max_cycles=args.cycles)
    except LiveLinkLost as exc:
        print(f"guideway: error: {exc}", file=sys.stderr)
        return EXIT_LINK_LOST
    except KeyboardInterrupt:
        print(f"guideway: interrupted: offset 0 written, live compensation off ({comp.stats.cycles} cycles, "
              f"{comp.stats.jumps_clamped} jump(s) clamped)", file=sys.stderr)
        return 130
    if not args.quiet:
        print(f"live compensation ended: {stats.reason}; {stats.cycles} cycles, {stats.overruns} over "
              f"{args.cycle_ms:g} ms, {stats.jumps_clamped} jump(s) clamped; offset 0 written")
    return 0


def linuxcnc_config(args: argparse.Namespace) -> int:
    from acquisition.live_linuxcnc import LinuxCncLive, component_hal_lines, hal_lines, ini_lines, mb2hal_ini
    from saved_runs.errors import UserError

    ip, _, port = args.server.partition(":")
    try:
        cfg = LinuxCncLive(axis=args.axis, rotary=args.axis.upper() in "ABC", server_ip=ip,
                           server_port=int(port) if port else 502, device_id=args.device_id,
                           timeout_ms=args.timeout_ms, av_ratio=args.av_ratio, via=args.via)
    except ValueError as exc:
        raise UserError(f"linuxcnc-config: {exc}") from None
    args.out.mkdir(parents=True, exist_ok=True)
    files = [(cfg.mb2hal_file, mb2hal_ini(cfg)), (cfg.hal_file, hal_lines(cfg))] if cfg.via == "mb2hal" else [
        (cfg.hal_file, component_hal_lines(cfg))]
    for name, text in (*files, ("guideway-live.ini", ini_lines(cfg))):
        (args.out / name).write_text(text, encoding="utf-8")
        print(f"wrote {args.out / name}")
    print("add the lines of guideway-live.ini to the machine's INI file; copy the other file(s) next to it "
          "(docs/compensation.md, LinuxCNC)")
    return 0


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number > 0 is needed, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"a number > 0 is needed, got {text!r}")
    return value


def _cycles(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"a whole number >= 1 is needed, got {text!r}")
    return int(text)


def register(sub) -> None:  # noqa: ANN001
    c = sub.add_parser("compensate", help="live compensation through the controller's external offset (seed 003)")
    csub = c.add_subparsers(dest="compensate_command", required=True)
    live = csub.add_parser("live", help="predict the error every cycle and write the opposite offset over Modbus")
    live.add_argument("run", type=Path, help="the as-found positioning run whose error is modelled")
    live.add_argument("--controller", required=True, metavar="URL",
                      help="the controller's live-compensation interface: modbus-tcp://HOST[:PORT][?device_id=N]")
    live.add_argument("--model", choices=LIVE_MODELS, default="spline", help="error model per direction "
                      "(default spline: the adaptive-knot spline)")
    live.add_argument("--cycle-ms", type=_positive, default=8.0, help="cycle time in ms (default 8, seed 003's)")
    live.add_argument("--max-jump-um", type=_positive, default=5.0,
                      help="largest change of the offset per cycle, um (arcsec on a rotary axis); larger steps "
                           "are clamped and logged (default 5)")
    live.add_argument("--word-order", choices=("ABCD", "CDAB"), default="ABCD",
                      help="word order of multi-register values (default ABCD, most significant word first)")
    live.add_argument("--cycles", type=_cycles, default=None, help="stop after N cycles (default: run until stopped)")
    live.add_argument("--quiet", action="store_true", help="no progress lines (errors still go to stderr)")
    live.set_defaults(func=run)
    lc = csub.add_parser("linuxcnc-config", help="write the LinuxCNC INI, HAL and mb2hal files for live compensation "
                         "through external axis offsets")
    lc.add_argument("--axis", required=True, help="the axis letter (X Y Z A B C U V W; A B C are rotary)")
    lc.add_argument("--server", required=True, metavar="IP[:PORT]",
                    help="the Modbus TCP server holding the live-compensation registers (port 502 by default)")
    lc.add_argument("--device-id", type=int, default=1, help="its Modbus unit id (default 1)")
    lc.add_argument("--timeout-ms", type=int, default=500, help="stale-heartbeat time T in ms (default 500)")
    lc.add_argument("--av-ratio", type=float, default=0.1,
                    help="[AXIS_L] OFFSET_AV_RATIO: velocity/acceleration share of the offset (default 0.1)")
    lc.add_argument("--via", choices=("mb2hal", "component"), default="mb2hal",
                    help="mb2hal: read the offset from a Modbus server holding the registers (the position needs "
                         "another path); component: guideway's HAL component serves the whole interface")
    lc.add_argument("--out", type=Path, required=True, help="folder for the files")
    lc.set_defaults(func=linuxcnc_config)
