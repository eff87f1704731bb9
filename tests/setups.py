"""Set-up files for tests: the documented examples (docs/setup-*.toml) with a few values changed."""

from __future__ import annotations

from pathlib import Path

DOCS = Path(__file__).resolve().parents[1] / "docs"


def replace_once(text: str, old: str, new: str) -> str:
    """``text`` with its one ``old`` replaced (fails if the example no longer holds it exactly once)."""
    assert text.count(old) == 1, f"expected {old!r} once in the example set-up"
    return text.replace(old, new)


def straightness_setup_text(*, stations: int, samples: int | None = None, return_pass: bool = False) -> str:
    """docs/setup-straightness.toml with ``stations`` stations and the warm-up wait off; ``samples`` per
    reading and the return pass if given."""
    text = (DOCS / "setup-straightness.toml").read_text()
    text = replace_once(text, "stations = 20 ", f"stations = {stations} ")
    text = replace_once(text, "enabled = true", "enabled = false")
    if samples is not None:
        text = replace_once(text, "samples_per_reading = 5", f"samples_per_reading = {samples}")
    if return_pass:
        text = replace_once(text, "return_pass = false", "return_pass = true")
    return text
