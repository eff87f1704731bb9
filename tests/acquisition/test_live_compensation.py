"""The live compensator (acquisition/live_compensation.py) against the simulated controller over real
loopback Modbus TCP: the offset is the opposite of the model's prediction (computed here with scipy and
numpy on their own), the jump limit, the off switch, stop, and a lost connection (in-process and through
the command line, with its exit code)."""

from __future__ import annotations

import io
import json
import os
import signal
import struct
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from pymodbus.client import ModbusTcpClient
from scipy.interpolate import CubicSpline

from acquisition.live_compensation import LiveCompensator, LiveLinkLost, predictor_from_means, start_in_thread
from mocks.live_controller import LiveOffsetController, start_live_controller
from tests.waiting import wait_for

ROOT = Path(__file__).resolve().parents[2]
X = np.array([0.0, 40.0, 90.0, 130.0, 200.0, 260.0, 300.0, 360.0])
UP = 8.0 * np.sin(np.radians(X)) + 2.0
DOWN = -6.0 * np.sin(np.radians(X)) + 1.0


@pytest.fixture
def controller() -> Iterator[tuple[LiveOffsetController, object]]:
    ctl = LiveOffsetController(rotary=True, timeout_ms=300)
    srv = start_live_controller(ctl)
    yield ctl, srv
    srv.stop()


def test_offset_is_the_opposite_of_the_prediction(controller) -> None:  # noqa: ANN001
    ctl, srv = controller
    # tolerance 0: the adaptive spline ends with every point a knot = the natural spline through all points
    pred = predictor_from_means("spline", X, UP, DOWN, rotary=True, tolerance=0.0)
    comp = LiveCompensator(pred, srv.url, cycle_ms=2, max_jump=1000)
    thread, out = start_in_thread(comp)
    try:
        up, down = CubicSpline(X, UP, bc_type="natural"), CubicSpline(X, DOWN, bc_type="natural")
        for target, expected in ((75.0, -up(75.0)), (215.0, -up(215.0)), (120.0, -down(120.0)),
                                 (120.0, -down(120.0)), (400.0, -up(360.0))):  # moving +: held beyond the range
            got_deg = ctl.move_to(target)
            assert got_deg * 3600.0 == pytest.approx(expected, abs=1e-4), target  # FLOAT32 on the wire
        assert ctl.lags_s and max(ctl.lags_s) < 1.0
    finally:
        comp.stop()
        thread.join(5)
    assert out["stats"].reason == "stopped"
    assert ctl.applied() == 0.0 and not ctl.enabled  # offset 0 and enable 0 written on the way out


def test_cdab_word_order_on_both_sides() -> None:
    ctl = LiveOffsetController(rotary=False, word_order="CDAB")
    srv = start_live_controller(ctl)
    comp = LiveCompensator(predictor_from_means("linear", X, UP, DOWN, rotary=False), srv.url, cycle_ms=2,
                           max_jump=1000, word_order="CDAB")
    thread, _ = start_in_thread(comp)
    try:
        assert ctl.move_to(65.0) * 1000.0 == pytest.approx(-np.interp(65.0, X, UP), abs=1e-4)  # um -> mm
        raw = struct.pack(">f", -np.interp(65.0, X, UP))  # the offset's bytes, most significant first
        assert ctl._regs[12:14] == [int.from_bytes(raw[2:], "big"), int.from_bytes(raw[:2], "big")]  # CDAB
    finally:
        comp.stop()
        thread.join(5)
        srv.stop()
    # a compensator with the wrong word order reads a position that makes no sense, or a wrong one: refused
    ctl = LiveOffsetController(rotary=False, word_order="CDAB", start=123.456)
    srv = start_live_controller(ctl)
    try:
        comp = LiveCompensator(predictor_from_means("linear", X, UP, DOWN, rotary=False), srv.url, cycle_ms=2,
                               max_jump=1000, word_order="ABCD")
        state = comp.client
        state.connect()
        assert state.read_state().position != 123.456
        state.close()
    finally:
        srv.stop()


def test_linear_and_table_models() -> None:
    lin = predictor_from_means("linear", X, UP, DOWN, rotary=True)
    table = predictor_from_means("bidirectional-table", X, UP, DOWN, rotary=True)
    assert lin.error(65.0, 1) == pytest.approx(np.interp(65.0, X, UP))
    grid = np.linspace(0.0, 360.0, len(X))  # 8 equidistant points
    assert table.error(65.0, -1) == pytest.approx(np.interp(65.0, grid, np.interp(grid, X, DOWN)))
    assert table.error(65.0, -1) != pytest.approx(np.interp(65.0, X, DOWN))
    assert lin.error(65.0, 0) == 0.0  # before the first motion


