"""Shared fixtures and options.

Hardware tests are skipped unless a device URL is given:
``pytest -m hardware --sensor-url keyence-lkg:/dev/ttyUSB0 --controller-url modbus-tcp://10.0.0.5:502``.
"""

from __future__ import annotations

import logging

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--sensor-url", default=None, help="PROTOCOL:URL of a real displacement sensor")
    parser.addoption("--controller-url", default=None, help="URL of a real interferometer controller")


@pytest.fixture(autouse=True)
def _quiet_pymodbus() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


@pytest.fixture
def sim_rig():
    """A running simulated rig (pty sensor + Modbus TCP controller), noise off."""
    from acquisition.simulation import start_simulated_rig

    rig = start_simulated_rig(seed=1, noise=False)
    yield rig
    rig.close()
