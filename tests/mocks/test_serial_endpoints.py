"""Line timing of the endpoints: a reply is never delivered before request +
reply would have crossed the wire, and its last byte is what arrives last.
(Lower bounds only: a busy machine may always be later.)"""

from __future__ import annotations

import time

from mocks.serial_endpoints import TcpEndpoint, sleep_until, wire_time_s


class Echo:
    def receive(self, data: bytes) -> bytes:
        return b"ANSWER:" + data


def test_wire_time_is_ten_bits_per_character() -> None:
    assert wire_time_s(12, 115200) == 12 * 10 / 115200
    assert wire_time_s(5, 0) == 0.0  # no line timing


def test_sleep_until_never_returns_early() -> None:
    due = time.monotonic() + 0.002
    sleep_until(due)
    assert time.monotonic() >= due


def test_reply_delivered_at_line_speed_last_byte_last() -> None:
    baud = 9600  # slow enough that the bounds are far apart
    endpoint = TcpEndpoint(Echo(), baudrate=baud)
    sent: list[tuple[float, bytes]] = []
    try:
        t_in = time.monotonic()
        assert endpoint._answer(b"M1\r", t_in, lambda b: sent.append((time.monotonic(), b)))
    finally:
        endpoint.stop()
    reply = b"ANSWER:M1\r"
    assert b"".join(b for _, b in sent) == reply
    (t_head, head), (t_last, last) = sent
    assert last == b"\r" and head == reply[:-1]
    char_s = 10 / baud
    assert t_last >= t_in + (3 + len(reply)) * char_s  # request + reply on the wire
    assert t_head >= t_in + (3 + len(reply) - 1) * char_s
