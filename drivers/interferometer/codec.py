"""Pure conversions between Modbus registers and typed values (no I/O).

Word order: ``ABCD`` = most significant 16-bit word first (Modbus convention,
pymodbus ``word_order="big"``); ``CDAB`` = least significant word first
(pymodbus ``"little"``; for a FLOAT64 the four words are reversed).  Bytes
inside a register are always big-endian.
"""

from __future__ import annotations

from collections.abc import Sequence

from pymodbus.client import ModbusTcpClient

from ..errors import ProtocolError
from ..readings import ControllerStatus
from .register_map import REGISTER_WIDTH, RegisterMap

WORD_ORDERS = {"ABCD": "big", "CDAB": "little"}
_DT = ModbusTcpClient.DATATYPE
_TYPES = {"UINT16": _DT.UINT16, "INT16": _DT.INT16, "UINT32": _DT.UINT32,
          "FLOAT32": _DT.FLOAT32, "FLOAT64": _DT.FLOAT64}
_INT_RANGES = {"UINT16": (0, 0xFFFF), "INT16": (-0x8000, 0x7FFF), "UINT32": (0, 0xFFFFFFFF)}


def check_word_order(word_order: str) -> str:
    if word_order not in WORD_ORDERS:
        raise ValueError(f"word order must be one of {sorted(WORD_ORDERS)}, not {word_order!r}")
    return word_order


def decode_value(registers: Sequence[int], type_name: str, word_order: str = "ABCD") -> float:
    """Decode one value of ``type_name`` from its registers.

    Raises :class:`ProtocolError` when a register is not a 16-bit value (0 … 65535) or the
    count does not fit the type (a device or link fault, not a bug of the caller).
    """
    order = WORD_ORDERS[check_word_order(word_order)]
    regs = list(registers)
    bad = [r for r in regs if not (isinstance(r, int) and 0 <= r <= 0xFFFF)]
    if bad:
        raise ProtocolError(f"{type_name} value from registers that are not 16-bit registers: {bad[:4]}")
    if len(regs) != REGISTER_WIDTH[type_name]:
        raise ProtocolError(f"{type_name} value needs {REGISTER_WIDTH[type_name]} register(s), got {len(regs)}")
    value = ModbusTcpClient.convert_from_registers(regs, _TYPES[type_name], word_order=order)
    return float(value)  # type: ignore[arg-type]


def encode_value(value: float, type_name: str, word_order: str = "ABCD") -> list[int]:
    """Encode one value of ``type_name`` into registers."""
    order = WORD_ORDERS[check_word_order(word_order)]
    dtype = _TYPES[type_name]
    v: float | int = int(value) if type_name in _INT_RANGES else float(value)
    if type_name in _INT_RANGES and not _INT_RANGES[type_name][0] <= v <= _INT_RANGES[type_name][1]:
        lo, hi = _INT_RANGES[type_name]
        raise ValueError(f"{value!r} does not fit a {type_name} register value ({lo} … {hi})")
    return ModbusTcpClient.convert_to_registers(v, dtype, word_order=order)


def decode_block(
    registers: Sequence[int], start: int, names: Sequence[str], regmap: RegisterMap, word_order: str
) -> dict[str, float]:
    """Decode the named values from a block of registers read from ``start``.

    A register pattern that is not a finite number (NaN, infinity) is returned
    as such; :attr:`~drivers.readings.InterferometerReading.ok` flags it.
    """
    bad = [r for r in registers if not (isinstance(r, int) and 0 <= r <= 0xFFFF)]
    if bad:
        raise ProtocolError(f"register block from {start} holds values that are not 16-bit registers: {bad[:4]}")
    out: dict[str, float] = {}
    for name in names:
        reg = regmap[name]
        lo = reg.address - start
        hi = lo + reg.count
        if lo < 0 or hi > len(registers):
            raise ProtocolError(f"register block from {start} ({len(registers)} regs) misses {name}")
        out[name] = decode_value(registers[lo:hi], reg.type, word_order)
    return out


def decode_status(status_word: int, sequence: int, error_code: int, regmap: RegisterMap) -> ControllerStatus:
    """Decode the status word into named flags and the error code into text."""
    bits = regmap.status_bits

    def flag(name: str) -> bool:
        return bool(status_word >> bits[name] & 1)

    return ControllerStatus(
        ready=flag("ready"),
        busy=flag("busy"),
        data_valid=flag("data_valid"),
        error=flag("error"),
        beam_ok=flag("beam_ok"),
        sequence=sequence,
        error_code=error_code,
        error_text=regmap.error_text(error_code) if error_code else "",
        raw_status=status_word,
    )
