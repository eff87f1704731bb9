"""Layer contract: tui -> acquisition -> (processing | drivers), tui importing
acquisition only; mocks may use processing only; only acquisition/simulation.py imports mocks; only tui imports
textual.  Checked by walking every import statement (including lazy ones)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("acquisition", "drivers", "processing", "tui", "mocks")
MAY_IMPORT = {
    "tui": {"acquisition"},
    "acquisition": {"processing", "drivers"},
    "processing": set(),
    "drivers": set(),
    "mocks": {"processing"},
}
COMPOSITION_ROOT = Path("acquisition/simulation.py")


def imported_modules(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
    return found


def violations(root: Path) -> list[str]:
    bad = []
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            rel = path.relative_to(root)
            for lineno, mod in imported_modules(path):
                top = mod.split(".")[0]
                if top == "textual" and pkg != "tui":
                    bad.append(f"{rel}:{lineno} imports textual outside tui")
                if top in PACKAGES and top != pkg:
                    allowed = set(MAY_IMPORT[pkg])
                    if rel == COMPOSITION_ROOT:
                        allowed.add("mocks")
                    if top not in allowed:
                        bad.append(f"{rel}:{lineno} ({pkg}) imports {mod}")
    return bad


def test_layers_are_respected() -> None:
    assert violations(ROOT) == []


def test_checker_catches_a_crossed_layer(tmp_path: Path) -> None:
    for pkg in PACKAGES:
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
    (tmp_path / "drivers" / "bad.py").write_text("from acquisition import engine\n")
    (tmp_path / "processing" / "ui.py").write_text("def f():\n    import textual.app\n")
    (tmp_path / "acquisition" / "other.py").write_text("import mocks.world\n")
    (tmp_path / "acquisition" / "simulation.py").write_text("import mocks.world\n")
    (tmp_path / "tui" / "view.py").write_text("from drivers.errors import DriverError\n")
    found = violations(tmp_path)
    assert found == [
        "acquisition/other.py:1 (acquisition) imports mocks.world",
        "drivers/bad.py:1 (drivers) imports acquisition",
        "processing/ui.py:2 imports textual outside tui",
        "tui/view.py:1 (tui) imports drivers.errors",
    ]


def test_headless_modules_do_not_load_textual() -> None:
    code = (
        "import sys, acquisition.demo, acquisition.engine, processing.straightness, "
        "drivers.interferometer, drivers.keyence_lkg, mocks.world, tui.cli\n"
        "print('textual' in sys.modules)"
    )
    # a fresh interpreter (the point): this one may have loaded textual for other tests
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
