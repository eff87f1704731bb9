"""Running the ``guideway`` command line from tests.

:func:`guideway` runs a command in this process, through ``tui.cli.main`` (the
console script is ``sys.exit(main())``), with stdin, stdout and stderr swapped
for strings: the same code path as ``python -m tui.cli`` without an
interpreter start-up per call.  Use it unless the separate process is the point
of the test (a signal, a kill, the process's exit); those start one with
:func:`spawn`, which gives it a temporary directory the test owns.
"""

from __future__ import annotations

import io
import os
import queue
import signal
import subprocess
import sys
import threading
from collections.abc import Callable
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import IO, Any, NamedTuple

from tui.cli import main

from .waiting import wait_for

ROOT = Path(__file__).resolve().parents[1]


class CliResult(NamedTuple):
    """What a command gave: its exit code and everything it printed."""

    returncode: int
    stdout: str
    stderr: str


def guideway(*args: str | os.PathLike[str], stdin: str = "") -> CliResult:
    """``guideway ARGS`` in this process; ``stdin`` is what the command reads from its standard input."""
    out, err = io.StringIO(), io.StringIO()
    saved_stdin, sys.stdin = sys.stdin, io.StringIO(stdin)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                code = main([os.fspath(a) for a in args])
            except SystemExit as exc:  # argparse: usage errors (2) and --help (0)
                code = exc.code if isinstance(exc.code, int) else int(exc.code is not None)
    finally:
        sys.stdin = saved_stdin
    return CliResult(code, out.getvalue(), err.getvalue())


def one_line_error(res: CliResult | subprocess.CompletedProcess[str], *fragments: str) -> str:
    """Assert exit code 2 with exactly one ``guideway: error:`` line, no traceback, holding every fragment."""
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("guideway: error:")]
    assert len(errors) == 1 and "Traceback" not in res.stderr, res.stderr
    for frag in fragments:
        assert frag in errors[0], errors[0]
    return errors[0]


def spawn(*args: str | os.PathLike[str], tmp_dir: Path, sigint_ignored: bool = False,
          **popen: Any) -> subprocess.Popen[str]:
    """Start ``python -m tui.cli ARGS`` as a separate process (text mode, ``popen`` as for Popen).

    Its TMPDIR is ``tmp_dir`` (created here), a directory the test owns: a process killed with SIGKILL
    cannot remove its temporary files (the simulated sensor's link directory), and they must not be
    left in the machine's /tmp.  ``sigint_ignored`` starts it with SIGINT ignored, as a non-interactive
    shell starts a background job (Python then leaves SIGINT ignored unless the program takes it back).
    """
    tmp_dir.mkdir(parents=True, exist_ok=True)
    argv = [sys.executable, "-m", "tui.cli", *(os.fspath(a) for a in args)]
    if sigint_ignored:
        argv = ["sh", "-c", 'trap "" INT; exec "$0" "$@"', *argv]  # an ignored signal stays so across exec
    env = {**os.environ, "TMPDIR": str(tmp_dir)}
    return subprocess.Popen(argv, cwd=ROOT, env=env, text=True, **popen)


def kill_when(condition: Callable[[], bool], *args: str | os.PathLike[str], tmp_dir: Path, what: str,
              timeout_s: float = 60.0) -> None:
    """Start ``guideway ARGS`` as a separate process and kill it with SIGKILL (nothing can clean up) as soon
    as ``condition()`` holds; fails if the process ends first or ``timeout_s`` passes."""
    proc = spawn(*args, tmp_dir=tmp_dir, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: condition() or proc.poll() is not None, timeout_s=timeout_s, what=what)
        assert proc.poll() is None, f"guideway {args[0]} ended (exit {proc.returncode}) before {what}"
    finally:
        proc.kill()
        proc.wait()


def run_separately(*args: str | os.PathLike[str], tmp_dir: Path, timeout_s: float = 90.0
                   ) -> subprocess.CompletedProcess[str]:
    """``python -m tui.cli ARGS`` as a separate process, to its end; killed, and the test failed, if it
    still runs after ``timeout_s``."""
    with spawn(*args, tmp_dir=tmp_dir, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        try:
            out, err = proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise AssertionError(f"guideway {' '.join(map(os.fspath, args))} still ran after {timeout_s} s; "
                                 "killed") from None
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


class LineReader:
    """The lines of a child's output as they come, read by a thread, so that every wait is bounded."""

    def __init__(self, stream: IO[str]) -> None:
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._thread = threading.Thread(target=self._pump, args=(stream,), daemon=True)
        self._thread.start()

    def _pump(self, stream: IO[str]) -> None:
        for line in stream:
            self._lines.put(line.rstrip("\n"))
        self._lines.put(None)  # end of file

    def next_line(self, timeout_s: float = 30.0, what: str = "a line") -> str:
        """The next line; fails after ``timeout_s``, or at end of file."""
        try:
            line = self._lines.get(timeout=timeout_s)
        except queue.Empty:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}") from None
        if line is None:
            self._lines.put(None)
            raise AssertionError(f"end of output while waiting for {what}")
        return line

    def join(self, timeout_s: float = 10.0) -> None:
        """Wait for end of file (the child has exited and its pipe is closed)."""
        self._thread.join(timeout=timeout_s)


def interrupt(proc: subprocess.Popen[str], sig: int = signal.SIGINT, timeout_s: float = 30.0) -> int:
    """Send ``sig`` and wait for the exit code; a child still running after ``timeout_s`` is killed
    and the test fails saying so (instead of hanging)."""
    proc.send_signal(sig)
    try:
        return proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise AssertionError(f"{' '.join(map(str, proc.args))} still ran {timeout_s} s after "
                             f"{signal.Signals(sig).name}; killed") from None