def test_jump_limit_clamps_and_logs(controller) -> None:  # noqa: ANN001
    ctl, srv = controller
    pred = predictor_from_means("linear", X, UP, DOWN, rotary=True)
    log = io.StringIO()
    comp = LiveCompensator(pred, srv.url, cycle_ms=2, max_jump=1.0, stream=log)
    written: list[float] = []  # every offset the compensator writes, in order
    original = comp.client.write_cycle

    def record(heartbeat: int, echo: int, offset: float) -> None:
        written.append(offset)
        original(heartbeat, echo, offset)

    comp.client.write_cycle = record  # type: ignore[method-assign]
    thread, _ = start_in_thread(comp)
    try:
        target = -float(np.interp(90.0, X, UP))  # -10 arcsec from 0: ten steps of at most 1
        ctl.move_to(90.0)  # returns once the offset has settled
        assert ctl.applied() == pytest.approx(target, abs=1e-4)
    finally:
        comp.stop()
        thread.join(5)
    moving = list(written[:-1])  # the last write is the 0 on the way out
    assert np.all(np.abs(np.diff([0.0, *moving])) <= 1.0 + 1e-9), moving
    assert sum(1 for w in moving if -10.0 < w < 0.0) >= 9  # the ramp: -1, -2, ..., -9
    assert comp.stats.jumps_clamped >= 9
    assert "jump: offset +0.000 -> -10.000 arcsec at 90.0000 deg (+): clamped to -1.000" in log.getvalue()


def test_off_switch_at_the_controller_ends_the_loop_with_offset_zero(controller) -> None:  # noqa: ANN001
    ctl, srv = controller
    comp = LiveCompensator(predictor_from_means("linear", X, UP, DOWN, rotary=True), srv.url, cycle_ms=2,
                           max_jump=1000)
    thread, out = start_in_thread(comp)
    ctl.move_to(90.0)
    assert ctl.applied() != 0.0
    client = ModbusTcpClient("127.0.0.1", port=srv.port, timeout=2)
    client.connect()
    client.write_register(8, 0, device_id=1)  # the operator's off switch
    client.close()
    thread.join(5)
    assert not thread.is_alive()
    assert out["stats"].reason.startswith("switched off")
    assert ctl.applied() == 0.0
    assert ctl._regs[12:14] == [0, 0]  # the compensator wrote offset 0 too


def test_lost_connection_ends_the_loop_and_the_controller_drops_the_offset(controller) -> None:  # noqa: ANN001
    ctl, srv = controller
    comp = LiveCompensator(predictor_from_means("linear", X, UP, DOWN, rotary=True), srv.url, cycle_ms=2,
                           max_jump=1000, timeout_s=0.3)
    thread, out = start_in_thread(comp)
    ctl.move_to(90.0)
    assert ctl.applied() == pytest.approx(-float(np.interp(90.0, X, UP)), abs=1e-4)
    srv.stop()  # the link goes down
    thread.join(5)
    assert not thread.is_alive()
    assert isinstance(out["error"], LiveLinkLost)
    assert "lost" in str(out["error"]) and "heartbeat timeout (300 ms)" in str(out["error"])
    # the controller side: the offset is still applied until T has passed without a heartbeat, then 0
    wait_for(lambda: ctl.applied() == 0.0 and ctl.stale, timeout_s=10, what="the controller dropping the offset")


SERVER = """
import sys, time
from mocks.live_controller import LiveOffsetController, start_live_controller
ctl = LiveOffsetController(rotary=True, timeout_ms=300)
srv = start_live_controller(ctl)
print(srv.port, flush=True)
while True:
    ctl.publish(45.0 if int(time.monotonic() * 10) % 2 else 135.0)
    time.sleep(0.01)
"""


