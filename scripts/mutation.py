"""On-demand mutation testing of the numeric core and the codecs (issue 28; not in CI: hours on 2 cores).

Run through ``scripts/mutation`` (it installs the ``mutation`` extra, mutmut 3.x, into .venv).  For every
module it copies the working tree (tracked and untracked, not ignored files) into its own scratch
directory, sets ``[tool.mutmut]`` there to mutate that one module with its own tests plus every test file
that imports it, runs ``mutmut run`` and reads the verdicts from mutmut's ``mutants/<module>.meta``.
At the end it prints one table: killed / survived / timeout / other / score, where

    score = (killed + timeout) / (killed + timeout + survived + other)

(a mutant that makes a test hang is detected; "other" = no tests, suspicious, segfault; mutants
excluded with ``# pragma: no mutate`` are not counted at all).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("acquisition", "drivers", "fleet", "mocks", "processing", "saved_runs", "tui")

# module -> its own test files (globs, relative to the repository); importers are added automatically
MODULES: dict[str, tuple[str, ...]] = {
    "processing/iso230_2.py": ("tests/processing/test_iso230_2*.py", "tests/acquisition/test_iso230.py"),
    "processing/decoupling.py": ("tests/processing/test_decoupling*.py", "tests/processing/test_datum_angles.py"),
    "processing/reference_lines.py": ("tests/processing/test_reference_lines*.py",
                                      "tests/processing/test_minimum_zone.py"),
    "processing/air_index.py": ("tests/processing/test_air_index.py", "tests/processing/test_environment.py"),
    "processing/uncertainty.py": ("tests/processing/test_uncertainty*.py",),
    "processing/compensation/linuxcnc.py": ("tests/processing/test_compensation_writers.py",
                                            "tests/processing/test_linuxcnc_writer_strength.py"),
    "processing/compensation/fanuc.py": ("tests/processing/test_compensation_writers.py",
                                         "tests/processing/test_fanuc_writer_strength.py"),
    "processing/diagnosis/serial.py": ("tests/processing/test_diagnosis_serial.py",
                                       "tests/saved_runs/test_diagnose_*.py"),
    "drivers/keyence_lkg/protocol.py": ("tests/drivers/test_keyence_lkg*.py",),
    "drivers/panasonic_hlg1/protocol.py": ("tests/drivers/test_panasonic_hlg1.py",),
    "drivers/me_ild1420/protocol.py": ("tests/drivers/test_me_ild1420*.py",),
    "drivers/interferometer/codec.py": ("tests/drivers/test_interferometer*.py",),
}

KILLED = {1, 3, 37}  # tests failed (3: pytest internal error), or the type checker caught it
TIMEOUT = {36, 24, -24, 152, 255}
SURVIVED = {0}
SKIPPED = {34}  # not counted


def importers(module: str) -> list[str]:
    """Test files that import ``module`` (``import a.b.c``, ``from a.b.c import``, ``from a.b import c``)."""
    dotted = module.removesuffix(".py").replace("/", ".")
    parent, name = dotted.rsplit(".", 1)
    direct = re.compile(rf"^\s*(from\s+{re.escape(dotted)}\s+import|import\s+{re.escape(dotted)}\b)", re.M)
    via_parent = re.compile(rf"^\s*from\s+{re.escape(parent)}\s+import\s+(\([^)]*\)|[^\n]*)", re.M)
    found = []
    for path in sorted((ROOT / "tests").rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if direct.search(text) or any(re.search(rf"\b{name}\b", m.group(1)) for m in via_parent.finditer(text)):
            found.append(str(path.relative_to(ROOT)))
    return found


def test_files(module: str) -> list[str]:
    own = {str(p.relative_to(ROOT)) for g in MODULES[module] for p in ROOT.glob(g)}
    return sorted(own | {t for t in importers(module) if Path(t).name.startswith("test_")})


def copy_tree(dest: Path) -> None:
    """The working tree (tracked and untracked, not ignored) into ``dest``."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            check=True, capture_output=True).stdout.decode().split("\0")
    for rel in filter(None, listed):
        src = ROOT / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def configure(dest: Path, module: str, tests: list[str]) -> None:
    import tomlkit

    doc = tomlkit.parse((dest / "pyproject.toml").read_text(encoding="utf-8"))
    mm = doc["tool"].setdefault("mutmut", tomlkit.table())  # type: ignore[union-attr]
    mm["source_paths"] = [f"{p}/" for p in PACKAGES]  # every package copied, so the imports resolve
    # the tests also read docs/ (the example set-ups), README, scripts ...: everything else at the top level
    mm["also_copy"] = sorted(f"{p.name}/" if p.is_dir() else p.name for p in dest.iterdir()
                             if p.name not in (*PACKAGES, "tests", "mutants", "mutmut.log"))
    mm["only_mutate"] = [module]
    mm["pytest_add_cli_args_test_selection"] = tests
    (dest / "pyproject.toml").write_text(tomlkit.dumps(doc), encoding="utf-8")


