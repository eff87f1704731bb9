"""One module per ``guideway`` sub-command.

Each module has ``register(subparsers)`` that adds its parser and sets
``func`` (a handler taking the parsed namespace and returning an exit code).
Handlers import what they need lazily, so ``guideway --help`` stays fast.
"""

from __future__ import annotations

import argparse
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
    "volumetric",
    "sim",
    "devices",
    "report",
    "simulate",
    "diagnose",
    "compare",
    "catalog",
    "trend",
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
