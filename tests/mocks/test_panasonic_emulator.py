"""The HL-G1 emulator against the frames of protocols.md section 1.5.

BCCs are computed by the test's own XOR rule (:func:`framed`), so an emulator
BCC bug cannot hide behind a shared helper."""

from __future__ import annotations

import math

import pytest

from mocks.faults import FaultPlan
from mocks.panasonic_hlg1 import PanasonicHLG1Emulator
from tests.drivers.hlg1_bcc import framed, xor_bcc


class Source:
    def __init__(self, value: float | None) -> None:
        self.value = value
        self.outputs: list[int] = []

    def __call__(self, output: int) -> float | None:
        self.outputs.append(output)
        return self.value


def test_manual_examples() -> None:
    at_3 = PanasonicHLG1Emulator(Source(-12.3456), station=3, range_mm=20)
    assert at_3.receive(b"%03#RMD**\r") == b"%03$RMD-0123456**\r"
    emu = PanasonicHLG1Emulator(Source(-12.3456), range_mm=20)
    assert emu.receive(b"%01#RMD5C\r") == b"%01$RMD-012345641\r"
    assert emu.receive(b"%01#RSP**\r") == b"%01$RSP+00001**\r"
    assert emu.receive(b"%01#WZS+00001**\r") == b"%01$WZS**\r"
    assert emu.receive(b"%01#WLR+00001**\r") == b"%01$WLR**\r"
    assert emu.receive(b"%01#WRS+00001**\r") == b"%01$WRS**\r"
    assert emu.receive(b"%01#WAV+00004**\r") == b"%01$WAV**\r"
    assert emu.averaging_code == 4 and emu.resets == 1
    assert PanasonicHLG1Emulator(Source(0.0), station=4).receive(b"%04#WHA+0055000**\r") == b"%04$WHA**\r"
    rmb = PanasonicHLG1Emulator(Source(2.5), light_intensity=567)
    rmb.outputs = [False, True, False]
    assert rmb.receive(b"%01#RMB**\r") == b"%01$RMB+002500005670100**\r"


def test_bcc_is_checked_and_replies_carry_one() -> None:
    emu = PanasonicHLG1Emulator(Source(1.0))
    assert emu.receive(framed("%01#RID")) == framed("%01$RID+00567")
    assert emu.receive(b"%01#RMD5D\r") == b"%01!0401\r"  # the document's BCC-error reply
    assert emu.receive(b"%01#RMD5c\r") == framed("%01$RMD+0010000")  # hex case is not significant
    assert emu.receive(b"%01#RMDZZ\r") == framed("%01!04")


def test_multi_drop_and_line_noise() -> None:
    src = Source(0.5)
    emu = PanasonicHLG1Emulator(src, station=7)
    assert emu.receive(framed("%01#RMD")) == b""  # another station's request
    assert emu.receive(b"%07$RMD+0005000**\r") == b""  # a reply on the bus, not a request
    assert emu.receive(b"\x00junk") == b""
    assert emu.receive(b"%07#RMD**\r") == b"%07$RMD+0005000**\r"  # noise before '%' skipped
    assert emu.receive(b"%07#R") == b""
    assert emu.receive(b"MD**\r%07#ROA**\r") == b"%07$RMD+0005000**\r%07$ROA+00000**\r"
    assert set(src.outputs) == {1}


@pytest.mark.parametrize(
    ("request_", "code"),
    [("%01#XYZ", "01"), ("%01#RMD+00001", "03"), ("%01#WZS+1", "03"), ("%01#WZS+00002", "03"),
     ("%01#WLR", "03"), ("%01#WHA+005500", "03"), ("%01#WAV00004x", "03")],
)
def test_error_replies(request_: str, code: str) -> None:
    emu = PanasonicHLG1Emulator(Source(0.0))
    assert emu.receive(framed(request_)) == framed(f"%01!{code}")
    assert emu.receive(f"{request_}**\r".encode()) == f"%01!{code}**\r".encode()


