"""Panasonic HL-G1 codec and driver against the manual's frames (protocols.md
section 1.5: command formats p.4-8, RMD example p.4-10, error codes p.4-16,
read commands p.4-22, BCC rule of the HL-D3 manual).

Expected BCCs come from :func:`xor_bcc` (tests/drivers/hlg1_bcc.py), written from the documented rule
("the exclusive logical sum from the header (%) to the final character of
communication data ... converted to 2-character ASCII code"), and are checked
against the literal examples the document gives.
"""

from __future__ import annotations

import math

import pytest

from drivers.errors import ChecksumError, DeviceError, ProtocolError, TransportTimeout
from drivers.panasonic_hlg1 import PanasonicHLG1
from drivers.panasonic_hlg1 import protocol as p
from drivers.readings import MeasurementStatus
from tests.drivers.hlg1_bcc import framed, xor_bcc
from tests.protocol_fakes import ExpectedProtocol

ERROR_CODES = {
    "01": "Command error", "02": "Address error", "03": "Data error", "04": "BCC error",
    "11": "Communication error", "21": "Control flow error", "22": "Execution error",
    "31": "Buffering condition error 1", "32": "Buffering condition error 2", "33": "Buffering condition error 3",
}


# The BCC rule ----------------------------------------------------------------------------------------
def test_bcc_matches_the_manual_examples() -> None:
    assert xor_bcc("%EE#RMBC") == "18"  # HL-D3 manual example
    assert p.bcc(b"%EE#RMBC") == b"18"
    assert framed("%01#RMD") == b"%01#RMD5C\r"  # protocols.md "same, with real BCC"
    assert framed("%01$RMD-0123456") == b"%01$RMD-012345641\r"
    assert framed("%01!04") == b"%01!0401\r"


# Requests ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "kwargs", "wire"),
    [
        ((3, "RMD"), {"use_bcc": False}, b"%03#RMD**\r"),  # manual p.4-10
        ((1, "RMD"), {}, b"%01#RMD5C\r"),
        ((1, "RSP"), {"use_bcc": False}, b"%01#RSP**\r"),  # manual p.4-8
        ((4, "WHA", "+0055000"), {"use_bcc": False}, b"%04#WHA+0055000**\r"),  # manual
        ((1, "WZS", "+00001"), {"use_bcc": False}, b"%01#WZS+00001**\r"),
        ((1, "RMB"), {"use_bcc": False}, b"%01#RMB**\r"),
        ((1, "WLR", "+00001"), {"use_bcc": False}, b"%01#WLR+00001**\r"),
        ((1, "WRS", "+00001"), {"use_bcc": False}, b"%01#WRS+00001**\r"),
        ((1, "WAV", "+00004"), {"use_bcc": False}, b"%01#WAV+00004**\r"),
        ((16, "WZS", "+00001"), {}, framed("%16#WZS+00001")),
        ((1, "RID"), {}, framed("%01#RID")),
    ],
)
def test_requests_are_the_documented_bytes(args: tuple, kwargs: dict, wire: bytes) -> None:
    assert p.encode_request(*args, **kwargs) == wire


@pytest.mark.parametrize(
    "call",
    [lambda: p.encode_request(0, "RMD"), lambda: p.encode_request(17, "RMD"), lambda: p.encode_request(1, "RM"),
     lambda: p.encode_request(1, "rmd"), lambda: p.encode_request(1, "WZS", "+1\r"),
     lambda: p.format_setting(100_000), lambda: p.format_measured(950.0001)],
)
def test_invalid_requests_are_refused(call) -> None:  # noqa: ANN001
    with pytest.raises(ValueError):
        call()


def test_data_formats() -> None:
    assert p.format_measured(5.5) == "+0055000"
    assert p.format_measured(-12.3456) == "-0123456"
    assert p.format_setting(1) == "+00001"
    assert p.parse_measured("-0123456") == -12.3456
    assert p.parse_measured("+9500000") == 950.0
    assert p.parse_setting("+04095") == 4095
    for bad in ("+9500001", "-9500001", "0123456", "+012345", "+01234567", "+01234a6"):
        with pytest.raises(ProtocolError):
            p.parse_measured(bad)


