"""Stand-alone environment transmitters (for rigs whose interferometer has no environment unit)."""

from .xymd02 import XYMD02

__all__ = ["XYMD02"]
