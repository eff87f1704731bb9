"""Typesetting the certificate with typst (https://typst.app, the ``typst`` wheel): a small builder that
writes typst code, every text from the run or the options as a typst string literal (no markup can be
injected: a machine named ``*bold* #x`` prints as written), and the compile step.

Reproducible: typst writes no clock and no random id when given a fixed ``timestamp`` (the issue date),
only the fonts named here are used (system fonts are ignored: another machine's fonts cannot change
the bytes), and the plots are PNGs rendered by matplotlib without a date.  PDF/A-2b.

Fonts: Libertinus Serif (embedded in typst) for Latin text and µ ± ° ↑ ↓; Noto Sans CJK TC (the
``cvttf-NotoSansCJK-Regular`` package) for CJK machine names (typst falls back glyph by glyph).
"""

from __future__ import annotations

import datetime
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

FONTS = ("Libertinus Serif", "Noto Sans CJK TC")
PDF_STANDARD = "a-2b"


def lit(text: object) -> str:
    """``text`` as a typst string literal (``"..."``): backslash, quote and control characters escaped."""
    out = []
    for ch in str(text):
        if ch in '\\"':
            out.append("\\" + ch)
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ord(ch) < 0x20 or ch == "\x7f":
            out.append(f"\\u{{{ord(ch):x}}}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def cjk_font_dir() -> str:
    """The folder of the Noto Sans CJK font the certificate embeds (a pip package, no system install)."""
    import cvttf_NotoSansCJK_Regular as cjk

    return str(Path(cjk.get_TTF_path()).parent)


@dataclass
class TypstDoc:
    """Typst source of a document built section by section; images kept as (name, PNG bytes)."""

    parts: list[str] = field(default_factory=list)
    images: dict[str, bytes] = field(default_factory=dict)

    def code(self, source: str) -> None:
        self.parts.append(source)

    def heading(self, text: str, level: int = 1) -> None:
        self.parts.append(f"#heading(level: {level}, {lit(text)})")

    def para(self, text: str, *, bold: bool = False, size: str | None = None) -> None:
        args = ", ".join(filter(None, ['weight: "bold"' if bold else "", f"size: {size}" if size else ""]))
        self.parts.append(f"#par(text({args + ', ' if args else ''}{lit(text)}))")

    def key_values(self, rows: list[tuple[str, str]]) -> None:
        cells = ", ".join(f"text(weight: \"bold\", {lit(k)}), {lit(v)}" for k, v in rows)
        self.parts.append(f"#table(columns: (auto, 1fr), stroke: none, inset: (x: 0pt, y: 2.5pt), "
                          f"column-gutter: 10pt, {cells})")

    def table(self, headers: tuple[str, ...], rows: list[tuple[str, ...]], columns: str | None = None) -> None:
        cols = columns or f"({', '.join(['auto'] * len(headers))})"
        head = ", ".join(f"text(weight: \"bold\", {lit(h)})" for h in headers)
        body = ", ".join(lit(c) for row in rows for c in row)
        self.parts.append(f"#table(columns: {cols}, inset: 4pt, stroke: 0.4pt + luma(140), "
                          f"table.header({head}){', ' + body if body else ''})")

    def image(self, name: str, png: bytes, caption: str, width: str = "100%") -> None:
        self.images[name] = png
        self.parts.append(f"#figure(image({lit(name)}, width: {width}), caption: {lit(caption)})")

    def source(self, *, number: str, banner: str | None, footer: str, title: str) -> str:
        """The whole typst document: A4 page with the certificate number, "page n of N" and (for a
        simulated run) the SIMULATED banner in the header of every page; ``footer`` on every page."""
        banner_code = (f"block(width: 100%, fill: rgb(\"#b00020\"), inset: 5pt, "
                       f"align(center, text(fill: white, weight: \"bold\", size: 10pt, {lit(banner)})))"
                       if banner else "none")
        return "\n".join([
            f"#set document(title: {lit(title)}, author: \"guideway\")",
            f"#set text(font: ({', '.join(lit(f) for f in FONTS)}), size: 9.5pt, lang: \"en\")",
            "#set par(justify: false, spacing: 0.8em)",
            "#set heading(numbering: \"1.\")",
            "#show heading.where(level: 1): set text(size: 11.5pt)",
            "#show heading: set block(above: 1.1em, below: 0.6em)",
            "#set page(paper: \"a4\", margin: (top: 3.3cm, bottom: 2.2cm, x: 1.9cm), header-ascent: 0.4cm,",
            f"  header: context {{ {banner_code}; v(2pt); grid(columns: (1fr, auto), "
            f"text(size: 8.5pt, {lit('Calibration certificate No. ' + number)}), "
            "text(size: 8.5pt, \"page \" + str(here().page()) + \" of \" + str(counter(page).final().first()))); "
            "line(length: 100%, stroke: 0.5pt) },",
            f"  footer: text(size: 7pt, fill: luma(60), {lit(footer)}))",
            *self.parts,
        ])


def compile_pdf(doc: TypstDoc, *, number: str, banner: str | None, footer: str, title: str,
                timestamp: datetime.date) -> bytes:
    """The PDF bytes of ``doc`` (typst, PDF/A-2b, fixed ``timestamp``: the same input gives the same bytes)."""
    import typst

    source = doc.source(number=number, banner=banner, footer=footer, title=title)
    when = datetime.datetime(timestamp.year, timestamp.month, timestamp.day, tzinfo=datetime.UTC)
    with tempfile.TemporaryDirectory(prefix="guideway-certificate-") as tmp:
        root = Path(tmp)
        for name, png in doc.images.items():
            (root / name).write_bytes(png)
        (root / "certificate.typ").write_text(source, encoding="utf-8")
        return typst.compile(str(root / "certificate.typ"), root=str(root), font_paths=[cjk_font_dir()],
                             ignore_system_fonts=True, pdf_standards=[PDF_STANDARD], timestamp=when)
