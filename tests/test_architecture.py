"""The layout contract (docs/architecture.md), checked by walking every import statement: module
level, inside a function (lazy) and under ``if TYPE_CHECKING:``.

* Layers: ``tui -> acquisition -> fleet -> saved_runs -> (processing | drivers)``; a layer may skip
  the ones below it, never reach up (``fleet`` and ``saved_runs`` together are the saved-runs layer:
  ``fleet`` works on many run directories through ``saved_runs``, which works on one).  ``tui``
  imports neither drivers, processing nor mocks;
  ``mocks`` uses processing only; only ``acquisition/simulated/`` imports mocks; only ``tui``
  imports textual.
* Inside ``saved_runs`` and ``fleet`` the sub-packages form a stack (:data:`STACKS`): each imports
  only those below it.
* No import cycle between modules.
* No top-level package holds more than 25 % of the code lines.
* The front ends share the services: no screen imports a command-line module.
* ``guideway --help`` loads neither NumPy, pandas, SciPy, Matplotlib, Textual nor SQLAlchemy.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("acquisition", "fleet", "saved_runs", "drivers", "processing", "tui", "mocks")
MAY_IMPORT = {
    "tui": {"acquisition", "fleet", "saved_runs"},
    "acquisition": {"fleet", "saved_runs", "processing", "drivers"},
    "fleet": {"saved_runs", "processing"},
    "saved_runs": {"processing", "drivers"},
    "processing": set(),
    "drivers": set(),
    "mocks": {"processing"},
}
MOCKS_IMPORTED_BY = Path("acquisition/simulated")  # the simulated rig: the only importer of mocks
# saved_runs' sub-packages (and top modules), lowest first: each may import only what stands before it
SAVED_RUNS_ORDER = ("errors", "toml_file", "store", "catalog", "importing", "results", "evaluation", "export",
                    "report", "certificate", "diagnosis", "volumetric")
FLEET_ORDER = ("catalog", "compare", "trend", "verify", "overview")
STACKS = {"saved_runs": SAVED_RUNS_ORDER, "fleet": FLEET_ORDER}
MAX_SHARE = 0.25
HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "textual", "sqlalchemy")


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(root: Path, path: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every import in ``path``; relative imports resolved, ``from X import
    name`` giving ``X.name`` (a module or a name in X)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    me = module_name(root, path).split(".")
    package = me if path.name == "__init__.py" else me[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            found += [(node.lineno, f"{module}.{alias.name}") for alias in node.names]
    return found


def code_files(root: Path) -> list[Path]:
    return sorted(p for pkg in PACKAGES if (root / pkg).is_dir() for p in (root / pkg).rglob("*.py"))


def violations(root: Path) -> list[str]:
    """Layer, mocks, textual, saved_runs-order and front-end rules broken, one line each."""
    bad = []
    for path in code_files(root):
        rel = path.relative_to(root)
        pkg = rel.parts[0]
        for lineno, mod in imported_modules(root, path):
            top = mod.split(".")[0]
            where = f"{rel.as_posix()}:{lineno}"
            if top == "textual" and pkg != "tui":
                bad.append(f"{where} imports textual outside tui")
            if top == "mocks" and pkg != "mocks" and not rel.is_relative_to(MOCKS_IMPORTED_BY):
                bad.append(f"{where} imports mocks outside {MOCKS_IMPORTED_BY.as_posix()}/")
            elif top in PACKAGES and top != pkg and top not in MAY_IMPORT[pkg] and top != "mocks":
                bad.append(f"{where} ({pkg}) imports {mod}")
            if pkg in STACKS and pkg == top and len(rel.parts) > 1 and "." in mod:
                order = STACKS[pkg]
                mine, theirs = _stack_place(order, rel.parts[1]), _stack_place(order, mod.split(".")[1])
                if mine is not None and theirs is not None and theirs > mine:
                    bad.append(f"{where} ({pkg}.{order[mine]}) imports upward: {mod}")
            if pkg == "tui" and mod.startswith("tui.commands") and rel.parts[1] not in ("cli.py", "commands"):
                bad.append(f"{where} imports the command line ({mod}); call the service it calls")
    return bad


def _stack_place(order: tuple[str, ...], part: str) -> int | None:
    name = part.removesuffix(".py")
    return order.index(name) if name in order else None


def module_graph(root: Path) -> dict[str, set[str]]:
    """Module -> the project modules it imports (a name imported from a module counts for that module)."""
    files = {module_name(root, p): p for p in code_files(root)}
    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        deps = set()
        for _, imp in imported_modules(root, path):
            while imp and imp not in files:
                imp = imp.rpartition(".")[0]
            if imp and imp != mod and not mod.startswith(imp + "."):  # a package's own __init__ is no edge
                deps.add(imp)
        graph[mod] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on, stack, out = set(), [], []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on.add(start)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def package_shares(root: Path) -> dict[str, float]:
    """Each top-level package's share of the non-blank code lines."""
    lines = {pkg: sum(1 for p in (root / pkg).rglob("*.py") for ln in p.read_text(encoding="utf-8").splitlines()
                      if ln.strip()) for pkg in PACKAGES if (root / pkg).is_dir()}
    total = sum(lines.values())
    return {pkg: n / total for pkg, n in lines.items()}


