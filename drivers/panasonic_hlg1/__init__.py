"""Panasonic HL-G1 laser displacement sensor (RS-422/RS-485, MEWTOCOL-style frames with BCC)."""

from .driver import PanasonicHLG1

__all__ = ["PanasonicHLG1"]
