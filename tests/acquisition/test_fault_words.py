"""A device fault in plain words (acquisition.fault_words.explain) from the drivers' own fault lines."""

from __future__ import annotations

import pytest

from acquisition.fault_words import explain, start_words
from drivers.errors import DeviceError, with_context

SENSOR = "displacement sensor (keyence-lkg on /tmp/guideway-sim-x/sensor)"
HINT = "; check the cable, baud rate and protocol setting"
CONTROLLER = "controller modbus-tcp://127.0.0.1:5020"
MODBUS_EXCEPTION = str(with_context(DeviceError(4, "Modbus exception 4: server device failure",
                                                command="read registers 0-23"), CONTROLLER))

CASES = [
    # (the driver's line as the engine gets it, the device, what happened)
    (f"{SENSOR}: no reply ending in b'\\r' from /dev/pts/7 within 0.5 s (got b''){HINT}",
     "The displacement sensor", "did not answer in time"),
    (f"{SENSOR}: read from /dev/pts/7 failed: [Errno 5] Input/output error{HINT}",
     "The displacement sensor", "lost its connection"),
    (f"{SENSOR}: device reported error 99 to 'M0': other error{HINT}",
     "The displacement sensor", "reports an error of its own"),
    (f"{CONTROLLER}: trigger: no response within 1.0 s (device id 1)", "The interferometer controller",
     "did not answer in time"),
    (f"{CONTROLLER}: read registers 0-23: connection lost: no Modbus answer from 127.0.0.1:5020 (it closed the "
     "connection or refused a new one)", "The interferometer controller", "lost its connection"),
    (MODBUS_EXCEPTION, "The interferometer controller", "refused a request"),
    (f"{CONTROLLER}: read registers 0-23: no valid Modbus reply in the bytes received (8f 00 11)",
     "The interferometer controller", "sent a reply that could not be read"),
    ("controller error 1 (beam interrupted) could not be cleared (beam OK is not set); check the beam: the optics "
     "alignment and that nothing crosses it", "The interferometer controller", "laser beam is interrupted"),
]


@pytest.mark.parametrize(("fault", "device", "what"), CASES)
def test_the_first_line_names_the_device_and_what_happened_without_technical_detail(fault: str, device: str,
                                                                                      what: str) -> None:
    words = explain(fault)
    assert words.what.startswith(device) and what in words.what, words
    for technical in ("b'", "Errno", "0x", "registers", "modbus", "Modbus", "/dev/", "127.0.0.1", "(", ":"):
        assert technical not in words.what, (technical, words.what)
    assert words.check.strip() and words.detail == fault  # what to check, and the whole line one key away


def test_a_failed_reconnection_says_so() -> None:
    words = explain("reconnection failed: cannot open serial port '/tmp/guideway-sim-x/sensor': [Errno 2] No such "
                    "file or directory; check the port name and that the sensor is connected")
    assert words.what == "The displacement sensor could not be reconnected."
    assert "cable" in words.check


def test_an_unknown_line_still_reads_as_a_sentence_with_the_line_as_detail() -> None:
    words = explain("something nobody foresaw")
    assert words.what == "A device stopped answering correctly." and words.detail == "something nobody foresaw"


def test_why_a_run_did_not_start_in_plain_words() -> None:
    # the lines of guideway acquire with no such port / no controller at the address (drivers/transport.py)
    port = "/dev/ttyUSB0"
    line = (f"cannot open serial port '{port}': [Errno 2] could not open port {port}: [Errno 2] No such file or "
            f"directory: '{port}'; check the port name and that the sensor is connected")
    words = start_words(line, {port: "sensor"})
    assert words.what == f"The sensor port {port} does not exist." and "Errno" not in words.check
    assert words.detail == line
    assert start_words(line).what == f"The serial port {port} does not exist."
    busy = line.replace("[Errno 2]", "[Errno 16]").replace("No such file or directory", "Device or resource busy")
    assert "in use by another program" in start_words(busy).what
    ctl = ("cannot connect to controller at modbus-tcp://127.0.0.1:1: no Modbus answer from 127.0.0.1:1 within "
           "1.0 s / connection refused; check the controller address and that it is switched on")
    words = start_words(ctl)
    assert words.what == "The interferometer controller at modbus-tcp://127.0.0.1:1 does not answer."
