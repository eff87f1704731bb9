"""``guideway sim serve`` as a person uses it: a separate process printing its
endpoints, real drivers talking to both devices, ``station N`` on stdin moving
the block, SIGINT ending it cleanly with exit code 0.  (A server runs until a
signal ends it: the separate process is the point.  Bad arguments fail before
anything runs, in this process.)"""

from __future__ import annotations

import signal
import socket
import subprocess
from pathlib import Path

import pytest

from acquisition.rig import open_controller, open_sensor
from mocks.world import BlockSetup

from .cli import LineReader, guideway, interrupt, one_line_error, spawn


class Served:
    """A running ``guideway sim serve`` with its stdout read line by line."""

    def __init__(self, tmp_dir: Path, *args: str) -> None:
        self.proc = spawn("sim", "serve", *args, tmp_dir=tmp_dir, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, bufsize=1)
        assert self.proc.stdout is not None
        self.lines = LineReader(self.proc.stdout)

    def next_line(self) -> str:
        return self.lines.next_line(30, what="a line from guideway sim serve")

    def endpoints(self) -> dict[str, str]:
        found = {}
        while (line := self.next_line()) and not line.startswith("ready:"):
            key, _, value = line.partition(": ")
            found[key] = value
        return found

    def send(self, line: str) -> str:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self.next_line()

    def interrupt(self) -> tuple[int, str]:
        code = interrupt(self.proc, signal.SIGINT)
        assert self.proc.stderr is not None
        return code, self.proc.stderr.read()

    def kill(self) -> None:
        """Kill the server if still running and close the pipes."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.lines.join(timeout_s=10)  # ends at end of file
        for pipe in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()


def test_serve_drive_both_devices_then_sigint_exits_0(tmp_path: Path) -> None:
    served = Served(tmp_path / "tmp", "--no-noise", "--seed", "2")
    try:
        ep = served.endpoints()
        sensor_spec, baud = ep["sensor"].split()[:2]
        protocol, _, url = sensor_spec.partition(":")
        assert protocol == "keyence-lkg" and baud == "baud=115200"
        assert ep["controller"].startswith("modbus-tcp://127.0.0.1:")
        sensor = open_sensor(protocol, url, baudrate=115200)
        controller = open_controller(ep["controller"])
        try:
            assert sensor.read_once().ok
            assert controller.trigger_and_read().position_mm == pytest.approx(0.0, abs=1e-9)
            assert served.send("station 3").startswith("block at station 3")
            # noise off: the mirror point has moved by three block lengths, give or take the
            # Abbe term of the guideway-induced pitch (tens of urad x a ~100 mm lever: a few um)
            length_mm = BlockSetup().length_mm
            assert controller.trigger_and_read().position_mm == pytest.approx(3 * length_mm, abs=0.02)
            assert served.send("beam off") == "beam off"
            assert not sensor.read_once().ok  # the LK-G reports no target
            assert "unknown command" in served.send("jump 4")
        finally:
            sensor.close()
            controller.close()
        code, err = served.interrupt()
    finally:
        served.kill()
    assert code == 0, err
    assert "Traceback" not in err


@pytest.mark.parametrize(("sensor", "baudrate"), [("panasonic-hlg1", 115200), ("me-ild1420", 921600)])
def test_serve_other_sensor_families(tmp_path: Path, sensor: str, baudrate: int) -> None:
    served = Served(tmp_path / "tmp", "--no-noise", "--sensor", sensor)
    try:
        sensor_spec, baud = served.endpoints()["sensor"].split()[:2]
        protocol, _, url = sensor_spec.partition(":")
        assert protocol == sensor and baud == f"baud={baudrate}"
        dev = open_sensor(protocol, url, baudrate=baudrate)
        try:
            assert dev.read_once().ok  # the ILD1420 streams on its own; the HL-G1 answers a poll
            assert dev.read_averaged(3).count == 3
            assert served.send("beam off") == "beam off"
            assert not dev.read_once().ok  # HL-G1: ALARM flag; ILD1420: an error value in the stream
            assert served.send("beam on") == "beam on"
            assert dev.read_once().ok
        finally:
            dev.close()
        code, err = served.interrupt()
    finally:
        served.kill()
    assert code == 0, err
    assert "Traceback" not in err


@pytest.mark.parametrize(("args", "prefix"), [(("--modbus-rtu",), "modbus-rtu:socket://127.0.0.1:"),
                                              (("--modbus", "rtu"), "modbus-rtu:/dev/pts/")])
def test_serve_modbus_rtu_framing(tmp_path: Path, args: tuple[str, ...], prefix: str) -> None:
    served = Served(tmp_path / "tmp", *args)
    try:
        url = served.endpoints()["controller"]
        assert url.startswith(prefix)
        controller = open_controller(url)
        try:
            assert controller.trigger_and_read().ok
        finally:
            controller.close()
        assert interrupt(served.proc, signal.SIGTERM) == 0
    finally:
        served.kill()


@pytest.mark.parametrize(
    ("args", "fragment"),
    [(("--sensor", "omron-zw"), "no simulated sensor 'omron-zw'"),
     (("--faults", "sensor:melt@3"), "unknown sensor fault 'melt'")],
)
def test_bad_arguments_one_line_exit_2(args: tuple[str, ...], fragment: str) -> None:
    one_line_error(guideway("sim", "serve", *args), fragment)


def test_modbus_port_in_use_one_line_exit_2() -> None:
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        one_line_error(guideway("sim", "serve", "--modbus-port", str(port)), f"port {port}", "--modbus-port")
    # a server that never ran leaves Ctrl-C and SIGTERM as they were
    assert {sig: signal.getsignal(sig) for sig in handlers} == handlers


def test_a_device_id_outside_the_serial_range_is_refused_before_anything_starts(capsys) -> None:
    from tui.cli import main

    assert main(["sim", "serve", "--device-id", "300"]) == 2
    err = capsys.readouterr().err
    assert err == "guideway: error: --device-id 300 must be 1..247 (a Modbus serial address)\n"
