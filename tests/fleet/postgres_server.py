"""A throwaway PostgreSQL server for the catalogue's tests: ``initdb`` and ``pg_ctl`` (Debian's
``postgresql`` package) as the ``postgres`` user when running as root, on a free port on 127.0.0.1, in a
temporary directory removed at the end (/work/shared/reference/postgresql.md).

Without the server binaries the tests are skipped locally with the reason, and fail loudly in CI
(``CI`` or ``GUIDEWAY_REQUIRE_POSTGRES`` set: .ci/run sets the latter and installs the package)."""

from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

USER = "guideway"


def server_bindir() -> Path | None:
    """The directory of ``initdb`` and ``pg_ctl`` (newest Debian version first, else PATH)."""
    for cand in sorted(glob.glob("/usr/lib/postgresql/*/bin"), key=lambda p: int(Path(p).parent.name), reverse=True):
        if (Path(cand) / "initdb").is_file() and (Path(cand) / "pg_ctl").is_file():
            return Path(cand)
    found = shutil.which("initdb")
    return Path(found).parent if found and shutil.which("pg_ctl") else None


def required() -> bool:
    """Whether a missing server must fail the tests (CI) instead of skipping them."""
    return any(os.environ.get(v, "").strip() not in ("", "0", "false") for v in ("CI", "GUIDEWAY_REQUIRE_POSTGRES"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _as_server_user(cmd: list[str]) -> list[str]:
    # initdb and postgres refuse to run as root: run them as the postgres system user
    return ["runuser", "-u", "postgres", "--", *cmd] if os.geteuid() == 0 else cmd


@contextmanager
def postgres_server() -> Iterator[str]:
    """Start a server; yield its URL (``postgresql://guideway@127.0.0.1:PORT/postgres``); always stop it
    and remove its directory."""
    bindir = server_bindir()
    if bindir is None:
        raise FileNotFoundError("PostgreSQL server binaries (initdb, pg_ctl) not found: apt-get install postgresql")
    # outside the tests' TMPDIR: the postgres user must be able to reach it (pytest's base is private to root)
    top = Path(tempfile.mkdtemp(prefix="guideway-pg-", dir="/tmp"))
    data, log = top / "data", top / "log"
    try:
        top.chmod(0o755)
        if os.geteuid() == 0:
            shutil.chown(top, "postgres", "postgres")
        port = _free_port()
        subprocess.run(_as_server_user([str(bindir / "initdb"), "-D", str(data), "-A", "trust", "-U", USER,
                                        "--no-sync", "-E", "UTF8"]), check=True, capture_output=True, timeout=120)
        options = f"-k {top} -p {port} -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=50"
        subprocess.run(_as_server_user([str(bindir / "pg_ctl"), "-D", str(data), "-o", options, "-l", str(log),
                                        "-w", "-t", "60", "start"]), check=True, capture_output=True, timeout=90)
        try:
            yield f"postgresql://{USER}@127.0.0.1:{port}/postgres"
        finally:
            subprocess.run(_as_server_user([str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate", "-w",
                                            "stop"]), capture_output=True, timeout=60)
    finally:
        shutil.rmtree(top, ignore_errors=True)
