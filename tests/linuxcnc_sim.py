"""Running LinuxCNC's own motion controller, headless, on comp files (shared/reference/linuxcnc.md).

:func:`run_linuxcnc` writes a simulation config under a test's directory (INI + HAL: ``trivkins``,
``motmod``, each joint's ``motor-pos-cmd`` looped to ``motor-pos-fb``, the estop and tool-change loops
closed, ``HOME_SEARCH_VEL = 0``, one ``COMP_FILE`` / ``COMP_FILE_TYPE`` per joint), runs
``linuxcnc -r CONFIG.ini`` with tests/linuxcnc_driver.py as its display (run by the system
``/usr/bin/python3``: the ``linuxcnc`` and ``hal`` modules are not in the venv), and returns what the
joints' HAL pins showed at every stop.  Several comp files are checked in one start: one joint each,
all moved together (an instance takes ~2 s to start and stop).

Rules of the machine it runs on:

* As root, ``rtapi_app`` refuses to run without a fallback user (``RTAPI_UID``, here ``nobody``), and
  ``RTAPI_FIFO_PATH`` (the path of its socket) must lie in a directory that user owns and reaches:
  a short-lived directory in /tmp (as tests/fleet/postgres_server.py does for the ``postgres`` user;
  pytest's directories are private to root, and a socket path has at most 107 characters).
* One LinuxCNC per machine (the launcher's ``/tmp/linuxcnc.lock``; started without a tty it shuts
  down another instance).  The tests serialise on an ``flock`` of the launcher itself, and never
  start while the lock file of an instance they did not start exists: they wait, then give up.
* ``HOME`` is the config's directory: the launcher copies its logs there after an error.

Without LinuxCNC the tests are skipped locally with the reason, and fail loudly in CI (``CI`` or
``GUIDEWAY_REQUIRE_LINUXCNC`` set: .ci/run sets the latter and installs linuxcnc-uspace).
"""

from __future__ import annotations

import fcntl
import json
import os
import pwd
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import pytest

LAUNCHER = Path("/usr/bin/linuxcnc")
SYSTEM_PYTHON = Path("/usr/bin/python3")
INSTANCE_LOCK = Path("/tmp/linuxcnc.lock")  # the launcher's: an instance is up
DRIVER = Path(__file__).resolve().parent / "linuxcnc_driver.py"
FALLBACK_USER = "nobody"
AXES = "XYZUVW"  # linear axes, one joint each
# the simulated joints: fast moves (the ramp of the correction takes half of these)
SERVO_PERIOD_NS = 1_000_000
MAX_VELOCITY = 200.0  # mm/s
MAX_ACCELERATION = 1000.0  # mm/s²