# Replies -------------------------------------------------------------------------------------------
def test_measured_value_examples() -> None:
    assert p.decode_measured(b"%03$RMD-0123456**\r", 3, require_bcc=False) == -12.3456
    assert p.decode_measured(b"%01$RMD-012345641\r", 1) == -12.3456
    assert p.decode_measured(b"%01$RMD-012345641\r", 1, require_bcc=False) == -12.3456  # a real BCC is checked


def test_all_outputs_example() -> None:
    out = p.decode_all_outputs(b"%01$RMB+002500005670100**\r", 1, require_bcc=False)
    assert out == p.AllOutputs(value_mm=2.5, light_intensity=567, out1=False, out2=True, out3=False, alarm=False)
    alarm = p.decode_all_outputs(framed("%01$RMB+002500005670001"), 1)
    assert alarm.alarm and not alarm.out2


def test_setting_and_ack_replies() -> None:
    assert p.decode_setting(b"%01$RSP+00001**\r", 1, "RSP", require_bcc=False) == 1
    assert p.decode_setting(framed("%01$RID+04095"), 1, "RID") == 4095
    assert p.decode_flag(framed("%01$ROA+00001"), 1, "ROA") is True
    assert p.decode_flag(framed("%01$RZB+00000"), 1, "RZB") is False
    with pytest.raises(ProtocolError):
        p.decode_flag(framed("%01$ROA+00002"), 1, "ROA")
    p.decode_ack(b"%04$WHA**\r", 4, "WHA", require_bcc=False)
    p.decode_ack(framed("%01$WZS"), 1, "WZS")
    with pytest.raises(ProtocolError):
        p.decode_ack(framed("%01$WZS+00001"), 1, "WZS")


@pytest.mark.parametrize("code", sorted(ERROR_CODES))
@pytest.mark.parametrize("with_bcc", [True, False])
def test_every_error_reply(code: str, with_bcc: bool) -> None:
    frame = framed(f"%01!{code}") if with_bcc else f"%01!{code}**\r".encode()
    with pytest.raises(DeviceError) as info:
        p.decode_measured(frame, 1, require_bcc=with_bcc)
    assert info.value.code == code and info.value.command == "RMD"
    assert info.value.text.startswith(ERROR_CODES[code])


def test_bcc_error_example() -> None:
    with pytest.raises(DeviceError, match="BCC check was not conformable"):
        p.decode_ack(b"%01!0401\r", 1, "WZS")


@pytest.mark.parametrize(
    ("frame", "error"),
    [
        (b"%01$RMD-012345642\r", ChecksumError),  # one off
        (b"%01$RMD-012345640\r", ChecksumError),
        (b"%01$RMD-0123456**\r", ProtocolError),  # no BCC although the request had one
        (b"%01$RMD-01234564G\r", ProtocolError),
        (b"%01$RMD-012345641", ProtocolError),  # no CR
        (framed("%02$RMD-0123456"), ProtocolError),  # another station
        (framed("%01$RID-0123456"), ProtocolError),  # another command
        (framed("%01#RMD-0123456"), ProtocolError),  # a request, not a reply
        (framed("%01!4"), ProtocolError),
        (framed("%01$RMD+9500001"), ProtocolError),
        (framed("%01$RMD-01234"), ProtocolError),
        (b"\x8f\x13#?\xfe\r", ProtocolError),
        (b"\r", ProtocolError),
    ],
)
def test_malformed_replies(frame: bytes, error: type[Exception]) -> None:
    with pytest.raises(error):
        p.decode_measured(frame, 1)


def test_lower_case_bcc_is_accepted() -> None:
    assert p.decode_measured(b"%01$RMD+0000000" + xor_bcc("%01$RMD+0000000").lower().encode() + b"\r", 1) == 0.0


# Driver conversations ------------------------------------------------------------------------------
def test_driver_reads_value_and_alarm_with_rmb() -> None:
    link = ExpectedProtocol([(framed("%01#RMB"), framed("%01$RMB-012345605670000")),
                             (framed("%01#RMB"), framed("%01$RMB+000000000000001"))])
    dev = PanasonicHLG1(link)
    ok, alarm = dev.read_once(), dev.read_once()
    link.assert_done()
    assert ok.ok and ok.value_mm == -12.3456 and ok.raw == framed("%01$RMB-012345605670000").decode()
    assert alarm.status is MeasurementStatus.ALARM and math.isnan(alarm.value_mm) and not alarm.ok


