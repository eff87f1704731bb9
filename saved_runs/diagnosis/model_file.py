"""Model files (TOML): the effect vocabulary of :mod:`processing.effects` as the model a run is
diagnosed against (docs/diagnosis.md).

A model file holds ``kind`` (``positioning`` or ``straightness``) and ``[[effect]]`` tables; a
scenario file (acquisition/simulated/scenario.py) reads its ``[[effect]]`` tables with the same
:func:`effects_from_tables`.  :func:`model_toml` writes a model file back.  Every problem is a
one-line :class:`~saved_runs.errors.SetupError` naming the file and the key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from processing.effects import KINDS, Effect, make_effect

from ..errors import SetupError
from ..toml_file import read_toml, toml_string


@dataclass(frozen=True)
class EffectModel:
    """A model file: the run kind and its effects."""

    kind: str
    effects: tuple[Effect, ...]
    source: str = ""


def effects_from_tables(data: Mapping[str, Any], kind: str, source: str, *, simulation: bool) -> tuple[Effect, ...]:
    tables = data.get("effect", [])
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise SetupError(f"{source}: effects are [[effect]] tables")
    out = []
    for i, t in enumerate(tables, start=1):
        try:
            e = make_effect(kind, t)
        except ValueError as exc:
            raise SetupError(f"{source}: [[effect]] {i}: {exc}") from None
        if simulation and e.free:
            raise SetupError(f"{source}: [[effect]] {i} ({e.type}): a scenario states every value; "
                             "free is for model files")
        if simulation and e.type == "periodic" and e.params.get("wavelength_mm") is None:
            raise SetupError(f"{source}: [[effect]] {i} (periodic): wavelength_mm is missing")
        out.append(e)
    return tuple(out)


def file_kind(data: Mapping[str, Any], source: str) -> str:
    kind = data.get("kind")
    if kind not in KINDS:
        raise SetupError(f"{source}: kind must be \"positioning\" or \"straightness\", got {kind!r}")
    return str(kind)


def model_from_dict(data: Mapping[str, Any], source: str = "model") -> EffectModel:
    """A model from its TOML structure (``kind`` and ``[[effect]]`` tables only)."""
    kind = file_kind(data, source)
    extra = sorted(set(data) - {"kind", "effect"})
    if extra:
        raise SetupError(f"{source}: unknown key {extra[0]!r} in a model file (it holds kind and [[effect]] "
                         "tables; scenario tables belong in a scenario file)")
    return EffectModel(kind, effects_from_tables(data, kind, source, simulation=False), source)


def load_model(path: Path | str) -> EffectModel:
    return model_from_dict(read_toml(path), str(path))


def empty_model(kind: str) -> EffectModel:
    return EffectModel(kind, (), "(no model: nothing known)")


# -- writing a model file -----------------------------------------------------------------------------------
def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        if math.isfinite(v):
            return repr(float(v))
        # TOML's own literals: +inf and -inf are not nan (a fitted value that ran away keeps its sign)
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return toml_string(str(v))


def commented_effect(effect: Effect) -> list[str]:
    """The ``[[effect]]`` table of ``effect`` as lines to be written as comments (uncommented, it reads back)."""
    return ["[[effect]]", *(f"{key} = {_toml_value(value)}" for key, value in effect.to_dict().items())]


def model_toml(kind: str, effects: list[tuple[Effect | None, str]], header: list[str]) -> str:
    """A model file holding ``effects`` (each with a comment line; None: the comment alone), readable by
    :func:`load_model`."""
    lines = [f"# {h}" for h in header] + [f"kind = {_toml_value(kind)}", ""]
    for effect, comment in effects:
        if comment:
            lines += [f"# {c}" for c in comment.splitlines()]
        if effect is None:
            lines.append("")
            continue
        lines.append("[[effect]]")
        for key, value in effect.to_dict().items():
            lines.append(f"{key} = {_toml_value(value)}")
        lines.append("")
    return "\n".join(lines)
