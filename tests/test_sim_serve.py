"""``guideway sim serve`` as a person uses it: a separate process printing its
endpoints, real drivers talking to both devices, ``station N`` on stdin moving
the block, SIGINT ending it cleanly with exit code 0."""

from __future__ import annotations

import queue
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from acquisition.rig import open_controller, open_sensor
from mocks.world import BlockSetup

from .test_cli import guideway, one_line_error

ROOT = Path(__file__).resolve().parents[1]


class Served:
    """A running ``guideway sim serve`` with its stdout read line by line."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "tui.cli", "sim", "serve", *args], cwd=ROOT,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, bufsize=1)
        self.lines: queue.Queue[str] = queue.Queue()
        self._pump_thread = threading.Thread(target=self._pump, daemon=True)
        self._pump_thread.start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))

    def next_line(self) -> str:
        return self.lines.get(timeout=30)

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
        self.proc.send_signal(signal.SIGINT)
        code = self.proc.wait(timeout=30)
        assert self.proc.stderr is not None
        return code, self.proc.stderr.read()

    def kill(self) -> None:
        """Kill the server if still running and close the pipes."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._pump_thread.join(timeout=10)  # ends at end of file
        for pipe in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()


def test_serve_drive_both_devices_then_sigint_exits_0() -> None:
    served = Served("--no-noise", "--seed", "2")
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
def test_serve_other_sensor_families(sensor: str, baudrate: int) -> None:
    served = Served("--no-noise", "--sensor", sensor)
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
def test_serve_modbus_rtu_framing(args: tuple[str, ...], prefix: str) -> None:
    served = Served(*args)
    try:
        url = served.endpoints()["controller"]
        assert url.startswith(prefix)
        controller = open_controller(url)
        try:
            assert controller.trigger_and_read().ok
        finally:
            controller.close()
        proc = served.proc
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0
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
    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        one_line_error(guideway("sim", "serve", "--modbus-port", str(port)), f"port {port}", "--modbus-port")


def test_a_device_id_outside_the_serial_range_is_refused_before_anything_starts(capsys) -> None:
    from tui.cli import main

    assert main(["sim", "serve", "--device-id", "300"]) == 2
    err = capsys.readouterr().err
    assert err == "guideway: error: --device-id 300 must be 1..247 (a Modbus serial address)\n"
