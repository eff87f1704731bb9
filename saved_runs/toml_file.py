"""TOML files with one-line errors: set-up, scenario, model and machine files.

:class:`TomlTable` gives typed, named access to one table and refuses unknown keys; every problem
is a one-line :class:`~saved_runs.errors.SetupError` naming the file, the table and the key.
:func:`toml_string` writes a string back as TOML.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from .errors import SetupError


class TomlTable:
    """One TOML table with typed, named access and a check for unknown keys."""

    def __init__(self, source: str, name: str, data: Any, examples: str = "docs/setup-*.toml") -> None:
        if not isinstance(data, dict):
            raise SetupError(f"{source}: [{name}] must be a table")
        self.source, self.name, self.data = source, name, data
        self.examples = examples  # the commented example files the messages point to
        self.used: set[str] = set()

    def _where(self, key: str) -> str:
        return f"{self.source}: [{self.name}] {key}" if self.name else f"{self.source}: {key}"

    def get(self, key: str, kind: type | tuple[type, ...], default: Any = ..., *, required: bool = False) -> Any:
        self.used.add(key)
        if key not in self.data:
            if required or default is ...:
                raise SetupError(f"{self._where(key)} is missing; add it (see the examples {self.examples})")
            return default
        v = self.data[key]
        if kind is float and isinstance(v, int) and not isinstance(v, bool):
            v = float(v)
        if isinstance(v, bool) and kind is not bool:
            raise SetupError(f"{self._where(key)} must be a {_type_name(kind)}, got {v!r}")
        if not isinstance(v, kind):
            raise SetupError(f"{self._where(key)} must be a {_type_name(kind)}, got {v!r}")
        return v

    def vector(self, key: str, n: int, default: Any = ...) -> tuple[float, ...]:
        v = self.get(key, list, default)
        if not (isinstance(v, list | tuple) and len(v) == n and all(_is_number(x) for x in v)):
            raise SetupError(f"{self._where(key)} must be a list of {n} numbers, got {v!r}")
        return tuple(float(x) for x in v)

    def table(self, key: str) -> TomlTable:
        self.used.add(key)
        return TomlTable(self.source, key, self.data.get(key, {}), self.examples)

    def check_unknown(self) -> None:
        extra = sorted(set(self.data) - self.used)
        if extra:
            where = f"[{self.name}]" if self.name else "top level"
            raise SetupError(f"{self.source}: unknown key {extra[0]!r} in {where}; check the spelling "
                             f"(see the commented examples {self.examples})")


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _type_name(kind: type | tuple[type, ...]) -> str:
    names = {bool: "true/false", int: "whole number", float: "number", str: "string", list: "list", dict: "table"}
    if isinstance(kind, tuple):
        return " or ".join(names.get(k, k.__name__) for k in kind)
    return names.get(kind, kind.__name__)


def read_toml(path: Path | str) -> dict[str, Any]:
    """Parse a TOML file (set-up, scenario, model or machine file); one-line errors for a missing or
    malformed file."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SetupError(f"{path}: no such setup file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SetupError(f"{path}: cannot read the setup file ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SetupError(f"{path}: not valid TOML ({exc})") from None


Built = TypeVar("Built")


def naming_source(build: Callable[[dict[str, Any], str], Built], data: dict[str, Any], source: str) -> Built:
    """``build(data, source)``; a refusal that does not start with ``source`` (the set-up file) gets it, so
    every message names the file to fix, whichever check (a dataclass's own, the target rules) refused."""
    try:
        return build(data, source)
    except SetupError as exc:
        text = str(exc)
        if text.startswith(f"{source}: "):
            raise
        raise SetupError(f"{source}: {text}") from None


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string: JSON's escapes are TOML's (control characters as \\uXXXX,
    which TOML requires of every one but tab), and DEL, which JSON leaves as it is."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")
