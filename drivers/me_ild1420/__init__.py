"""Micro-Epsilon optoNCDT 1420 laser displacement sensor (RS-422: ASCII commands, binary values)."""

from .driver import ILD1420, StreamBlock

__all__ = ["ILD1420", "StreamBlock"]
