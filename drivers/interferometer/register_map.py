"""Load the controller's register map from ``register_map.toml``."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import cache
from importlib import resources

REGISTER_WIDTH = {"UINT16": 1, "INT16": 1, "UINT32": 2, "FLOAT32": 2, "FLOAT64": 4}


@dataclass(frozen=True, slots=True)
class Register:
    """One entry of the map: ``count`` 16-bit registers starting at ``address``."""

    name: str
    address: int
    type: str
    access: str
    unit: str
    meaning: str

    @property
    def count(self) -> int:
        if self.type.startswith("RESERVED"):
            return int(self.type.removeprefix("RESERVED"))
        return REGISTER_WIDTH[self.type]


@dataclass(frozen=True, slots=True)
class RegisterMap:
    """The whole map: registers by name, command codes, status bits, error texts."""

    version: int
    registers: tuple[Register, ...]
    commands: dict[str, int]
    status_bits: dict[str, int]
    error_codes: dict[int, str]

    def __getitem__(self, name: str) -> Register:
        for reg in self.registers:
            if reg.name == name:
                return reg
        raise KeyError(name)

    def span(self, first: str, last: str) -> tuple[int, int]:
        """(address, count) of a contiguous read from ``first`` through ``last``."""
        a, b = self[first], self[last]
        return a.address, b.address + b.count - a.address

    def error_text(self, code: int) -> str:
        return self.error_codes.get(code, f"unknown error code {code}")


def parse_register_map(text: str) -> RegisterMap:
    """Parse and validate a register map in the TOML layout of ``register_map.toml``."""
    data = tomllib.loads(text)
    regs = tuple(
        Register(
            name=r["name"], address=int(r["address"]), type=r["type"], access=r["access"],
            unit=r.get("unit", ""), meaning=r.get("meaning", ""),
        )
        for r in data["register"]
    )
    used: dict[int, str] = {}
    for reg in regs:
        if reg.type not in REGISTER_WIDTH and not reg.type.startswith("RESERVED"):
            raise ValueError(f"register {reg.name}: unknown type {reg.type}")
        for addr in range(reg.address, reg.address + reg.count):
            if addr in used:
                raise ValueError(f"register {reg.name} overlaps {used[addr]} at {addr}")
            used[addr] = reg.name
    return RegisterMap(
        version=int(data["version"]),
        registers=regs,
        commands={k: int(v) for k, v in data["commands"].items()},
        status_bits={k: int(v) for k, v in data["status_bits"].items()},
        error_codes={int(k): str(v) for k, v in data["error_codes"].items()},
    )


@cache
def load_register_map() -> RegisterMap:
    """The packaged map (version 1)."""
    text = resources.files(__package__).joinpath("register_map.toml").read_text("utf-8")
    return parse_register_map(text)
