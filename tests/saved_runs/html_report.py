"""Reading a generated HTML report back in tests: tables as lists of cell texts,
images, and the self-containment check."""

from __future__ import annotations

import base64
import re
from html.parser import HTMLParser

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class _Tables(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.imgs: list[dict[str, str | None]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.imgs.append(dict(attrs))

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def parse(doc: str) -> _Tables:
    p = _Tables()
    p.feed(doc)
    return p


def table_with_header(doc: str, first_header: str, contains: str | None = None) -> list[list[str]]:
    """Rows (header first) of the first table whose first header cell is ``first_header``
    (and, if given, which has a header cell ``contains``)."""
    for t in parse(doc).tables:
        if t and t[0] and t[0][0] == first_header and (contains is None or contains in t[0]):
            return t
    raise AssertionError(f"no table headed {first_header!r} / {contains!r}")


def rows_by_first_cell(table: list[list[str]]) -> dict[str, dict[str, str]]:
    header = table[0]
    return {row[0]: dict(zip(header, row, strict=True)) for row in table[1:]}


def number(cell: str) -> float:
    return float(cell.replace("−", "-"))


def assert_self_contained(doc: str) -> int:
    """No reference to anything outside the file; every image a PNG data URI. Returns the image count."""
    assert "http://" not in doc and "https://" not in doc
    assert not re.search(r"<(link|script|iframe|object|embed)\b", doc)
    assert "url(" not in doc
    imgs = parse(doc).imgs
    for img in imgs:
        src = img.get("src") or ""
        assert src.startswith("data:image/png;base64,"), src[:40]
        assert base64.b64decode(src.split(",", 1)[1], validate=True).startswith(PNG_SIGNATURE)
    return len(imgs)