@pytest.fixture(scope="module")
def as_found(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("live") / "found"
    res = subprocess.run([sys.executable, "-m", "tui.cli", "acquire", "positioning", "--setup",
                          str(ROOT / "tests" / "data" / "seed003" / "rotary-found.toml"), "--out", str(run),
                          "--simulate", "--auto"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return run


def _server() -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen([sys.executable, "-c", SERVER], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    return proc, int(proc.stdout.readline())


def _compensate(run: Path, port: int, *, sigint_ignored: bool = False) -> subprocess.Popen:
    argv = [sys.executable, "-m", "tui.cli", "compensate", "live", str(run), "--controller",
            f"modbus-tcp://127.0.0.1:{port}", "--cycle-ms", "4"]
    if sigint_ignored:  # as a non-interactive shell starts a background job: an ignored signal stays so across exec
        argv = ["sh", "-c", 'trap "" INT; exec "$0" "$@"', *argv]
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert proc.stdout.readline().startswith("live compensation: spline model of")
    return proc



def _end(*procs: subprocess.Popen) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
        p.communicate(timeout=10)  # and close its pipes


def _registers(port: int) -> list[int]:
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
    assert client.connect()
    regs = list(client.read_holding_registers(0, count=17, device_id=1).registers)
    client.close()
    return regs


def test_cli_exits_3_with_one_line_when_the_server_dies(as_found: Path) -> None:
    server, port = _server()
    comp = _compensate(as_found, port)
    try:
        wait_for(lambda: _registers(port)[9] > 10, timeout_s=10, what="the heartbeat")  # it is cycling
        server.kill()  # the controller dies mid-run
        server.communicate(timeout=5)
        _, err = comp.communicate(timeout=15)
    finally:
        _end(server, comp)
    assert comp.returncode == 3, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("guideway: error: connection to the live-compensation controller")
    assert "Traceback" not in err


@pytest.mark.parametrize("sigint_ignored", [False, True], ids=["sigint-default", "sigint-ignored"])
def test_cli_ctrl_c_writes_offset_zero_before_exit(as_found: Path, sigint_ignored: bool) -> None:
    # sigint-ignored: a job started in the background by a script (CI running the suite as one) inherits SIGINT
    # ignored; before the fix the compensator never saw the Ctrl-C and ran on (this test ran into its 15 s)
    server, port = _server()
    comp = _compensate(as_found, port, sigint_ignored=sigint_ignored)
    try:
        wait_for(lambda: _registers(port)[8] == 1 and _registers(port)[12:14] != [0, 0], timeout_s=10,
                 what="a non-zero offset")
        os.kill(comp.pid, signal.SIGINT)
        _, err = comp.communicate(timeout=15)
        after = _registers(port)
    finally:
        _end(server, comp)
    assert comp.returncode == 130, err
    assert "offset 0 written" in err
    assert after[8] == 0 and after[12:14] == [0, 0] and after[11] == 0


def test_cli_usage_errors_are_one_line(as_found: Path, tmp_path: Path) -> None:
    def guideway(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "tui.cli", *args], cwd=ROOT, capture_output=True, text=True,
                              timeout=60)

    res = guideway("compensate", "live", str(as_found), "--controller", "http://x")
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "modbus-tcp://" in res.stderr
    res = guideway("compensate", "live", str(tmp_path / "nope"), "--controller", "modbus-tcp://127.0.0.1:1")
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    res = guideway("compensate", "live", str(as_found), "--controller", "modbus-tcp://127.0.0.1:1", "--cycle-ms", "0")
    assert res.returncode == 2 and "--cycle-ms" in res.stderr
    # nobody listening: the controller cannot be reached (exit 3, one line)
    res = guideway("compensate", "live", str(as_found), "--controller", "modbus-tcp://127.0.0.1:1")
    assert res.returncode == 3 and res.stderr.count("\n") == 1, res.stderr


def test_acquire_live_compensation_refusals(as_found: Path, tmp_path: Path) -> None:
    def acquire(*args: object) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "tui.cli", "acquire", *map(str, args)], cwd=ROOT,
                              capture_output=True, text=True, timeout=120)

    rotary = ROOT / "tests" / "data" / "seed003" / "rotary-left.toml"
    linear = ROOT / "docs" / "setup-positioning.toml"
    cases = [
        (("positioning", "--setup", rotary, "--out", tmp_path / "a", "--auto", "--live-compensation", as_found),
         "--live-compensation needs --simulate"),
        (("positioning", "--setup", linear, "--out", tmp_path / "b", "--simulate", "--auto", "--live-compensation",
          as_found), "is a rotary axis's run, this set-up's axis is linear"),
        (("positioning", "--setup", rotary, "--out", tmp_path / "c", "--simulate", "--auto", "--live-model",
          "linear"), "--live-model needs --live-compensation"),
        (("straightness", "--setup", ROOT / "docs" / "setup-straightness.toml", "--out", tmp_path / "d",
          "--simulate", "--auto", "--live-compensation", as_found), "--live-compensation is for positioning runs"),
    ]
    for args, fragment in cases:
        res = acquire(*args)
        assert res.returncode == 2, (args, res.stderr)
        assert res.stderr.count("\n") == 1 and fragment in res.stderr, res.stderr
        assert not Path(str(args[4])).exists()
    # an "as-found" run measured with compensation active is not the axis's own error
    compensated = tmp_path / "compensated"
    compensated.mkdir()
    for name in ("points.csv", "events.jsonl"):
        if (as_found / name).exists():
            (compensated / name).write_bytes((as_found / name).read_bytes())
    meta = json.loads((as_found / "run.json").read_text())
    meta["compensation"] = {"active": True, "format": "live", "file": "live spline"}
    (compensated / "run.json").write_text(json.dumps(meta))
    res = acquire("positioning", "--setup", rotary, "--out", tmp_path / "e", "--simulate", "--auto",
                  "--live-compensation", compensated)
    assert res.returncode == 2 and "measured with compensation active" in res.stderr, res.stderr


def test_unfittable_means_are_a_one_line_error() -> None:
    from saved_runs.errors import UserError

    with pytest.raises(UserError, match="cannot fit the spline model"):
        predictor_from_means("spline", X, np.where(X == 90.0, np.nan, UP), DOWN, rotary=True)
    with pytest.raises(UserError, match="unknown live model"):
        predictor_from_means("nurbs", X, UP, DOWN, rotary=True)


def test_cli_choices_are_the_models() -> None:
    from acquisition.live_compensation import LIVE_MODELS
    from tui.commands.compensate import LIVE_MODELS as CLI_MODELS

    assert CLI_MODELS == LIVE_MODELS  # written out so that --help loads no numerics
