"""The Panasonic HL-G1 BCC rule as the tests compute it: written from the documented rule (protocols.md
section 1.5, the HL-D3 manual: "the exclusive logical sum from the header (%) to the final character of
communication data ... converted to 2-character ASCII code"), independent of the driver and of the
emulator, so that a BCC bug in either cannot hide behind a shared helper."""

from __future__ import annotations


def xor_bcc(text: str) -> str:
    """The BCC of ``text``: the XOR of its characters as two upper-case hex digits."""
    acc = 0
    for ch in text:
        acc ^= ord(ch)
    return format(acc, "02X")


def framed(body: str) -> bytes:
    """``body`` with its BCC and CR, by the test's own rule."""
    return (body + xor_bcc(body) + "\r").encode()
