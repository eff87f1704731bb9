"""Shared fixtures and options.

Hardware tests are skipped unless a device URL is given:
``pytest -m hardware --sensor-url keyence-lkg:/dev/ttyUSB0 --controller-url modbus-tcp://10.0.0.5:502``.
"""

from __future__ import annotations

import logging
import os
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from .setups import straightness_setup_text


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--sensor-url", default=None, help="PROTOCOL:URL of a real displacement sensor")
    parser.addoption("--controller-url", default=None, help="URL of a real interferometer controller")


@pytest.fixture(autouse=True)
def _quiet_pymodbus() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


@pytest.fixture
def sim_rig():
    """A running simulated rig (pty sensor + Modbus TCP controller), noise off."""
    from acquisition.simulated.rig import start_simulated_rig

    rig = start_simulated_rig(seed=1, noise=False)
    yield rig
    rig.close()


@pytest.fixture(scope="session", autouse=True)
def session_tmpdir(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The session's own TMPDIR, for this process (``tempfile``) and every child it starts.

    Temporary files (the simulated sensor's ``guideway-sim-*`` link directory) then never mix with
    other runs' in the machine's /tmp: what a test leaves behind is seen (``_nothing_left_in_tmpdir``),
    and it goes with the session's other temporary directories (kept only when a test failed).
    """
    tmp = tmp_path_factory.mktemp("tmpdir", numbered=False)
    patch = pytest.MonkeyPatch()
    patch.setenv("TMPDIR", str(tmp))
    patch.setattr(tempfile, "tempdir", str(tmp))
    yield tmp
    patch.undo()


@pytest.fixture(autouse=True)
def _nothing_left_in_tmpdir(session_tmpdir: Path, request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a test that leaves a file or directory in TMPDIR (a child it killed must be given a
    TMPDIR of the test's own: ``tests.cli.spawn``)."""
    before = set(os.listdir(session_tmpdir))
    yield
    left = sorted(set(os.listdir(session_tmpdir)) - before)
    if left:
        pytest.fail(f"{request.node.nodeid} left {', '.join(left)} in TMPDIR {session_tmpdir}", pytrace=False)


@pytest.fixture
def refused_port() -> Iterator[int]:
    """A loopback TCP port that refuses connections for the whole test: bound, never listening, kept open
    (a port that was merely free a moment ago may have been taken since)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


@pytest.fixture
def setup_file(tmp_path: Path) -> Path:
    """A straightness set-up file: the documented example with 6 stations, 2 samples, no warm-up wait."""
    path = tmp_path / "setup.toml"
    path.write_text(straightness_setup_text(stations=6, samples=2))
    return path


@pytest.fixture(scope="session")
def reliability_references(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, Path]]:
    """Each run kind's trial set-up and the run it gives when never interrupted (tests/reliability.py),
    made when first asked for and shared by the reliability tests."""
    from .reliability import reference_run

    base = tmp_path_factory.mktemp("reliability-references")

    class Lazy(dict):
        def __missing__(self, kind: str) -> tuple[Path, Path]:
            self[kind] = reference_run(kind, base)
            return self[kind]

    return Lazy()
