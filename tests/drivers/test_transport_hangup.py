"""A port that hangs up (unplugged USB adapter; emulated by closing a pty's
master side) gives ConnectionLost on read and write, never a raw pyserial error."""

from __future__ import annotations

import os
import termios
import tty

import pytest

from drivers.errors import ConnectionLost
from drivers.transport import open_serial


@pytest.fixture
def hung_up_link():
    master, slave = os.openpty()
    tty.setraw(slave)
    link = open_serial(os.ttyname(slave))
    os.close(master)  # the far side is gone: reads/ioctls on the slave now fail with EIO
    yield link
    link.close()
    os.close(slave)


def test_read_on_hung_up_port_is_connection_lost(hung_up_link) -> None:
    with pytest.raises(ConnectionLost, match="read from"):
        hung_up_link.read_until(b"\r", 0.2)


def test_write_on_hung_up_port_is_connection_lost(hung_up_link) -> None:
    with pytest.raises(ConnectionLost, match="write to"):
        hung_up_link.write(b"M1\r")


def test_drain_failing_on_hang_up_is_connection_lost(hung_up_link, monkeypatch: pytest.MonkeyPatch) -> None:
    # The write itself can still succeed when the far side goes in the middle of it; pyserial's
    # flush() (tcdrain) then raises termios.error, which is not an OSError.
    monkeypatch.setattr(hung_up_link.port, "write", lambda data: len(data))

    def drain_fails() -> None:
        raise termios.error(5, "Input/output error")

    monkeypatch.setattr(hung_up_link.port, "flush", drain_fails)
    with pytest.raises(ConnectionLost, match="write to"):
        hung_up_link.write(b"M1\r")
