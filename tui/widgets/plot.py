"""A small braille-dot plot: points and straight lines in a terminal cell grid.

Each cell holds 2 x 4 dots (Unicode braille), so an 80-column plot has 140+
horizontal dots.  The y range covers every series and line; a left margin
carries the y extremes, the bottom row the x extremes and the x label, and with
``PlotData.legend`` a last row names every labelled series in its colour.
Axis values are plain decimals in the data's unit (``1900``, ``-2.41``), never
``+1.9e+03``: a technician reads millimetres and micrometres, not exponents.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from rich.text import Text
from textual.widget import Widget

# dot bit of braille cell (column 0..1, row 0..3)
_DOTS = ((0x01, 0x02, 0x04, 0x40), (0x08, 0x10, 0x20, 0x80))
MARGIN = 9


@dataclass
class Series:
    points: list[tuple[float, float]]
    style: str
    label: str = ""
    join: bool = False  # connect consecutive points


@dataclass
class PlotData:
    series: list[Series] = field(default_factory=list)
    x_label: str = ""
    y_label: str = ""
    legend: bool = False  # a last row naming each labelled series in its colour
    x_format: Callable[[float], str] | None = None  # the x extremes as text (dates), else plain decimals

    def bounds(self) -> tuple[float, float, float, float] | None:
        pts = [p for s in self.series for p in s.points if math.isfinite(p[0]) and math.isfinite(p[1])]
        if not pts:
            return None
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
        if x1 == x0:
            x0, x1 = x0 - 1, x1 + 1
        if y1 == y0:
            y0, y1 = y0 - 1, y1 + 1
        pad = (y1 - y0) * 0.05
        return x0, x1, y0 - pad, y1 + pad


def axis_number(v: float, span: float, width: int = MARGIN - 1) -> str:
    """``v`` as a plain decimal with the digits the axis' ``span`` resolves (3 significant digits of the
    span, at most 4 decimals), in at most ``width`` characters; an exponent only when nothing else fits."""
    decimals = 0 if span <= 0 or not math.isfinite(span) else min(4, max(0, 2 - math.floor(math.log10(span))))
    text = f"{v:.{decimals}f}"
    if text.startswith("-") and float(text) == 0:  # -0.00
        text = text[1:]
    return text if len(text) <= width else f"{v:.2g}"


def legend_text(series: list[Series], width: int) -> Text:
    """The labelled series as ``━ label`` (a line) or ``• label`` (points), each in its colour, as many as
    fit in ``width`` characters (whole entries only)."""
    out = Text(no_wrap=True, overflow="crop")
    for s in series:
        if not s.label:
            continue
        entry = ("━ " if s.join else "• ") + s.label
        if len(out) + len(entry) + 2 > width:
            break
        if len(out):
            out.append("  ")
        out.append(entry[:2], style=s.style)
        out.append(entry[2:])
    return out


class Plot(Widget):
    """Draws :class:`PlotData` (set :attr:`data` and call ``refresh()``)."""

    DEFAULT_CSS = """
    Plot { height: 8; }
    """

    def __init__(self, *, id: str | None = None, classes: str | None = None) -> None:  # noqa: A002
        super().__init__(id=id, classes=classes)
        self.data = PlotData()
        self.empty_text = "no points yet"

    def show(self, data: PlotData) -> None:
        self.data = data
        self.refresh()

    def render(self) -> Text:
        legend = self.data.legend
        w, h = self.size.width - MARGIN, self.size.height - 1 - legend
        b = self.data.bounds()
        if w < 4 or h < 1 or b is None:
            return Text(self.empty_text, style="dim")
        x0, x1, y0, y1 = b
        cols, rows = w * 2, h * 4
        cells = [[0] * w for _ in range(h)]
        styles: list[list[str | None]] = [[None] * w for _ in range(h)]

        def dot(x: float, y: float, style: str) -> None:
            if not (math.isfinite(x) and math.isfinite(y)):
                return
            cx = round((x - x0) / (x1 - x0) * (cols - 1))
            cy = round((y1 - y) / (y1 - y0) * (rows - 1))
            if 0 <= cx < cols and 0 <= cy < rows:
                cells[cy // 4][cx // 2] |= _DOTS[cx % 2][cy % 4]
                styles[cy // 4][cx // 2] = style

        for s in self.data.series:
            pts = sorted(s.points) if s.join else s.points
            for (xa, ya), (xb, yb) in zip(pts, pts[1:], strict=False) if s.join else ():
                # a dot per column and per row the segment crosses: steep segments stay lines, not dots
                n = max(2, int(max(abs(xb - xa) / (x1 - x0) * cols, abs(yb - ya) / (y1 - y0) * rows)) + 1)
                for i in range(n + 1):
                    t = i / n
                    dot(xa + (xb - xa) * t, ya + (yb - ya) * t, s.style)
            for x, y in pts:
                dot(x, y, s.style)
        out = Text(no_wrap=True, overflow="crop")
        for r in range(h):
            label = (axis_number(y1, y1 - y0) if r == 0 else axis_number(y0, y1 - y0) if r == h - 1
                     else (self.data.y_label if r == 1 else ""))
            out.append(f"{label[:MARGIN - 1]:>{MARGIN - 1}}│", style="dim")
            for c in range(w):
                bits = cells[r][c]
                out.append(chr(0x2800 + bits) if bits else " ", style=styles[r][c] or "")
            out.append("\n")
        fmt = self.data.x_format or (lambda v: axis_number(v, x1 - x0, w))
        left, right = fmt(x0), fmt(x1)
        mid = self.data.x_label[: max(0, w - len(left) - len(right) - 2)]
        gap = max(1, w - len(left) - len(right) - len(mid))
        out.append(" " * MARGIN + left + " " * (gap // 2) + mid + " " * (gap - gap // 2) + right, style="dim")
        if legend:
            out.append("\n" + " " * MARGIN)
            out.append_text(legend_text(self.data.series, w))
        return out
