"""SerialLink's read loop over a real byte stream (``loop://``, and a pty fed
in pieces): frames split or joined across reads come out whole and in order,
a missing terminator is a timeout that keeps nothing for the next read."""

from __future__ import annotations

import os
import threading
import tty

import pytest

from drivers.errors import TransportTimeout
from drivers.transport import open_serial


def test_frames_already_waiting_are_split_at_the_terminator() -> None:
    link = open_serial("loop://")
    try:
        link.write(b"M1,+0.1\rM2,-0.2\rQ")
        assert link.read_until(b"\r", 1.0) == b"M1,+0.1\r"
        assert link.read_until(b"\r", 1.0) == b"M2,-0.2\r"
        assert link.read_exact(1, 1.0) == b"Q"
        with pytest.raises(TransportTimeout, match="within 0.05 s"):
            link.read_until(b"\r", 0.05)
    finally:
        link.close()


def test_partial_data_is_dropped_after_a_timeout() -> None:
    link = open_serial("loop://")
    try:
        link.write(b"M1,+0")
        with pytest.raises(TransportTimeout, match=r"got b'M1,\+0'"):
            link.read_until(b"\r", 0.05)
        link.write(b"R0\r")
        assert link.read_until(b"\r", 1.0) == b"R0\r"
    finally:
        link.close()


def test_frame_written_in_pieces_over_a_pty_comes_out_whole() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    link = open_serial(os.ttyname(slave))
    pieces = [b"M0,+01.2", b"345,-00.0", b"120\r", b"R0\r"]
    feeder = threading.Thread(target=lambda: [os.write(master, p) for p in pieces], daemon=True)
    feeder.start()
    try:
        assert link.read_until(b"\r", 5.0) == b"M0,+01.2345,-00.0120\r"
        assert link.read_until(b"\r", 5.0) == b"R0\r"
    finally:
        feeder.join(timeout=10)
        link.close()
        os.close(master)
        os.close(slave)
