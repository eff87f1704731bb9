"""Fault plans for emulators: what goes wrong, on which device, at which request.

Spec syntax (CLI ``--faults`` and tests), comma-separated entries::

    DEVICE:KIND@N[xCOUNT][=ARG]

DEVICE is ``sensor``, ``controller`` or ``live`` (the live-compensation interface of a simulated
controller, mocks/live_controller.py); the fault starts at the N-th request
to that device (1-based) and lasts COUNT requests (default: every request
from then on).  When several entries cover the same request the first one in
the spec applies.  Kinds:

* sensor (applied by the sensor emulator):
  ``garbage`` (reply replaced by noise bytes), ``drop`` (no reply),
  ``delay`` (reply ARG seconds late, default 1), ``error`` (device error code
  ARG, default the protocol's "other error"), ``corrupt`` (the reply is
  damaged so that the protocol's integrity check fails: a checksummed
  protocol (BCC, CRC) sends a wrong checksum; a protocol without one, the
  Keyence ASCII protocol, gets bit 7 of one reply byte flipped).
* sensor, port level (applied by the endpoint in
  :mod:`mocks.serial_endpoints`, emulators ignore it): ``close`` - instead of
  answering request N the device drops the link, like an unplugged USB
  adapter.  Behind a pty the emulator closes its master side: the driver's
  next read sees a hang-up (end of file; pyserial raises "device reports
  readiness to read but returned no data") and writes fail with EIO.  The
  endpoint then opens a fresh pty pair (a new ``/dev/pts/N``; its stable
  symlink, when it has one, is re-pointed) - the adapter "re-enumerating".
  Behind TCP the connection is closed (the driver reads end of file) and the
  listener keeps accepting.  So a reconnect (re-open the port) works; each of
  the COUNT faulted requests closes the link again, after them the device
  answers normally.
* controller: ``freeze-seq`` (sequence counter stops), ``beam-loss``
  (the beam is interrupted for COUNT requests, default 1 - someone walking
  through it: error 1 is set at once and stays latched until *clear error*,
  a measurement running meanwhile fails), ``exception`` (Modbus exception
  code ARG, default 4 device failure), ``delay`` (reply ARG seconds late),
  ``slow`` (a measurement triggered while active takes ARG seconds, default
  2.5: a slow controller).
* live (applied by :class:`mocks.live_controller.LiveOffsetController`): ``close`` - instead of
  answering request N the controller closes the compensator's connection (a lost link: the
  compensator stops; docs/compensation.md, "Live compensation in simulation").

Contract for emulators: call :meth:`FaultPlan.next_request` exactly once per
request (command line / frame) and act on the sensor kinds above except
``close``; endpoints look the port-level kinds up with
:meth:`FaultPlan.fault_for` after the request has been counted.
See ``docs/faults.md``.
"""

from __future__ import annotations

import math
import re
import threading
from dataclasses import dataclass

from pymodbus.constants import ExcCodes

# Port-level kinds are carried out by the endpoint, not by the emulator.
PORT_KINDS = frozenset({"close"})
KINDS = {
    "sensor": {"garbage", "drop", "delay", "error", "corrupt", "close"},
    "controller": {"freeze-seq", "beam-loss", "exception", "delay", "drop", "corrupt", "close", "slow"},
    "live": {"close"},
}
# Kinds that are an event rather than a state: without xCOUNT they last this many requests.
DEFAULT_COUNT = {"beam-loss": 1}
# What ARG is, for the kinds that take one (the others take none).
SECONDS_ARG = frozenset({"delay", "slow"})
_SPEC = re.compile(r"^(?P<dev>[a-z]+):(?P<kind>[a-z-]+)@(?P<at>\d+)(?:x(?P<count>\d+))?(?:=(?P<arg>[^,]+))?$")


@dataclass(frozen=True)
class Fault:
    device: str
    kind: str
    at: int
    count: int | None = None
    arg: str | None = None

    def active(self, n: int) -> bool:
        return n >= self.at and (self.count is None or n < self.at + self.count)

    def spec(self) -> str:
        """The entry as written in a spec (``sensor:garbage@12x2``)."""
        return (f"{self.device}:{self.kind}@{self.at}" + (f"x{self.count}" if self.count is not None else "")
                + (f"={self.arg}" if self.arg is not None else ""))


