"""Set-up files of either kind: validate a TOML structure by its ``kind`` and write one back.

The TUI's set-up screen edits the same TOML structure the set-up loaders read
(``docs/setup-*.toml``) and checks it with them, so its messages are the
loader's; :func:`setup_toml_text` writes the structure as a set-up file.
"""

from __future__ import annotations

import math
from typing import Any

from saved_runs.errors import SetupError
from saved_runs.toml_file import toml_string

from .positioning import PositioningSetup, positioning_setup_from_dict
from .straightness import StraightnessSetup, straightness_setup_from_dict

KINDS = ("straightness", "positioning")


def setup_kind(data: dict[str, Any]) -> str:
    """The run kind a set-up structure describes (``kind``; default straightness, as the loader's)."""
    kind = data.get("kind", "straightness")
    if kind not in KINDS:
        raise SetupError(f"kind is {kind!r}; use one of {', '.join(KINDS)}")
    return str(kind)


def setup_from_dict(data: dict[str, Any], source: str = "setup") -> StraightnessSetup | PositioningSetup:
    """Validate ``data`` with the loader of its kind (the checks of ``guideway acquire``)."""
    if setup_kind(data) == "straightness":
        return straightness_setup_from_dict(data, source)
    return positioning_setup_from_dict(data, source)


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SetupError(f"{where}: {v} cannot be written to a set-up file")
        return repr(v)
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    raise SetupError(f"{where}: a {type(v).__name__} cannot be written to a set-up file")


def setup_toml_text(data: dict[str, Any]) -> str:
    """A set-up structure (keys, then one ``[table]`` per sub-table) as TOML text that
    :func:`saved_runs.toml_file.read_toml` reads back to the same structure."""
    top = [f"{k} = {_value(v, k)}" for k, v in data.items() if not isinstance(v, dict)]
    lines = ["# guideway set-up (written by guideway tui; keys as in docs/setup-*.toml)", *top]
    for name, table in data.items():
        if not isinstance(table, dict):
            continue
        lines += ["", f"[{name}]"]
        for k, v in table.items():
            if isinstance(v, dict):
                raise SetupError(f"[{name}] {k}: nested tables are not part of a set-up file")
            lines.append(f"{k} = {_value(v, f'[{name}] {k}')}")
    return "\n".join(lines) + "\n"
