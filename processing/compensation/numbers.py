"""Fixed-point number formatting shared by the table writers."""

from __future__ import annotations


def fixed(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals, never ``-0.000``."""
    v = round(float(value), decimals) + 0.0  # + 0.0 turns -0.0 into 0.0
    return f"{v:.{decimals}f}"