def missing() -> str | None:
    """Why LinuxCNC cannot run here (one line), or None."""
    if not LAUNCHER.is_file() or not shutil.which("rtapi_app", path="/usr/bin:/usr/local/bin"):
        return "LinuxCNC is not installed (apt-get install linuxcnc-uspace)"
    probe = subprocess.run([str(SYSTEM_PYTHON), "-c", "import linuxcnc, hal"], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"the system python3 cannot import linuxcnc and hal: {probe.stderr.strip().splitlines()[-1:]}"
    return None


def required() -> bool:
    """Whether a missing LinuxCNC must fail the tests (CI) instead of skipping them."""
    return any(os.environ.get(v, "").strip() not in ("", "0", "false") for v in ("CI", "GUIDEWAY_REQUIRE_LINUXCNC"))


def cannot_run(reason: str) -> NoReturn:
    """Skip the test with ``reason``, or fail it where LinuxCNC is required (CI)."""
    if required():
        pytest.fail(f"{reason} (CI must run the LinuxCNC tests: GUIDEWAY_REQUIRE_LINUXCNC / CI is set)", pytrace=False)
    pytest.skip(f"{reason}; the LinuxCNC tests need it locally")


class LinuxCncBusy(RuntimeError):
    """Another LinuxCNC instance (not started by these tests) is running on this machine."""


@dataclass(frozen=True)
class Stop:
    """The HAL pins of every joint (``joint.N.<pin>``, machine units) at rest after a move to ``commanded``."""

    commanded: float
    joints: tuple[dict[str, float], ...]


@dataclass(frozen=True)
class CompFile:
    """One joint's comp file: its text as written and the INI's ``COMP_FILE_TYPE``."""

    text: str
    file_type: int


@contextmanager
def one_instance(wait_s: float) -> Iterator[None]:
    """Hold the machine-wide test lock and see that no other LinuxCNC is up (waiting ``wait_s`` for it);
    :class:`LinuxCncBusy` if one stays up."""
    # an flock on the launcher: a file every process on the machine sees, and nothing left behind
    with open(LAUNCHER, "rb") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            end = time.monotonic() + wait_s
            while INSTANCE_LOCK.exists():
                if time.monotonic() > end:
                    raise LinuxCncBusy(f"another LinuxCNC is running on this machine ({INSTANCE_LOCK} exists); "
                                       "the tests do not stop an instance they did not start")
                time.sleep(0.5)
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _ini(n: int, files: Sequence[CompFile], low: float, high: float) -> str:
    axes = " ".join(AXES[:n])
    text = f"""[EMC]
VERSION = 1.1
MACHINE = guideway comp check
DEBUG = 0

[DISPLAY]
DISPLAY = ./linuxcnc_driver.py

[TASK]
TASK = milltask
CYCLE_TIME = 0.001

[RS274NGC]
PARAMETER_FILE = sim.var

[EMCMOT]
EMCMOT = motmod
COMM_TIMEOUT = 1.0
SERVO_PERIOD = {SERVO_PERIOD_NS}

[EMCIO]
EMCIO = io
CYCLE_TIME = 0.100
TOOL_TABLE = sim.tbl

[HAL]
HALFILE = sim.hal

[TRAJ]
COORDINATES = {axes}
LINEAR_UNITS = mm
ANGULAR_UNITS = degree
DEFAULT_LINEAR_VELOCITY = {MAX_VELOCITY}
MAX_LINEAR_VELOCITY = {MAX_VELOCITY}
DEFAULT_LINEAR_ACCELERATION = {MAX_ACCELERATION}
MAX_LINEAR_ACCELERATION = {MAX_ACCELERATION}

[KINS]
KINEMATICS = trivkins coordinates={AXES[:n]}
JOINTS = {n}
"""
    for j, comp in enumerate(files):
        text += f"""
[AXIS_{AXES[j]}]
MAX_VELOCITY = {MAX_VELOCITY}
MAX_ACCELERATION = {MAX_ACCELERATION}
MIN_LIMIT = {low}
MAX_LIMIT = {high}

[JOINT_{j}]
TYPE = LINEAR
HOME = 0.0
MAX_VELOCITY = {MAX_VELOCITY}
MAX_ACCELERATION = {MAX_ACCELERATION}
MIN_LIMIT = {low}
MAX_LIMIT = {high}
FERROR = 1.0
MIN_FERROR = 1.0
HOME_OFFSET = 0.0
HOME_SEARCH_VEL = 0
HOME_LATCH_VEL = 0
HOME_SEQUENCE = 0
COMP_FILE = joint{j}.comp
COMP_FILE_TYPE = {comp.file_type}
"""
    return text


def _hal(n: int) -> str:
    lines = ["loadrt [KINS]KINEMATICS",
             "loadrt [EMCMOT]EMCMOT servo_period_nsec=[EMCMOT]SERVO_PERIOD num_joints=[KINS]JOINTS",
             "addf motion-command-handler servo-thread",
             "addf motion-controller servo-thread"]
    # a perfect drive: the motor is where it is commanded
    lines += [f"net j{j}pos joint.{j}.motor-pos-cmd => joint.{j}.motor-pos-fb" for j in range(n)]
    lines += ["net estop-loop iocontrol.0.user-enable-out => iocontrol.0.emc-enable-in",
              "net tool-prep-loop iocontrol.0.tool-prepare => iocontrol.0.tool-prepared",
              "net tool-change-loop iocontrol.0.tool-change => iocontrol.0.tool-changed"]
    return "\n".join(lines) + "\n"


def _environment(config: Path, fifo: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH", "PYTHONHOME", "DISPLAY")}
    env.update(PATH="/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin", HOME=str(config), RTAPI_FIFO_PATH=str(fifo))
    if os.geteuid() == 0:
        env["RTAPI_UID"] = str(pwd.getpwnam(FALLBACK_USER).pw_uid)
    return env


def _stop(proc: subprocess.Popen[bytes], config: Path) -> None:
    """End the LinuxCNC this module started (``proc``, the launcher, leads its own session).

    The launcher shuts LinuxCNC down when its display exits, and defers its own SIGTERM trap until
    then: so first the driver (its pid in driver.pid, checked to be of this session), then the
    launcher, and only then SIGKILL to the session, after which the launcher's lock file (created
    by this instance: none existed when it started) is removed so that later runs are not refused."""
    if proc.poll() is not None:
        return
    try:
        pid = int((config / "driver.pid").read_text())
        if os.getsid(pid) == proc.pid:
            os.kill(pid, signal.SIGTERM)
    except (OSError, ValueError):
        pass  # not started yet, or already gone
    for sig, wait_s in ((None, 20.0), (signal.SIGTERM, 20.0)):
        if sig is not None:
            proc.send_signal(sig)
        try:
            proc.wait(timeout=wait_s)
            return
        except subprocess.TimeoutExpired:
            pass
    os.killpg(proc.pid, signal.SIGKILL)  # its own session: only what this module started
    proc.wait(timeout=10)
    INSTANCE_LOCK.unlink(missing_ok=True)


def run_linuxcnc(config: Path, files: Sequence[CompFile], stops: Sequence[float], *, timeout_s: float = 80.0,
                 busy_wait_s: float = 20.0) -> list[Stop]:
    """Run LinuxCNC with joint j reading ``files[j]`` (at most 6 joints, X Y Z U V W, mm), home every joint at
    0, move all of them together to each of ``stops`` in turn (G53 G0) and return the HAL pins at each.

    ``config``: an empty directory for the config, the files and the logs.  Raises RuntimeError with
    the launcher's output when LinuxCNC fails or times out, :class:`LinuxCncBusy` when another
    instance stays up for ``busy_wait_s``."""
    n = len(files)
    if not 1 <= n <= len(AXES):
        raise ValueError(f"1 to {len(AXES)} comp files, not {n}")
    low, high = min(0.0, *stops) - 10.0, max(0.0, *stops) + 10.0
    config.mkdir(parents=True, exist_ok=True)
    for j, comp in enumerate(files):
        (config / f"joint{j}.comp").write_text(comp.text, encoding="utf-8")
    (config / "sim.ini").write_text(_ini(n, files, low, high), encoding="utf-8")
    (config / "sim.hal").write_text(_hal(n), encoding="utf-8")
    (config / "sim.tbl").write_text("", encoding="utf-8")
    (config / "sim.var").write_text("", encoding="utf-8")
    (config / "plan.json").write_text(json.dumps({"joints": n, "stops": list(stops), "out": "stops.json"}),
                                      encoding="utf-8")
    driver = config / DRIVER.name
    shutil.copyfile(DRIVER, driver)
    driver.chmod(0o755)
    log = config / "linuxcnc.log"
    fifo_dir = Path(tempfile.mkdtemp(prefix="gw-rtapi-", dir="/tmp"))
    try:
        fifo_dir.chmod(0o755)
        if os.geteuid() == 0:
            shutil.chown(fifo_dir, FALLBACK_USER)
        with one_instance(busy_wait_s), open(log, "wb") as out:
            proc = subprocess.Popen([str(LAUNCHER), "-r", str(config / "sim.ini")], cwd=config,
                                    stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                    env=_environment(config, fifo_dir / "fifo"), start_new_session=True)
            try:
                code = proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                _stop(proc, config)
                raise RuntimeError(f"LinuxCNC did not finish within {timeout_s:g} s:\n{_tail(log)}") from None
            finally:
                _stop(proc, config)
    finally:
        shutil.rmtree(fifo_dir, ignore_errors=True)
    if code != 0:
        raise RuntimeError(f"LinuxCNC exited with {code}:\n{_tail(log)}")
    records = json.loads((config / "stops.json").read_text(encoding="utf-8"))
    if len(records) != len(stops):
        raise RuntimeError(f"LinuxCNC recorded {len(records)} of {len(stops)} stops:\n{_tail(log)}")
    return [Stop(float(r["commanded"]), tuple(r["joints"])) for r in records]


def _tail(log: Path, lines: int = 30) -> str:
    return "\n".join(log.read_text(encoding="utf-8", errors="replace").splitlines()[-lines:])


def linuxcnc_version() -> str:
    """The installed linuxcnc-uspace package version (e.g. ``2.9.0~pre1+git20230208.f1270d6ed7-1+deb12u2``)."""
    res = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "linuxcnc-uspace"], capture_output=True, text=True)
    return res.stdout.strip() or "unknown"