def test_non_ascii_in_a_request_is_a_communication_error() -> None:
    assert PanasonicHLG1Emulator(Source(0.0)).receive(b"%01#RM\xc4**\r") == b"%01!11**\r"


def test_setting_mode_refuses_every_command() -> None:
    emu = PanasonicHLG1Emulator(Source(0.0))
    emu.setting_mode = True
    assert emu.receive(framed("%01#RMD")) == framed("%01!21")
    emu.setting_mode = False
    assert emu.receive(framed("%01#RMD")) == framed("%01$RMD+0000000")


def test_zero_set_and_release() -> None:
    src = Source(1.2345)
    emu = PanasonicHLG1Emulator(src)
    assert emu.receive(b"%01#WZS+00001**\r") == b"%01$WZS**\r"
    src.value = 1.0
    assert emu.receive(b"%01#RMD**\r") == b"%01$RMD-0002345**\r"
    assert emu.receive(b"%01#WZS+00000**\r") == b"%01$WZS**\r"
    assert emu.receive(b"%01#RMD**\r") == b"%01$RMD+0010000**\r"
    src.value = None
    assert emu.receive(b"%01#WZS+00001**\r") == b"%01!22**\r"  # no target to take as zero


@pytest.mark.parametrize("cause", ["no-target", "laser-off", "beyond-range", "nan"])
def test_alarm(cause: str) -> None:
    src = Source({"no-target": None, "beyond-range": 10.5, "nan": math.nan}.get(cause, 2.0))
    emu = PanasonicHLG1Emulator(src, range_mm=10.0)
    if cause == "laser-off":
        assert emu.receive(b"%01#WLR+00000**\r") == b"%01$WLR**\r"
    assert emu.receive(b"%01#ROA**\r") == b"%01$ROA+00001**\r"
    assert emu.receive(b"%01#RMB**\r") == b"%01$RMB+000000000000001**\r"
    assert emu.receive(b"%01#RID**\r") == b"%01$RID+00000**\r"


def test_judgement_outputs() -> None:
    emu = PanasonicHLG1Emulator(Source(0.0))
    emu.outputs = [True, False, True]
    assert emu.receive(b"%01#RZA**\r%01#RZB**\r%01#RZC**\r") == (
        b"%01$RZA+00001**\r%01$RZB+00000**\r%01$RZC+00001**\r")


@pytest.mark.parametrize(
    ("spec", "with_bcc", "reply"),
    [
        ("sensor:drop@1x1", True, b""),
        ("sensor:garbage@1x1", True, b"\x8f\x13#?\xfe\r"),
        ("sensor:error@1x1", True, framed("%01!11")),
        ("sensor:error@1x1=32", False, b"%01!32**\r"),
    ],
)
def test_faults(spec: str, with_bcc: bool, reply: bytes) -> None:
    emu = PanasonicHLG1Emulator(Source(0.25), faults=FaultPlan.parse(spec))
    request = framed("%01#RMD") if with_bcc else b"%01#RMD**\r"
    assert emu.receive(request) == reply
    clean = framed("%01$RMD+0002500") if with_bcc else b"%01$RMD+0002500**\r"
    assert emu.receive(request) == clean
    assert emu.receive(framed("%05#RMD")) == b""  # not for this station: not a request to count


@pytest.mark.parametrize("request_", [framed("%01#RMD"), b"%01#RMD**\r"])
def test_corrupt_fault_sends_a_wrong_bcc(request_: bytes) -> None:
    emu = PanasonicHLG1Emulator(Source(0.25), faults=FaultPlan.parse("sensor:corrupt@1x1"))
    reply = emu.receive(request_)
    body = "%01$RMD+0002500"
    assert reply[:-3] == body.encode() and reply.endswith(b"\r")
    check = reply[-3:-1].decode()
    assert all(c in "0123456789ABCDEF" for c in check) and check != xor_bcc(body)
    with_bcc = request_[-3:-1] != b"**"
    assert emu.receive(request_) == (framed(body) if with_bcc else f"{body}**\r".encode())
