"""Horizontal bars in a terminal cell grid: a value per row as a bar of eighth blocks, scaled per group,
with a reference mark (the diagnosis' noise) on every row of the group, so a gap is seen shrinking to it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rich.text import Text
from textual.widget import Widget

_EIGHTHS = " ▏▎▍▌▋▊▉█"
VALUE_WIDTH = 8


@dataclass
class Bar:
    label: str
    value: float
    style: str = "cyan"


@dataclass
class BarGroup:
    """Bars drawn to one scale (the largest value of the group); ``reference`` is marked on every row."""

    title: str
    bars: list[Bar] = field(default_factory=list)
    reference: float | None = None
    reference_label: str = ""


def bar_cells(value: float, scale: float, width: int) -> str:
    """``value`` of ``scale`` as a bar of ``width`` cells at most, in eighths of a cell."""
    if not (math.isfinite(value) and scale > 0) or value <= 0:
        return ""
    eighths = round(min(value / scale, 1.0) * width * 8)
    return "█" * (eighths // 8) + (_EIGHTHS[eighths % 8] if eighths % 8 else "")


class Bars(Widget):
    """Draws a list of :class:`BarGroup` (``show(groups)``); height: one row per bar and title."""

    DEFAULT_CSS = """
    Bars { height: auto; }
    """

    def __init__(self, *, id: str | None = None, classes: str | None = None) -> None:  # noqa: A002
        super().__init__(id=id, classes=classes)
        self.groups: list[BarGroup] = []

    def show(self, groups: list[BarGroup]) -> None:
        self.groups = groups
        self.refresh(layout=True)

    def get_content_height(self, container: object, viewport: object, width: int) -> int:
        return sum(1 + len(g.bars) for g in self.groups)

    def render(self) -> Text:
        out = Text(no_wrap=True, overflow="crop")
        rows = [b.label for g in self.groups for b in g.bars]
        label_w = min(24, max((len(r) for r in rows), default=0)) + 1
        width = max(4, self.size.width - label_w - VALUE_WIDTH - 1)
        for gi, g in enumerate(self.groups):
            values = [b.value for b in g.bars] + ([g.reference] if g.reference is not None else [])
            scale = max((v for v in values if math.isfinite(v)), default=0.0)  # the mark inside the bars
            ref = None
            if g.reference is not None and scale > 0 and math.isfinite(g.reference):
                ref = min(width - 1, round(g.reference / scale * width))
            if gi:
                out.append("\n")
            out.append(g.title, style="bold")
            if g.reference_label:
                out.append(f"  ┆ {g.reference_label}", style="dim")
            for b in g.bars:
                cells = bar_cells(b.value, scale, width).ljust(width)
                out.append("\n" + f"{b.label[:label_w - 1]:<{label_w}}")
                for i, ch in enumerate(cells):
                    if i == ref:  # the reference, inside the bar too
                        out.append("┆", style="dim" if ch == " " else f"bold on {b.style}")
                    else:
                        out.append(ch, style=b.style)
                out.append(f" {b.value:>{VALUE_WIDTH - 1}.3f}" if math.isfinite(b.value) else " n/a")
        return out
