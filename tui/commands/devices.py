"""``guideway devices probe``: check that real (or simulated) devices answer.

Prints each device's identity, then ``--count`` readings (or readings until
Ctrl-C with ``--follow``): the sensor's value in mm with its status, every
controller channel with the environment and the decoded status flags.  Exit 0
when the devices answered without an error, 3 when one reported an error (an
error reply, a Modbus exception, the controller's error flag or *beam OK*
clear: not a pass), 2 with a one-line reason when one did not answer.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import sys
import time

from .signals import ctrl_c_raises

EXIT_DEVICE_ERROR = 3


def probe(args: argparse.Namespace) -> int:
    from acquisition.probe import open_probe
    from acquisition.rig import ControllerTiming, SensorOptions
    from saved_runs.errors import UserError

    if args.count < 1:
        raise UserError(f"--count must be at least 1 (got {args.count})")
    d = ControllerTiming()
    timing = ControllerTiming(d.trigger_timeout_s if args.trigger_timeout is None else args.trigger_timeout,
                              d.poll_interval_s,
                              d.request_timeout_s if args.request_timeout is None else args.request_timeout,
                              d.trigger_retries)  # not `or`: an explicit 0 is refused, not the default
    if problem := timing.problem():
        raise UserError(problem.replace("trigger_timeout_s", "--trigger-timeout").replace(
            "request_timeout_s", "--request-timeout"))
    options = SensorOptions(args.series, args.output)
    # with --follow, Ctrl-C works from before the first line printed to the end
    with ctrl_c_raises() if args.follow else contextlib.nullcontext(), \
            open_probe(args.sensor, args.controller, baudrate=args.baud, environment=args.environment,
                       sensor_options=options, timing=timing) as p:
        for line in p.identity_lines():
            print(line, flush=True)
        indices = itertools.count(1) if args.follow else range(1, args.count + 1)
        try:
            for i in indices:
                print("\n".join(p.reading_lines(i)), flush=True)
                if args.follow:
                    time.sleep(args.interval)
        except KeyboardInterrupt:  # --follow ends here; a normal end, not an error
            pass
    if p.device_errors:
        print(f"guideway: {p.device_errors} reading(s) with a device error: not a pass (exit 3)", file=sys.stderr)
        return EXIT_DEVICE_ERROR
    return 0


def register(sub) -> None:  # noqa: ANN001
    d = sub.add_parser("devices", help="check the measuring devices")
    dsub = d.add_subparsers(dest="devices_command", required=True, parser_class=type(d))
    p = dsub.add_parser("probe", help="show identity and a few readings of the sensor, the controller and/or the "
                                      "environment transmitter")
    p.add_argument("--sensor", default=None, metavar="PROTOCOL:URL",
                   help="displacement sensor, e.g. keyence-lkg:/dev/ttyUSB0 or keyence-lkg:socket://host:port")
    p.add_argument("--baud", type=int, default=None, metavar="N",
                   help="sensor baud rate (default: the protocol's usual rate)")
    p.add_argument("--series", default=None, choices=("LK-G3000", "LK-G5000"),
                   help="keyence-lkg controller series (LK-G5000 reads with MS,nn; default LK-G3000)")
    p.add_argument("--output", type=int, default=None, metavar="N",
                   help="keyence-lkg output to read (LK-G3000: 1-2, LK-G5000: 1-99; default 1)")
    p.add_argument("--controller", default=None, metavar="URL",
                   help="interferometer controller: modbus-tcp://host:port[?device_id=N] or "
                        "modbus-rtu:PORT[?baud=..&parity=E&device_id=N]")
    p.add_argument("--trigger-timeout", type=float, default=None, metavar="S",
                   help="seconds a controller measurement may take (default 2; a slow controller needs more)")
    p.add_argument("--request-timeout", type=float, default=None, metavar="S",
                   help="seconds one Modbus request waits for its reply (default 1)")
    p.add_argument("--environment", default=None, metavar="URL",
                   help="XY-MD02 temperature/humidity transmitter: modbus-rtu:PORT[?baud=9600] or modbus-tcp://host:port")
    p.add_argument("--count", type=int, default=3, metavar="N", help="readings to take (default 3)")
    p.add_argument("--follow", action="store_true", help="keep reading until Ctrl-C")
    p.add_argument("--interval", type=float, default=0.5, metavar="S",
                   help="seconds between readings with --follow (default 0.5)")
    p.set_defaults(func=probe)
