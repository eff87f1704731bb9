"""The ``guideway`` command line.

Every expected failure (bad input, bad file, unreachable or misbehaving
device) ends with a one-line ``guideway: error: ...`` on stderr and exit code 2;
never a traceback.  Sub-commands live in :mod:`tui.commands`.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from saved_runs.errors import EXPECTED_ERRORS, os_error_line

from .commands import register_all

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse would print its usage block too)
        print(f"guideway: error: {message}; see '{self.prog} --help'", file=sys.stderr)
        raise SystemExit(EXIT_USAGE)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a sub-command first, only that one is registered (faster start)."""
    p = _Parser(prog="guideway", description="Guideway straightness and machine-axis calibration.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    first = next(iter(argv), None) if argv else None
    register_all(sub, only=first if first and not first.startswith("-") else None)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(argv).parse_args(argv)
    try:
        return int(args.func(args))
    except EXPECTED_ERRORS as exc:
        print(f"guideway: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("guideway: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except OSError as exc:  # a file or folder that cannot be written or read (e.g. RUN/results on a full disk)
        print(f"guideway: error: {os_error_line(exc)}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
