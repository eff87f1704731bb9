"""Keyence LK-G3000 / LK-G5000 laser displacement sensor controllers (RS-232C ASCII)."""

from .driver import KeyenceLKG

__all__ = ["KeyenceLKG"]