class FaultSpecError(ValueError):
    """A fault spec that cannot be parsed."""


def _check_arg(part: str, kind: str, arg: str | None) -> None:
    """ARG as the emulators read it: seconds (``delay``, ``slow``), a Modbus exception code
    (``exception``), the device's error code (``error``), none for the other kinds.  Checked
    here, or a bad one only shows when the fault fires, as the emulator failing (a Modbus
    'server device failure')."""
    if arg is None:
        return
    if kind in SECONDS_ARG:
        try:
            seconds = float(arg)
        except ValueError:
            seconds = float("nan")
        if not (math.isfinite(seconds) and seconds >= 0):
            raise FaultSpecError(f"fault {part!r}: ARG must be a number of seconds >= 0, got {arg!r}")
    elif kind == "exception":
        codes = sorted(int(c) for c in ExcCodes)
        if not (arg.isdigit() and int(arg) in codes):
            raise FaultSpecError(f"fault {part!r}: ARG must be a Modbus exception code "
                                 f"({', '.join(map(str, codes))}), got {arg!r}")
    elif kind == "error":
        if not arg.isdigit():
            raise FaultSpecError(f"fault {part!r}: ARG must be the device's error code, a whole number, got {arg!r}")
    else:
        raise FaultSpecError(f"fault {part!r}: {kind} takes no ARG (=...)")


class FaultPlan:
    """Counts requests per device and says which fault (if any) applies to each."""

    def __init__(self, faults: tuple[Fault, ...] = ()) -> None:
        self.faults = faults
        self._counts: dict[str, int] = {}
        self._fired: set[int] = set()  # indices into faults of the entries that applied to a request
        self._lock = threading.Lock()

    @classmethod
    def parse(cls, spec: str | None) -> FaultPlan:
        faults = []
        for part in (spec or "").split(","):
            part = part.strip()
            if not part:
                continue
            m = _SPEC.match(part)
            if not m:
                raise FaultSpecError(f"bad fault spec {part!r}; expected DEVICE:KIND@N[xCOUNT][=ARG]")
            dev, kind = m["dev"], m["kind"]
            if dev not in KINDS:
                raise FaultSpecError(f"unknown device {dev!r} in fault {part!r}; use sensor, controller or live")
            if kind not in KINDS[dev]:
                raise FaultSpecError(f"unknown {dev} fault {kind!r}; use one of {', '.join(sorted(KINDS[dev]))}")
            at = int(m["at"])
            if at < 1:
                raise FaultSpecError(f"fault {part!r}: N counts requests from 1")
            count = int(m["count"]) if m["count"] else DEFAULT_COUNT.get(kind)
            if count == 0:
                raise FaultSpecError(f"fault {part!r}: xCOUNT must be at least 1 (a fault of 0 requests never fires)")
            _check_arg(part, kind, m["arg"])
            faults.append(Fault(dev, kind, at, count, m["arg"]))
        return cls(tuple(faults))

    def next_request(self, device: str) -> Fault | None:
        """Count one request to ``device``; return the fault that applies to it."""
        with self._lock:
            n = self._counts.get(device, 0) + 1
            self._counts[device] = n
        fault = self.fault_for(device, n)
        if fault is not None:
            with self._lock:
                self._fired.add(next(i for i, f in enumerate(self.faults) if f is fault))
        return fault

    def fault_for(self, device: str, n: int) -> Fault | None:
        """The fault that applies to the ``n``-th request to ``device`` (counts nothing)."""
        for f in self.faults:
            if f.device == device and f.active(n):
                return f
        return None

    def requests(self, device: str) -> int:
        return self._counts.get(device, 0)

    def unfired(self) -> tuple[Fault, ...]:
        """The entries that have not applied to any request yet."""
        with self._lock:
            return tuple(f for i, f in enumerate(self.faults) if i not in self._fired)
