"""``guideway devices probe`` against emulators started here (sensor on a pty,
controller on Modbus TCP): identity, readings with units and status, device
errors shown as readings, and one-line exit-2 failures.  In this process, but
``--follow`` ended by Ctrl-C (the signal is the point)."""

from __future__ import annotations

import contextlib
import socket
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from acquisition.simulated.rig import start_simulated_rig

from ..cli import LineReader, guideway, interrupt, one_line_error, spawn


def probe(*args: str) -> tuple[int, list[str], str]:
    """``guideway devices probe ARGS`` (tests/cli.py): exit code, printed lines, stderr."""
    res = guideway("devices", "probe", *args)
    return res.returncode, res.stdout.splitlines(), res.stderr


def test_both_devices_identity_and_three_readings(sim_rig) -> None:
    sensor = f"{sim_rig.sensor_protocol}:{sim_rig.sensor_url}"
    code, lines, err = probe("--sensor", sensor, "--controller", sim_rig.controller_url)
    assert code == 0, err
    # the LK-G command set has no identity query: the line says so, and names the command set spoken
    assert lines[0] == (f"sensor {sensor}: model=(not reported; protocol keyence-lkg) "
                        "commands=Keyence LK-G3000 (RS-232C) output=1")
    assert lines[1].startswith(f"controller {sim_rig.controller_url}: vendor=guideway-sim")
    assert "model=SIM-6DOF-IFM" in lines[1]
    sensor_lines = [ln for ln in lines if " sensor: " in ln]
    assert [ln.split()[0] for ln in sensor_lines] == ["#1", "#2", "#3"]
    # noise off: the LK-G reports height = standoff - beam length, 5 decimals, in mm
    world = sim_rig.world
    expected_mm = world.block.standoff_mm - world.sensor_distance_mm()
    value = sensor_lines[0].split()[2]
    assert sensor_lines[0].split()[3:5] == ["mm", "ok"]
    assert float(value) == pytest.approx(expected_mm, abs=0.6e-5)
    i = lines.index(next(ln for ln in lines if ln.startswith("#1 controller:")))
    assert "[ready data-valid beam-ok]" in lines[i]
    # the block has not moved since the datum: every error motion reads 0
    assert lines[i + 1].split() == ["position", "0.000000", "mm", "stry", "0.000", "um", "strz", "0.000", "um"]
    for word in ("pitch", "yaw", "roll"):
        assert word in lines[i + 2]
    env = lines[i + 3].split()
    assert env[0::3] == ["air", "pressure", "humidity", "material"]
    assert env[2::3] == ["C", "hPa", "%RH", "C"]
    assert 15 < float(env[1]) < 25 and 900 < float(env[4]) < 1100


def test_controller_error_is_shown_as_a_reading_and_is_not_a_pass(sim_rig) -> None:
    sim_rig.world.beam_blocked = True
    code, lines, err = probe("--controller", sim_rig.controller_url, "--count", "1")
    assert code == 3, err  # the device answered, but reports an error: exit 3, not 0
    assert lines[1].startswith(f"#1 controller: device error: controller {sim_rig.controller_url}: device reported "
                               "error 1 to 'trigger': beam interrupted")
    assert "error" in lines[2] and "beam-ok" not in lines[2] and "latched" not in lines[2]
    assert err.strip() == "guideway: 1 reading(s) with a device error: not a pass (exit 3)"
    # the beam is back, the error stays latched (docs/modbus-map.md): still not a pass, and the line says
    # why the controller reports an error with its beam OK, and that a run clears it
    sim_rig.world.beam_blocked = False
    code, lines, err = probe("--controller", sim_rig.controller_url, "--count", "1")
    assert code == 3, err
    assert "[ready error beam-ok]" in lines[2] and "error 1: beam interrupted" in lines[2]
    assert lines[2].endswith("(latched: the beam is OK again; a run clears the error itself, command 5)")


def test_sensor_answering_garbage_exits_2_one_line() -> None:
    rig = start_simulated_rig(seed=1, noise=False, faults="sensor:garbage@1")
    try:
        res = guideway("devices", "probe", "--sensor", f"keyence-lkg:{rig.sensor_url}")
    finally:
        rig.close()
    one_line_error(res, f"sensor keyence-lkg:{rig.sensor_url} did not answer properly")


def test_sensor_that_hangs_up_exits_2() -> None:
    rig = start_simulated_rig(seed=1, noise=False, faults="sensor:close@2")
    try:
        code, lines, err = probe("--sensor", f"keyence-lkg:{rig.sensor_url}")
    finally:
        rig.close()
    assert code == 2 and lines[1].startswith("#1 sensor:")
    assert err.count("\n") == 1 and "did not answer properly" in err and "failed" in err