def verdicts(dest: Path, module: str) -> dict[str, list[str]]:
    meta = json.loads((dest / "mutants" / f"{module}.meta").read_text(encoding="utf-8"))
    out: dict[str, list[str]] = {"killed": [], "survived": [], "timeout": [], "other": []}
    for key, code in meta["exit_code_by_key"].items():
        if code in SKIPPED:
            continue
        kind = ("killed" if code in KILLED else "timeout" if code in TIMEOUT
                else "survived" if code in SURVIVED else "other")
        out[kind].append(key)
    return out


def run_module(module: str, workdir: Path, jobs: int, keep: bool) -> dict[str, list[str]]:
    dest = workdir / module.removesuffix(".py").replace("/", "__")
    if dest.exists() and not keep:
        shutil.rmtree(dest)
    dest.mkdir(parents=True, exist_ok=True)
    copy_tree(dest)
    tests = test_files(module)
    configure(dest, module, tests)
    print(f"== {module}: {len(tests)} test files ({dest / 'mutmut.log'})", flush=True)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    t0 = time.monotonic()
    run = [sys.executable, "-m", "mutmut", "run", "--max-children", str(jobs)]
    with open(dest / "mutmut.log", "w", encoding="utf-8") as log:
        rc = subprocess.run(run, cwd=dest, env=env, stdout=log, stderr=subprocess.STDOUT).returncode
        if rc == 0 and keep and (dest / "mutants" / f"{module}.meta").exists():
            # mutmut re-runs a mutant only when its function changed, not when the tests did: an earlier
            # survivor is tested again by name (the new tests may kill it)
            again = verdicts(dest, module)["survived"]
            if again:
                rc = subprocess.run([*run, *again], cwd=dest, env=env, stdout=log,
                                    stderr=subprocess.STDOUT).returncode
    if rc != 0 or not (dest / "mutants" / f"{module}.meta").exists():
        print(f"   mutmut failed (exit {rc}); see {dest / 'mutmut.log'}", flush=True)
        return {}
    v = verdicts(dest, module)
    print(f"   {time.monotonic() - t0:.0f} s; survivors: {' '.join(v['survived']) or 'none'}", flush=True)
    return v


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("modules", nargs="*", help=f"modules to mutate (default: all {len(MODULES)}): "
                    + ", ".join(MODULES))
    ap.add_argument("--jobs", type=int, default=2, help="mutmut --max-children (default 2)")
    ap.add_argument("--workdir", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "guideway-mutation",
                    help="scratch directories, one per module (default $TMPDIR/guideway-mutation)")
    ap.add_argument("--keep", action="store_true", help="reuse an earlier run's results: mutmut tests the "
                    "mutants of changed functions, then every earlier survivor again; default: start afresh")
    ap.add_argument("--list-tests", action="store_true", help="print the test files of each module and stop")
    a = ap.parse_args()
    unknown = [m for m in a.modules if m not in MODULES]
    if unknown:
        print(f"error: not a module of the mutation run: {', '.join(unknown)} (choose from {', '.join(MODULES)})",
              file=sys.stderr)
        return 2
    modules = a.modules or list(MODULES)
    if a.list_tests:
        for m in modules:
            print(m, *test_files(m), sep="\n  ")
        return 0
    rows = []
    for m in modules:
        v = run_module(m, a.workdir.resolve(), a.jobs, a.keep)
        if not v:
            rows.append(f"| {m} | – | – | – | – | failed |")
            continue
        k, s, t, o = (len(v[x]) for x in ("killed", "survived", "timeout", "other"))
        total = k + s + t + o
        score = f"{(k + t) / total:.2f}" if total else "–"
        rows.append(f"| {m} | {k} | {s} | {t} | {o} | {score} |")
    print("\n| module | killed | survived | timeout | other | score |\n|---|---:|---:|---:|---:|---:|")
    print("\n".join(rows))
    return 0 if all(not r.endswith("failed |") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
