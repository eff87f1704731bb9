"""A device fault in plain words: what happened and what to check, for the technician.

The engine pauses a run on a device fault with the driver's one-line message
(``RunEngine._device_fault``: the ``fault`` of the question).  That line is for
the record (run.json ``faults``) and for whoever debugs the link: it carries
``b'\\r'``, errno tuples, register addresses and exception names.  :func:`explain`
turns it into two short sentences a technician can act on; the driver's line stays
available as the detail.  The wording follows the driver's error families
(drivers/errors.py: transport, protocol, device) as their messages name them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class FaultWords:
    """``what``: what happened (one sentence, no technical detail); ``check``: what to do about it;
    ``detail``: the driver's own line."""

    device: str
    what: str
    check: str
    detail: str


# (pattern on the driver's line, what happened (after the device's name), what to check);
# the first match wins, so the more specific come first
RULES: tuple[tuple[str, str, str], ...] = (
    (r"could not be cleared|beam ok=false|beam interrupt|check the beam",
     "reports that the laser beam is interrupted",
     "Clear the beam path (nobody in the beam, nothing on the guideway), check the laser head and the "
     "reflector are aligned, then retry."),
    (r"did not complete|measurement .*not finish|slow",
     "started a measurement that did not finish in time",
     "The controller answers but is slow or busy: check that nothing else uses it; a slow controller needs "
     "a longer [controller] trigger_timeout_s."),
    (r"cannot (connect|open)|connection (lost|refused|reset)|failed: |device reports readiness|"
     r"errno|broken pipe|end of file|\beio\b|hung up|closed",
     "lost its connection",
     "Check that its cable is plugged in at both ends, the USB adapter is connected and the device is "
     "powered; retry reconnects to the same port."),
    (r"no reply|no response|within [0-9.]+ ?s|timed? ?out|only [0-9]+ of [0-9]+ bytes",
     "did not answer in time",
     "Check that it is switched on and its cable is plugged in; check the baud rate and the protocol in the "
     "set-up."),
    (r"checksum|crc|bcc|corrupt",
     "sent a damaged reply (its checksum does not match)",
     "Electrical noise or a loose connector: check the cable and its shield, keep it away from motor cables."),
    (r"exception|illegal (data|function)|server device failure",
     "refused a request",
     "Check the controller's unit id (device_id) and that it is in remote mode, then retry."),
    (r"device reported error|error code|error [0-9]+",
     "reports an error of its own",
     "Look at the device's display or status light; the manual lists the code (technical details: d)."),
    (r"no valid|malformed|unexpected|not a valid|non-ascii|garbage|does not (end|answer)|stray|unknown|bad |lacks",
     "sent a reply that could not be read",
     "Check that the protocol and baud rate in the set-up match the device, and the cable."),
)

DEVICES: tuple[tuple[str, str], ...] = (
    (r"displacement sensor|keyence|panasonic|ild1420|hl-g1|lk-g|/sensor\b", "The displacement sensor"),
    (r"environment transmitter|xy-md02", "The environment transmitter"),
    (r"controller|interferometer|modbus|beam", "The interferometer controller"),
)


def explain(fault: str) -> FaultWords:
    """The plain-words reading of one driver fault line (see the module docstring)."""
    low = fault.lower()
    device = next((name for pattern, name in DEVICES if re.search(pattern, low)), "A device")
    what, check = next(((w, c) for pattern, w, c in RULES if re.search(pattern, low)),
                       ("stopped answering correctly", "Check the device, its cable and power, then retry."))
    if low.startswith("reconnection failed"):  # the engine's retry could not open the device again
        what = "could not be reconnected"
    return FaultWords(device, f"{device} {what}.", check, fault)


def start_words(error: str, ports: dict[str, str] | None = None) -> FaultWords:
    """Why a run could not start, in plain words: a serial port that does not exist or cannot be opened,
    a controller that does not answer (the driver's line, with its errno twice, stays the ``detail``);
    ``ports`` names the set-up's ports (``{"/dev/ttyUSB0": "sensor"}``: "The sensor port ...")."""
    if m := re.search(r"cannot open serial port '([^']+)': (.*)", error, re.S):
        port, why = m.group(1), m.group(2).lower()
        whose = (ports or {}).get(port, "serial")
        if "errno 2]" in why or "no such file" in why:
            what = f"The {whose} port {port} does not exist."
            check = ("Check the port name on the form and that the device's USB adapter is plugged in "
                     "(F5 tries again), or tick simulated devices.")
        elif "errno 13]" in why or "permission" in why:
            what = f"The {whose} port {port} may not be opened by this user."
            check = "Add the user to the dialout group and log in again (F5 tries again)."
        elif "errno 16]" in why or "busy" in why:
            what = f"The {whose} port {port} is in use by another program."
            check = "Close the other program that has it open (F5 tries again)."
        else:
            what = f"The {whose} port {port} could not be opened."
            check = "Check the port name on the form, the USB adapter and the device's power (F5 tries again)."
        return FaultWords("A serial device", what, check, error)
    if m := re.search(r"cannot connect to controller at (\S+?):? ", error):
        return FaultWords("The interferometer controller",
                          f"The interferometer controller at {m.group(1)} does not answer.",
                          "Check the controller URL on the form, that the controller is switched on and its "
                          "cable is plugged in (F5 tries again), or tick simulated devices.", error)
    words = explain(error)
    if words.device == "A device":  # not a device's fault (a set-up file, a run directory): its own words
        return FaultWords("", error[:1].upper() + error[1:].rstrip(".") + ".", "F5 tries again.", error)
    return FaultWords(words.device, words.what, words.check + " (F5 tries again)", error)
