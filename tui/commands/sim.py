"""``guideway sim serve``: run the simulated devices standalone, for the TUI or
an external tool, until Ctrl-C / SIGTERM.

It prints one line per endpoint, machine-readable::

    sensor: keyence-lkg:/tmp/guideway-sim-XXXX/sensor baud=115200 (pty /dev/pts/5)
    controller: modbus-tcp://127.0.0.1:40123
    ready: ...

then reads operator commands on stdin (``station N``, ``beam off``,
``beam on``, ``help``), answering each with one line.  End of stdin leaves the
devices running; Ctrl-C or SIGTERM stops them and exits 0.
"""

from __future__ import annotations

import argparse
import signal
import sys
import tempfile
import threading
from pathlib import Path

from . import seed as seed_arg


def _read_commands(rig, out_lock: threading.Lock) -> None:  # noqa: ANN001 - SimulatedRig, imported lazily
    for line in sys.stdin:
        answer = rig.command(line)
        if answer:
            with out_lock:
                print(answer, flush=True)


def serve(args: argparse.Namespace) -> int:
    from acquisition.simulated.faults import parse_faults
    from acquisition.simulated.rig import start_simulated_rig
    from acquisition.simulated.sensors import sensor_emulator
    from saved_runs.errors import UserError

    sensor_emulator(args.sensor)  # bad names / specs fail before anything starts
    parse_faults(args.faults)
    if not 1 <= args.device_id <= 247:
        raise UserError(f"--device-id {args.device_id} must be 1..247 (a Modbus serial address)")
    stop = threading.Event()
    previous: dict[int, object] = {}
    with tempfile.TemporaryDirectory(prefix="guideway-sim-") as tmp:
        rig = start_simulated_rig(seed=args.seed, noise=not args.no_noise, sensor=args.sensor,
                                  faults=args.faults, modbus_port=args.modbus_port,
                                  controller=args.modbus, device_id=args.device_id,
                                  sensor_link=Path(tmp) / "sensor")
        try:
            # taken once the devices run (and given back below): a rig that fails to start leaves them as they were
            previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
            out_lock = threading.Lock()
            with out_lock:
                print(f"sensor: {rig.sensor_protocol}:{rig.sensor_url} baud={rig.sensor_baudrate} "
                      f"(pty {rig.sensor_path()})")
                print(f"controller: {rig.controller_url}")
                print("ready: type 'station N' to move the block, 'help' for commands; Ctrl-C to stop",
                      flush=True)
            threading.Thread(target=_read_commands, args=(rig, out_lock), name="sim-stdin",
                             daemon=True).start()
            while not stop.wait(0.5):
                pass
        finally:
            rig.close()
            for sig, handler in previous.items():
                signal.signal(sig, handler)
    print("simulated devices stopped", file=sys.stderr)
    return 0


def register(sub) -> None:  # noqa: ANN001
    s = sub.add_parser("sim", help="simulated devices for the TUI or external tools")
    ssub = s.add_subparsers(dest="sim_command", required=True, parser_class=type(s))
    p = ssub.add_parser("serve", help="serve a simulated sensor (pty) and controller (Modbus) until Ctrl-C")
    p.add_argument("--sensor", default="keyence-lkg", metavar="PROTOCOL",
                   help="sensor family to emulate: keyence-lkg (default), panasonic-hlg1 or me-ild1420 "
                        "(each at its own baud rate)")
    p.add_argument("--modbus-port", type=int, default=0, metavar="N",
                   help="TCP port of the controller on 127.0.0.1 (default: a free port)")
    p.add_argument("--modbus", choices=("tcp", "rtu", "rtu-over-tcp"), default="tcp",
                   help="controller transport: Modbus TCP (default), Modbus RTU on a pty at 115200 baud "
                        "(URL modbus-rtu:/dev/pts/N?...), or RTU frames over TCP (modbus-rtu:socket://127.0.0.1:N)")
    p.add_argument("--modbus-rtu", dest="modbus", action="store_const", const="rtu-over-tcp",
                   help="same as --modbus rtu-over-tcp")
    p.add_argument("--device-id", type=int, default=1, metavar="N",
                   help="Modbus unit id the controller answers at, and only there, like a controller behind a "
                        "gateway (default 1; the controller URL then carries ?device_id=N)")
    p.add_argument("--faults", default=None, metavar="SPEC",
                   help="inject device faults, e.g. sensor:close@20x1 or controller:slow@1=2.5 "
                        "(DEVICE:KIND@N[xCOUNT][=ARG], docs/faults.md)")
    p.add_argument("--seed", type=seed_arg, default=0, help="seed of the simulated world (default 0)")
    p.add_argument("--no-noise", action="store_true", help="switch the simulated instrument noise off")
    p.set_defaults(func=serve)