@pytest.mark.parametrize(
    ("args", "fragment"),
    [((), "nothing to probe"),
     (("--sensor", "/dev/ttyUSB0"), "must be PROTOCOL:URL"),
     (("--sensor", "acme-laser:/dev/ttyUSB0"), "unknown sensor protocol 'acme-laser'"),
     (("--controller", "modbus-tcp://127.0.0.1:{port}"),
      "cannot connect to controller at modbus-tcp://127.0.0.1:{port}: no Modbus answer from 127.0.0.1:{port} "
      "within 1.0 s / connection refused; check the controller address"),
     (("--controller", "http://x"), "must start with modbus-tcp://"),
     # an explicit 0 was taken as "not given" and the default used
     (("--controller", "modbus-tcp://127.0.0.1:{port}", "--request-timeout", "0"),
      "--request-timeout must be a positive number of seconds, got 0.0"),
     (("--controller", "modbus-tcp://127.0.0.1:{port}", "--trigger-timeout", "0"),
      "--trigger-timeout must be a positive number of seconds, got 0.0")],
)
def test_bad_or_unreachable_devices_exit_2(refused_port: int, args,
                                           fragment: str) -> None:
    args = [a.format(port=refused_port) for a in args]
    fragment = fragment.format(port=refused_port)
    code, _, err = probe(*args)
    assert code == 2
    assert err.startswith("guideway: error:") and err.count("\n") == 1 and fragment in err


@pytest.mark.parametrize("sigint_ignored", [False, True], ids=["sigint-default", "sigint-ignored"])
def test_follow_runs_until_ctrl_c(sim_rig, tmp_path: Path, sigint_ignored: bool) -> None:
    # A process started with SIGINT ignored (a background job of a non-interactive shell; before the fix
    # it read on, and this test ran into its 30 s limit) still ends on Ctrl-C: --follow takes SIGINT back
    # before it prints its first line, so the signal, sent once five readings are out, cannot come too
    # early.  Every wait is bounded.
    proc = spawn("devices", "probe", "--follow", "--interval", "0.01", "--sensor", f"keyence-lkg:{sim_rig.sensor_url}",
                 tmp_dir=tmp_path / "tmp", sigint_ignored=sigint_ignored, stdout=subprocess.PIPE,
                 stderr=subprocess.PIPE)
    with proc:
        assert proc.stdout is not None and proc.stderr is not None
        lines = LineReader(proc.stdout)
        try:
            seen = [lines.next_line(30, what="the probe's identity and five readings") for _ in range(6)]
            code = interrupt(proc)
        finally:
            if proc.poll() is None:
                proc.kill()
            lines.join()  # the reader is done with stdout before the pipe is closed
        err = proc.stderr.read()
    assert seen[5].startswith("#5 sensor:")
    assert code == 0 and "Traceback" not in err


def test_a_sensor_of_another_family_is_not_given_a_model() -> None:
    rig = start_simulated_rig(seed=1, noise=False, sensor="panasonic-hlg1")  # an HL-G1 on the line
    try:
        code, lines, err = probe("--sensor", f"keyence-lkg:{rig.sensor_url}", "--baud", "9600")
    finally:
        rig.close()
    assert code == 2 and err.count("\n") == 1 and "did not answer properly" in err
    assert all("model=Keyence" not in ln for ln in lines), lines
    assert lines and "model=(not reported; protocol keyence-lkg)" in lines[0]


@pytest.fixture
def hang_up_port() -> Iterator[int]:
    """A loopback TCP port whose listener accepts every connection and closes it at once (no Modbus)."""
    listener = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            with contextlib.suppress(OSError):
                conn, _ = listener.accept()
                conn.close()

    port = listener.getsockname()[1]
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield port
    finally:
        stop.set()
        # wake the accept() with one last connection while the listener is still open; the loop then ends
        socket.create_connection(("127.0.0.1", port), timeout=5).close()
        thread.join(timeout=5)
        listener.close()
        assert not thread.is_alive(), "the hang-up listener's thread did not end"


def test_a_port_that_hangs_up_is_no_modbus_answer_one_line(hang_up_port: int) -> None:
    code, lines, err = probe("--controller", f"modbus-tcp://127.0.0.1:{hang_up_port}")
    assert code == 2 and lines == []  # no identity line for a device that never answered
    assert err.startswith("guideway: error:") and err.count("\n") == 1
    assert f"no Modbus answer from 127.0.0.1:{hang_up_port}" in err and "check the controller address" in err
    assert "seconds into read" not in err


