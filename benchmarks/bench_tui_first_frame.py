"""Time from launching ``guideway tui --simulate`` to its first painted frame (target 1.0 s), and
to F5 being accepted (target 1.0 s: the run starts, the connect screen appears).

Each run starts the installed command (or ``python -m tui.cli``) in a fresh process on a
pseudo-terminal of 80x24 and reads what it writes until the set-up screen's text appears
(the first complete frame).  Then it presses F5 every 20 ms until the connect screen's title
appears (F5 accepted; a press before the set-up can be checked is refused, as a technician's
would be).  Process start is taken just before the spawn, so interpreter start-up and imports
count.  Prints every run, the medians and the ratio to the targets, and the CPU time the process
had used at the first frame (/proc: less dependent on other load on the machine).

    python benchmarks/bench_tui_first_frame.py [--runs 5] [--code DIR]

``--code DIR`` runs the tool from another checkout (e.g. ``git archive 8c3aa62 | tar -x -C DIR``)
with this environment's Python, for a before/after comparison.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import select
import shutil
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import termios
import time
from pathlib import Path

TARGET_S = 1.0
F5_TARGET_S = 1.0
MARKER = b"set-up file"  # the first line of the set-up screen's form
ACCEPTED = b"Connect and warm-up"  # the title of the screen F5 opens
F5 = b"\x1b[15~"
TIMEOUT_S = 60.0


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a running process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def first_frame_s(cmd: list[str], runs_dir: Path, env_extra: dict[str, str] | None = None
                  ) -> tuple[float, float, float, float]:
    """(first frame s, CPU s at the first frame, F5 accepted s, CPU s then) of one launch."""
    runs_dir.mkdir(parents=True, exist_ok=True)
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "80", "LINES": "24", **(env_extra or {})}
    t0 = time.perf_counter()
    proc = subprocess.Popen([*cmd, "tui", "--simulate", "--runs", str(runs_dir)], stdin=slave, stdout=slave,
                            stderr=slave, env=env, start_new_session=True, cwd=runs_dir)
    os.close(slave)
    seen = b""
    try:
        while MARKER not in seen:
            if time.perf_counter() - t0 > TIMEOUT_S:
                raise RuntimeError(f"no first frame within {TIMEOUT_S} s (got {seen[-200:]!r})")
            ready, _, _ = select.select([master], [], [], 0.5)
            if ready:
                seen += os.read(master, 65536)
        first, cpu = time.perf_counter() - t0, cpu_s(proc.pid)
        seen = b""
        while ACCEPTED not in seen:
            if time.perf_counter() - t0 > TIMEOUT_S:
                raise RuntimeError(f"F5 not accepted within {TIMEOUT_S} s (got {seen[-200:]!r})")
            os.write(master, F5)
            ready, _, _ = select.select([master], [], [], 0.02)
            if ready:
                seen = seen[-200:] + os.read(master, 65536)
        return first, cpu, time.perf_counter() - t0, cpu_s(proc.pid)
    finally:
        os.killpg(proc.pid, signal.SIGTERM)  # only the process group this run started
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        os.close(master)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--code", type=Path, default=None, help="run the tool from this checkout (PYTHONPATH)")
    args = ap.parse_args()
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    cmd = [exe] if exe and args.code is None else [sys.executable, "-m", "tui.cli"]
    env = {"PYTHONPATH": str(args.code.resolve())} if args.code is not None else None
    times, cpus, f5s, f5_cpus = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            wall, cpu, f5, f5_cpu = first_frame_s(cmd, Path(tmp) / f"r{i}", env)
            times.append(wall)
            cpus.append(cpu)
            f5s.append(f5)
            f5_cpus.append(f5_cpu)
            print(f"run {i + 1}: first frame after {wall:.3f} s ({cpu:.2f} s CPU), F5 accepted after {f5:.3f} s "
                  f"({f5_cpu:.2f} s CPU)")
    med, f5_med = statistics.median(times), statistics.median(f5s)
    print(f"guideway tui first frame: median {med:.3f} s of {args.runs} runs "
          f"(target < {TARGET_S} s, ratio {med / TARGET_S:.2f}); median CPU {statistics.median(cpus):.2f} s")
    print(f"guideway tui F5 accepted: median {f5_med:.3f} s after launch "
          f"(target < {F5_TARGET_S} s, ratio {f5_med / F5_TARGET_S:.2f}); "
          f"median CPU {statistics.median(f5_cpus):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
