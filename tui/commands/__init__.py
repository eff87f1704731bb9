"""One module per ``guideway`` sub-command.

Each module has ``register(subparsers)`` that adds its parser and sets
``func`` (a handler taking the parsed namespace and returning an exit code).
Handlers import what they need lazily, so ``guideway --help`` stays fast.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from importlib import import_module

# Order = order in ``guideway --help``.
COMMAND_MODULES = (
    "demo",
    "acquire",
    "gcode",
    "process",
    "import_data",
    "air_index",
    "export",
    "compensate",
    "volumetric",
    "sim",
    "devices",
    "report",
    "certificate",
    "simulate",
    "diagnose",
    "compare",
    "verify",
    "catalog",
    "trend",
    "fleet",
    "tui",
)


# Command names that differ from their module's name.
MODULE_OF = {"import": "import_data", "air-index": "air_index"}


def register_all(subparsers, only: str | None = None) -> None:  # noqa: ANN001 - argparse's private type
    """Register every sub-command, or only ``only`` when it names one (its options may import heavy
    modules for their choices, e.g. export's models: ``guideway tui`` then starts sooner)."""
    module = MODULE_OF.get(only or "", only)
    names = [module] if module in COMMAND_MODULES else COMMAND_MODULES
    for name in names:
        import_module(f"{__name__}.{name}").register(subparsers)


def seed(text: str) -> int:
    """``--seed``: a whole number >= 0 (the simulated world's random generators take no negative seed)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a seed is a whole number >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"a seed is a whole number >= 0, got {text!r}")
    return value


def sized(name: str, least: int) -> Callable[[str], int]:
    """An option's type: a whole number from ``least`` to the documented maximum of the size ``name``
    (acquisition/setup/maxima.py), checked before anything is allocated; ``1e12`` is read as the
    number it is, so the message says it is too large rather than not a number."""
    from acquisition.setup.maxima import MAXIMA, size_problem

    def parse(text: str) -> int:
        try:
            value = float(text) if not text.strip().lstrip("+-").isdigit() else int(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"a whole number is needed, got {text!r}")
        if value < least:
            raise argparse.ArgumentTypeError(f"at least {least}, got {text}")
        if (problem := size_problem(name, value)) is not None:
            raise argparse.ArgumentTypeError(problem)
        if value != int(value):
            raise argparse.ArgumentTypeError(f"a whole number is needed, got {text!r}")
        return int(value)

    parse.__name__ = name  # argparse names the type in its message
    assert name in MAXIMA
    return parse
