"""One module per ``guideway`` sub-command.

Each module has ``register(subparsers)`` that adds its parser and sets
``func`` (a handler taking the parsed namespace and returning an exit code).
Handlers import what they need lazily, so ``guideway --help`` stays fast.
"""

from __future__ import annotations

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
    "sim",
    "devices",
    "report",
    "tui",
)


def register_all(subparsers) -> None:  # noqa: ANN001 - argparse's private type
    for name in COMMAND_MODULES:
        import_module(f"{__name__}.{name}").register(subparsers)
