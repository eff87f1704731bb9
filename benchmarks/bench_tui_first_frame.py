"""Time from launching ``guideway tui --simulate`` to its first painted frame (target 1.5 s).

Each run starts the installed command (or ``python -m tui.cli``) in a fresh process on a
pseudo-terminal of 80x24 and reads what it writes until the set-up screen's text appears
(the first complete frame).  Process start is taken just before the spawn, so interpreter
start-up and imports count.  Prints every run, the median and the ratio to the target, and the
CPU time the process had used by then (/proc: less dependent on other load on the machine).

    python benchmarks/bench_tui_first_frame.py [--runs 5]
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

TARGET_S = 1.5
MARKER = b"set-up file"  # the first line of the set-up screen's form
TIMEOUT_S = 60.0


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a running process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def first_frame_s(cmd: list[str], runs_dir: Path) -> tuple[float, float]:
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "80", "LINES": "24"}
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
        return time.perf_counter() - t0, cpu_s(proc.pid)
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
    args = ap.parse_args()
    exe = shutil.which("guideway", path=str(Path(sys.executable).parent))
    cmd = [exe] if exe else [sys.executable, "-m", "tui.cli"]
    times, cpus = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            wall, cpu = first_frame_s(cmd, Path(tmp))
            times.append(wall)
            cpus.append(cpu)
            print(f"run {i + 1}: first frame after {wall:.3f} s ({cpu:.2f} s CPU)")
    med = statistics.median(times)
    print(f"guideway tui first frame: median {med:.3f} s of {args.runs} runs "
          f"(target < {TARGET_S} s, ratio {med / TARGET_S:.2f}); median CPU {statistics.median(cpus):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
