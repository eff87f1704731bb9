"""A tiny builder for a printable, self-contained HTML page.

Plots are embedded as base64 PNG data URIs, so the file can be mailed,
archived and printed without its directory.  All text is escaped.
"""

from __future__ import annotations

import base64
import html
import io
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import FileWriteError, UserError, what_to_do
from ..store.files import write_text_atomic

CSS = """
body { font-family: "DejaVu Sans", Arial, "Noto Sans CJK SC", "Microsoft YaHei", "PingFang SC", "WenQuanYi Zen Hei",
       sans-serif; margin: 2em auto; max-width: 60em; color: #111; }
h1 { font-size: 1.5em; border-bottom: 2px solid #333; padding-bottom: .2em; }
h2 { font-size: 1.2em; margin-top: 1.6em; border-bottom: 1px solid #999; }
table { border-collapse: collapse; margin: .6em 0; font-size: .9em; }
th, td { border: 1px solid #bbb; padding: .2em .6em; text-align: right; }
th { background: #eee; }
td.text, th.text { text-align: left; }
table.kv td:first-child { white-space: nowrap; }
figure { margin: 1em 0; page-break-inside: avoid; }
figcaption { font-size: .85em; color: #444; }
img { max-width: 100%; }
.note { font-size: .85em; color: #444; }
.alert { border: 3px solid #b00; background: #fee; color: #600; font-weight: bold; padding: .5em .8em; }
.banner { border: 4px solid #a60; background: #fff4d6; color: #630; font-size: 1.4em; font-weight: bold;
          text-align: center; padding: .4em .8em; letter-spacing: .05em; }
.headline { font-size: 1.25em; font-weight: bold; margin: .4em 0; }
.verdict-pass { color: #060; } .verdict-fail { color: #b00; } .verdict-open { color: #a60; }
h3 { font-size: 1em; margin-top: 1.2em; }
.footer { margin-top: 2em; border-top: 1px solid #999; }
@media print {
  body { margin: 0; max-width: none; font-size: 10pt; }
  h2, h3 { page-break-after: avoid; }
  tr { page-break-inside: avoid; }
  thead { display: table-header-group; }  /* header row repeated on every printed page */
  .alert, .banner { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
}
"""


def esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


def fmt(value: Any, digits: int = 3) -> str:
    """Numbers with ``digits`` decimals; None/NaN as an em dash; other values as text."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return "—"
        text = f"{value:.{digits}f}"
        return text[1:] if text.startswith("-") and float(text) == 0 else text  # no "-0.000"
    return str(value)


def figure_png(fig: Any, dpi: int = 110) -> bytes:
    """PNG bytes of a matplotlib figure (the figure is closed)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()


class HtmlPage:
    """Accumulates sections; :meth:`render` returns the whole document."""

    def __init__(self, title: str) -> None:
        self.title = title
        self._parts: list[str] = []

    def heading(self, text: str, level: int = 2) -> None:
        self._parts.append(f"<h{level}>{esc(text)}</h{level}>")

    def paragraph(self, text: str, cls: str = "") -> None:
        attr = f' class="{esc(cls)}"' if cls else ""
        self._parts.append(f"<p{attr}>{esc(text)}</p>")

    def table(self, header: Sequence[str], rows: Iterable[Sequence[Any]], *, digits: int = 3,
              text_columns: Sequence[int] = (0,), cls: str = "") -> None:
        def cell(tag: str, i: int, v: Any) -> str:
            attr = ' class="text"' if i in text_columns else ""
            return f"<{tag}{attr}>{esc(fmt(v, digits))}</{tag}>"

        out = [f'<table class="{esc(cls)}">' if cls else "<table>",
               "<thead><tr>" + "".join(cell("th", i, h) for i, h in enumerate(header)) + "</tr></thead>"]
        out += ["<tr>" + "".join(cell("td", i, v) for i, v in enumerate(row)) + "</tr>" for row in rows]
        out.append("</table>")
        self._parts.append("\n".join(out))

    def key_values(self, items: Iterable[tuple[str, Any]], *, digits: int = 3) -> None:
        self.table(("item", "value"), items, digits=digits, text_columns=(0, 1), cls="kv")

    def preformatted(self, text: str) -> None:
        """Text shown as written (a file's contents)."""
        self._parts.append(f"<pre>{esc(text)}</pre>")

    def alert(self, text: str) -> None:
        """A boxed warning the reader cannot miss (also when printed)."""
        self._parts.append(f'<p class="alert">{esc(text)}</p>')

    def banner(self, text: str) -> None:
        """A large notice at the top of the page (a simulated run)."""
        self._parts.append(f'<p class="banner">{esc(text)}</p>')

    def image(self, png: bytes, caption: str) -> None:
        data = base64.b64encode(png).decode("ascii")
        self._parts.append(
            f'<figure><img alt="{esc(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>"
        )

    def render(self) -> str:
        body = "\n".join(self._parts)
        return (
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{esc(self.title)}</title><style>{CSS}</style></head>\n"
            f"<body><h1>{esc(self.title)}</h1>\n{body}\n</body></html>\n"
        )


def write_page(path: Path | str, text: str, *, option: str, example: str) -> Path:
    """Write a rendered report ``text`` to ``path`` atomically (its folder created); return the path.

    ``option`` (``--out``, ``--report``) and ``example`` (a file name) word the one-line refusal of a
    directory; a file that cannot be written is one line naming it."""
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        raise UserError(f"{option} {path} is a directory; give a file name, e.g. {path / example}")
    try:
        # inside a run (RUN/results/report.html) no link is followed, in the file's place or its folder's
        write_text_atomic(path, text, make_parents=True)
    except FileWriteError as exc:
        raise UserError(f"cannot write the report to {path}: {exc.reason}{what_to_do(exc.errno)}") from None
    return path
