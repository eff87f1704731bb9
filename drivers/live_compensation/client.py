"""The compensator's side of the live-compensation interface: a Modbus client that reads the
controller's state and writes the offset (docs/compensation.md, "Live compensation interface").
Every failure is a typed error of :mod:`drivers.errors` (through :class:`~drivers.modbus_link.ModbusLink`)."""

from __future__ import annotations

from ..errors import ProtocolError
from ..modbus_link import ModbusLink
from .codec import READ_COUNT, REG_ENABLE, WRITE_START, ControllerState, decode_state, encode_cycle


class LiveCompensationClient:
    """One live-compensation controller at ``url`` (``modbus-tcp://HOST[:PORT][?device_id=N]``)."""

    def __init__(self, url: str, *, rotary: bool, word_order: str = "ABCD", timeout_s: float = 0.5) -> None:
        self.link = ModbusLink(url, timeout_s=timeout_s, name="live-compensation controller")
        self.rotary = rotary
        self.word_order = word_order

    @property
    def url(self) -> str:
        return self.link.url

    def connect(self) -> None:
        self.link.connect()

    def close(self) -> None:
        self.link.close()

    def read_state(self) -> ControllerState:
        """Registers 0-16 in one request."""
        regs = self.link.read_holding(0, READ_COUNT)
        try:
            return decode_state(regs, self.word_order)
        except ValueError as exc:
            raise ProtocolError(f"{self.link.name} {self.link.url}: {exc}") from None

    def write_cycle(self, heartbeat: int, echo: int, offset: float) -> None:
        """Registers 9-13 in one request (function 16): heartbeat, sample echo, offset (um or arcsec)."""
        values = encode_cycle(heartbeat, echo, offset, self.rotary, self.word_order)
        what = f"write the offset {offset:+.3f} to registers {WRITE_START}-{WRITE_START + len(values) - 1}"
        self.link.call(what, self.link.client.write_registers, WRITE_START, values)

    def set_enable(self, on: bool) -> None:
        """Register 8: 1 apply the offset, 0 off."""
        self.link.write_register(REG_ENABLE, 1 if on else 0, what=f"write enable {int(on)} to register {REG_ENABLE}")