# -- issue 9: sensor output, device errors, slow and gateway controllers ---------------------------------
def test_probe_reads_the_lkg5000_output_it_is_told() -> None:
    rig = start_simulated_rig(seed=1, noise=False)
    try:
        code, lines, err = probe("--sensor", f"keyence-lkg:{rig.sensor_url}", "--series", "LK-G5000",
                                 "--output", "2", "--count", "1")
    finally:
        rig.close()
    assert code == 0, err
    assert lines[0].endswith("commands=Keyence LK-G5000 (RS-232C) output=2")
    assert "'MS,02," in lines[1]  # the LK-G5000 reply to MS,02 (the raw frame is shown)


@pytest.mark.parametrize(("args", "fragment"), [
    (("--series", "LK-G3000", "--output", "3"), "LK-G3000 output must be 1..2, not 3"),
    (("--output", "0"), "output must be 1..2, not 0"),
])
def test_bad_sensor_output_is_a_one_line_error(sim_rig, args, fragment) -> None:
    code, _, err = probe("--sensor", f"keyence-lkg:{sim_rig.sensor_url}", *args)
    assert code == 2 and err.startswith("guideway: error:") and fragment in err and err.count("\n") == 1


def test_a_sensor_error_reply_is_not_a_pass() -> None:
    rig = start_simulated_rig(seed=1, noise=False, faults="sensor:error@1x1=22")  # the first reading
    try:
        code, lines, err = probe("--sensor", f"keyence-lkg:{rig.sensor_url}", "--count", "2")
    finally:
        rig.close()
    assert code == 3 and "#1 sensor: device error" in lines[1] and lines[2].startswith("#2 sensor: +")
    assert "1 reading(s) with a device error" in err


def test_a_slow_controller_is_told_apart_from_a_wrong_address() -> None:
    rig = start_simulated_rig(seed=1, noise=False, faults="controller:slow@1=0.2")
    try:
        code, lines, err = probe("--controller", rig.controller_url, "--count", "1",
                                 "--trigger-timeout", "0.05")
        ok = probe("--controller", rig.controller_url, "--count", "1", "--trigger-timeout", "0.5")
    finally:
        rig.close()
    assert code == 2 and lines[0].startswith(f"controller {rig.controller_url}: vendor=guideway-sim")
    assert "trigger not completed within 0.05 s" in err and "a slow one needs a longer --trigger-timeout" in err
    assert "check the controller address" not in err and err.count("\n") == 1
    assert ok[0] == 0 and ok[1][1].startswith("#1 controller: status 0x0015 [ready data-valid beam-ok]")


def test_a_controller_behind_a_gateway_is_probed_at_its_device_id() -> None:
    rig = start_simulated_rig(seed=1, noise=False, device_id=7)
    try:
        assert rig.controller_url.endswith("?device_id=7")
        code, lines, err = probe("--controller", rig.controller_url, "--count", "1")
        bare = rig.controller_url.removesuffix("?device_id=7")
        code1, lines1, err1 = probe("--controller", bare, "--count", "1")
    finally:
        rig.close()
    assert code == 0 and "model=SIM-6DOF-IFM" in lines[0], err
    assert code1 == 2 and lines1 == [] and "Modbus exception 11" in err1
    assert "no device answers at device id 1 behind the gateway: check device_id= in the URL" in err1


def test_a_controller_that_answered_the_open_is_not_blamed_on_its_address() -> None:
    # open_controller reads the status once, so a controller under probe has answered at this address;
    # a timeout in the identity step (no FC 43/14 identity, the status read checks it answers) is not
    # an address problem
    from acquisition.probe import open_probe
    from acquisition.rig import ControllerTiming
    from mocks.faults import FaultPlan
    from mocks.interferometer import DeviceIdentity, InterferometerEmulator, start_controller
    from mocks.world import Noise, World
    from saved_runs.errors import UserError

    emu = InterferometerEmulator(World(noise=Noise.off()), faults=FaultPlan.parse("controller:drop@2x5"))
    emu.identity = DeviceIdentity()  # no device identification objects
    server = start_controller(emu)
    try:
        with (open_probe(None, server.url, timing=ControllerTiming(request_timeout_s=0.2)) as p,
              pytest.raises(UserError) as info):
            p.identity_lines()
    finally:
        server.stop()
    text = str(info.value)
    assert emu.faults.requests("controller") == 2  # the open's status read, then the dropped one
    assert "no response within 0.2 s" in text and "the controller answered before" in text
    assert "check the controller address" not in text and "\n" not in text
