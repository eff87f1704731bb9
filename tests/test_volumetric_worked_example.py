"""The worked example of docs/volumetric.md runs as written: its two commands make the runs, its
machine file (taken from the page) reads them, and ``--at 250 150``, the grid and the export print
what the page shows.  The page's numbers come from these commands; when the simulated devices or the
model change them, this test says the page must be updated."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from tui.cli import main

from .setups import replace_once

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "volumetric.md"


def example_blocks() -> list[str]:
    """The fenced blocks of the page's "Worked example" section, in order."""
    text = PAGE.read_text(encoding="utf-8")
    section = text[text.index("## Worked example"):]
    section = section[: section.index("\n## ", 4)]
    return re.findall(r"```[a-z]*\n(.*?)```", section, flags=re.S)


def x_setup() -> str:
    """docs/setup-positioning.toml changed as the page says: 0 … 400 mm, runs = 2, its [simulation]."""
    text = (ROOT / "docs" / "setup-positioning.toml").read_text(encoding="utf-8")
    text = replace_once(text, "\nend_mm = 1000.0 ", "\nend_mm = 400.0 ")
    text = replace_once(text, "\nruns = 5 ", "\nruns = 2 ")
    simulation = ("[simulation]\npitch_amplitude = 3.0\npitch_wavelength = 300.0\nslope_per_m = 10.0\n"
                  "backlash = 2.0\nperiodic = 0.0\nthermal_per_m_per_h = 0.0\nnoise = 0.1\n")
    return text[: text.index("[simulation]")] + simulation


def same(printed: list[str], page: list[str]) -> None:
    """Every line the page shows is the printed line at that place (a source the page cuts short with
    "(...)" or "..." up to the cut)."""
    assert len(printed) >= len(page), printed
    for got, want in zip(printed, page, strict=False):
        cut = re.sub(r"\s*(\(\.\.\.\)|\.\.\.)$", "", want)
        assert got.startswith(cut) if cut != want else got == want, (got, want)


@pytest.fixture(scope="module")
def example(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str]]:
    d = tmp_path_factory.mktemp("worked-example")
    commands, machine, at, grid = example_blocks()
    (d / "x-setup.toml").write_text(x_setup())
    (d / "machine.toml").write_text(machine)
    mp = pytest.MonkeyPatch()
    mp.chdir(d)
    try:
        for line in commands.strip().splitlines():
            args = shlex.split(line)
            assert args[0] == "guideway" and main(args[1:]) == 0, line
    finally:
        mp.undo()
    return d, [at, grid]


def run(d: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, *args: str) -> list[str]:
    monkeypatch.chdir(d)
    capsys.readouterr()
    assert main(["volumetric", "machine.toml", *args]) == 0
    return capsys.readouterr().out.splitlines()


def test_at_one_pose_prints_what_the_page_shows(example, capsys, monkeypatch) -> None:  # noqa: ANN001
    d, (at, _) = example
    lines = at.strip().splitlines()
    assert lines[0] == "$ guideway volumetric machine.toml --at 250 150"
    page = [x for x in lines[1:] if not x.startswith("guideway: note:")]  # the note goes to stderr
    same(run(d, capsys, monkeypatch, "--at", "250", "150"), page)


def test_grid_exact_and_export_print_what_the_page_says(example, capsys, monkeypatch) -> None:  # noqa: ANN001
    d, (_, grid) = example
    same(run(d, capsys, monkeypatch, "--out", "vol", "--grid", "11"), grid.strip().splitlines())
    exact = run(d, capsys, monkeypatch, "--out", "vol-exact", "--grid", "11", "--exact")
    assert "  max |exact - first order| 0.0003 um" in exact  # "(--exact: the same to 0.0003 µm.)"
    out = run(d, capsys, monkeypatch, "--export", "linuxcnc", "--out", "comp")
    table = np.loadtxt(d / "comp" / "X.comp")  # "11 positions ... 1.761 … 398.124 mm"
    assert len(table) == 11 and (table[0, 0], table[-1, 0]) == (1.761, 398.124)
    after = float(re.search(r"^X: .* -> ([0-9.]+) um after the table", "\n".join(out), re.M).group(1))
    assert round(after, 1) == 4.6  # "after the X table the error along X still reaches 4.6 µm"
    assert any(re.match(r"  ECX +position \(no axis\) +up to 12\.199 um", x) for x in out)  # "the pitch's 12.2 µm"