def test_driver_manual_example_without_bcc_at_station_3() -> None:
    link = ExpectedProtocol([(b"%03#RMD**\r", b"%03$RMD-0123456**\r")])
    reading = PanasonicHLG1(link, station=3, use_bcc=False).read_value()
    link.assert_done()
    assert reading.ok and reading.value_mm == -12.3456


def test_driver_write_commands() -> None:
    link = ExpectedProtocol([
        (b"%01#WZS+00001**\r", b"%01$WZS**\r"),
        (b"%01#WZS+00000**\r", b"%01$WZS**\r"),
        (b"%01#WRS+00001**\r", b"%01$WRS**\r"),
        (b"%01#WLR+00001**\r", b"%01$WLR**\r"),
        (b"%01#WLR+00000**\r", b"%01$WLR**\r"),
        (b"%01#WAV+00004**\r", b"%01$WAV**\r"),
    ])
    dev = PanasonicHLG1(link, use_bcc=False)
    dev.zero_set()
    dev.zero_set(False)
    dev.reset()
    dev.laser(True)
    dev.laser(False)
    dev.set_averaging_code(4)
    link.assert_done()


def test_driver_threshold_at_station_4() -> None:
    link = ExpectedProtocol([(b"%04#WHA+0055000**\r", b"%04$WHA**\r")])
    PanasonicHLG1(link, station=4, use_bcc=False).set_threshold_a(5.5)
    link.assert_done()


def test_driver_read_commands_with_bcc() -> None:
    link = ExpectedProtocol([
        (framed("%01#RID"), framed("%01$RID+04095")),
        (framed("%01#ROA"), framed("%01$ROA+00001")),
        (framed("%01#RZA"), framed("%01$RZA+00000")),
        (framed("%01#RZC"), framed("%01$RZC+00001")),
        (framed("%01#RSP"), framed("%01$RSP+00001")),
        (framed("%01#RMB"), framed("%01$RMB+002500005670100")),
    ])
    dev = PanasonicHLG1(link)
    assert dev.light_intensity() == 4095
    assert dev.alarm() is True
    assert dev.judgement_output(1) is False
    assert dev.judgement_output(3) is True
    assert dev.sampling_cycle_code() == 1
    assert dev.read_all_outputs().out2 is True
    link.assert_done()


def test_driver_device_error_keeps_code_and_text() -> None:
    link = ExpectedProtocol([(framed("%01#WZS+00001"), framed("%01!21"))])
    with pytest.raises(DeviceError) as info:
        PanasonicHLG1(link).zero_set()
    link.assert_done()
    assert info.value.code == "21" and "setting mode" in info.value.text and info.value.command == "WZS"


def test_driver_checksum_error_then_recovers() -> None:
    link = ExpectedProtocol([(framed("%01#RMD"), b"%01$RMD-012345642\r"),
                             (framed("%01#RMD"), b"%01$RMD-012345641\r")])
    dev = PanasonicHLG1(link)
    with pytest.raises(ChecksumError):
        dev.read_value()
    assert dev.read_value().value_mm == -12.3456
    link.assert_done()


def test_driver_timeout_is_typed() -> None:
    link = ExpectedProtocol([(framed("%01#RMB"), None)])
    with pytest.raises(TransportTimeout):
        PanasonicHLG1(link).read_once()
    link.assert_done()


def test_driver_refuses_bad_configuration() -> None:
    for station in (0, 17):
        with pytest.raises(ValueError):
            PanasonicHLG1(ExpectedProtocol([]), station=station)
    dev = PanasonicHLG1(ExpectedProtocol([]), station=12)
    assert dev.identify() == {"model": "Panasonic HL-G1 (RS-485)", "station": "12"}
    with pytest.raises(ValueError):
        dev.judgement_output(4)
    with pytest.raises(ValueError):
        dev.set_threshold_a(1000.0)


def test_registered_as_a_sensor_protocol() -> None:
    from acquisition.rig import SENSOR_DRIVERS

    assert SENSOR_DRIVERS["panasonic-hlg1"] is PanasonicHLG1