def test_layers_are_respected() -> None:
    assert violations(ROOT) == []


def test_no_import_cycles() -> None:
    assert cycles(module_graph(ROOT)) == []


def test_no_package_holds_more_than_a_quarter_of_the_code() -> None:
    shares = package_shares(ROOT)
    assert {pkg: round(s, 3) for pkg, s in shares.items() if s > MAX_SHARE} == {}


def test_checker_catches_each_broken_rule(tmp_path: Path) -> None:
    for pkg in PACKAGES:
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
    for sub in ("acquisition/simulated", "saved_runs/store", "saved_runs/report", "tui/screens", "tui/commands",
                "fleet/catalog"):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "__init__.py").write_text("")
    (tmp_path / "drivers" / "bad.py").write_text("from acquisition import engine\n")
    (tmp_path / "processing" / "ui.py").write_text("def f():\n    import textual.app\n")
    (tmp_path / "acquisition" / "other.py").write_text("import mocks.world\n")
    (tmp_path / "acquisition" / "simulated" / "rig.py").write_text("import mocks.world\n")
    (tmp_path / "saved_runs" / "store" / "up.py").write_text("from ..report import build\n")
    (tmp_path / "saved_runs" / "back.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                                     "    from acquisition.setup import x\n")
    (tmp_path / "tui" / "view.py").write_text("from drivers.errors import DriverError\n")
    (tmp_path / "fleet" / "catalog" / "up.py").write_text("from ..trend import fit\n")
    (tmp_path / "saved_runs" / "store" / "fleet_up.py").write_text("from fleet.catalog import runs\n")
    (tmp_path / "tui" / "screens" / "results.py").write_text("from ..commands.process import METHODS\n")
    assert violations(tmp_path) == [
        "acquisition/other.py:1 imports mocks outside acquisition/simulated/",
        "drivers/bad.py:1 (drivers) imports acquisition.engine",
        "fleet/catalog/up.py:1 (fleet.catalog) imports upward: fleet.trend.fit",
        "processing/ui.py:2 imports textual outside tui",
        "saved_runs/back.py:3 (saved_runs) imports acquisition.setup.x",
        "saved_runs/store/fleet_up.py:1 (saved_runs) imports fleet.catalog.runs",
        "saved_runs/store/up.py:1 (saved_runs.store) imports upward: saved_runs.report.build",
        "tui/screens/results.py:1 imports the command line (tui.commands.process.METHODS); call the service "
        "it calls",
        "tui/view.py:1 (tui) imports drivers.errors.DriverError",
    ]


def test_cycle_finder_sees_a_lazy_loop(tmp_path: Path) -> None:
    (tmp_path / "saved_runs").mkdir()
    (tmp_path / "saved_runs" / "__init__.py").write_text("")
    (tmp_path / "saved_runs" / "a.py").write_text("from .b import f\n")
    (tmp_path / "saved_runs" / "b.py").write_text("def f():\n    from .c import g\n")
    (tmp_path / "saved_runs" / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                                  "    from .a import h\n")
    (tmp_path / "saved_runs" / "d.py").write_text("from . import a\n")  # into the loop, not part of it
    assert cycles(module_graph(tmp_path)) == [["saved_runs.a", "saved_runs.b", "saved_runs.c"]]


def test_headless_modules_do_not_load_textual() -> None:
    code = (
        "import sys, acquisition.demo, acquisition.engine, processing.straightness, saved_runs.report.build, "
        "drivers.interferometer, drivers.keyence_lkg, mocks.world, tui.cli\n"
        "print('textual' in sys.modules)"
    )
    # a fresh interpreter (the point): this one may have loaded textual for other tests
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_help_loads_no_numerical_library() -> None:
    """``guideway --help`` (every sub-command registered) answers without NumPy, pandas, SciPy,
    Matplotlib, Textual or SQLAlchemy: their import alone takes most of a second."""
    code = (
        "import contextlib, io, sys\n"
        "from tui.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()) as out, contextlib.suppress(SystemExit):\n"
        "    main(['--help'])\n"
        f"print(sorted({{m.split('.')[0] for m in sys.modules}} & {set(HEAVY)!r}), 'acquire' in out.getvalue())"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["[]", "True"]
