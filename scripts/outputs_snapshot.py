#!/usr/bin/env python3
"""Record, and compare, what a fixed set of ``guideway`` commands prints and writes.

A behaviour-preserving change (moving code between packages, renaming modules) must leave every
command's output, exit code and written file as it was.  This script runs a fixed list of commands
on fixed seeds (demo, acquire straightness and positioning ``--simulate --auto``, process / report /
export in every format and model, gcode, simulate, diagnose, volumetric, import, air-index, every
``--help`` and a few refusals), then stores each command's stdout, stderr and exit code and every
file it wrote, with what legitimately differs from one run to the next masked: wall-clock
timestamps and durations, run uids, pseudo-terminal names, TCP ports and the two directories
(checkout and work directory).

    .venv/bin/python scripts/outputs_snapshot.py record OUT_DIR [--checkout DIR]
    .venv/bin/python scripts/outputs_snapshot.py compare OUT_A OUT_B

``record`` runs ``DIR/.venv/bin/guideway`` (default: this checkout) with DIR as working directory,
so the same script records an older checkout for comparison.  ``compare`` lists every file that
differs or exists on one side only and exits 1 if there is any.  Record the same checkout twice to
see that the masks leave nothing that varies by itself.
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

# A positioning data file for `import positioning`: 3 runs x 2 directions x 5 targets with air data.
IMPORT_CSV_HEADER = "run,direction,target_mm,reading_mm,time_s,air_temp_c,air_pressure_hpa,humidity_pct,material_temp_c"


def import_csv() -> str:
    rows = [IMPORT_CSV_HEADER]
    t = 0.0
    targets = (0.0, 98.4, 201.7, 297.9, 400.0)
    for run in (1, 2, 3):
        for direction in (1, -1):
            order = targets if direction == 1 else tuple(reversed(targets))
            for i, target in enumerate(order):
                # a deterministic deviation: scale error, a reversal error and a run-to-run shift (mm)
                dev = 12e-6 * target + (1.5e-3 if direction < 0 else 0.0) + 0.4e-3 * run - 0.3e-3 * (i % 2)
                rows.append(f"{run},{direction:+d},{target},{target + dev:.6f},{t:.1f},20.3,1013.1,45,20.1")
                t += 7.5
    return "\n".join(rows) + "\n"


def machine_toml(st_run: Path, pos_run: Path) -> str:
    """A two-axis machine whose X errors come from the recorded runs (volumetric run sources)."""
    return f"""kind = "machine"
name = "snapshot machine"

[frame]
primary = "X"
secondary = "Z"

[tool]
offset_mm = [0.0, 0.0, -120.0]

[[workpiece_chain]]
name = "X"
type = "prismatic"
direction = "+X"
range = [0.0, 380.0]

[workpiece_chain.errors]
EX = {{ run = "{pos_run}", channel = "linear" }}
EY = {{ run = "{st_run}", channel = "straightness", up = "+Y" }}
EB = {{ run = "{st_run}", channel = "yaw", up = "+Y" }}
EC = {{ run = "{st_run}", channel = "pitch", up = "+Y" }}
EA = {{ run = "{st_run}", channel = "roll", up = "+Y" }}

[[tool_chain]]
name = "Z"
type = "prismatic"
direction = "+Z"
range = [0.0, 200.0]

[tool_chain.errors]
EX = {{ poly = [0.0, 0.004] }}
EZ = {{ poly = [0.0, -0.01, 0.00002] }}

[[squareness]]
axes = ["X", "Z"]
value_urad = 12.0
"""


def commands(w: Path, checkout: Path) -> list[tuple[str, list[str]]]:
    """(name, argv after `guideway`) in the order they run; later commands read earlier runs."""
    st, pos = w / "st", w / "pos"
    cmds: list[tuple[str, list[str]]] = [("help", ["--help"])]
    for sub in ("demo", "acquire", "gcode", "process", "import", "air-index", "export", "volumetric", "sim",
                "devices", "report", "simulate", "diagnose", "tui"):
        cmds.append((f"help-{sub}", [sub, "--help"]))
    cmds += [
        ("demo", ["demo", "--out", str(w / "demo"), "--seed", "3"]),
        ("demo-hlg1", ["demo", "--out", str(w / "demo-hlg1"), "--sensor", "panasonic-hlg1", "--stations", "8",
                       "--seed", "5"]),
        ("demo-ild", ["demo", "--out", str(w / "demo-ild"), "--sensor", "me-ild1420", "--stations", "6",
                      "--no-noise"]),
        ("demo-fault", ["demo", "--out", str(w / "demo-fault"), "--stations", "10", "--seed", "2",
                        "--faults", "sensor:garbage@4x1"]),
        ("acquire-st", ["acquire", "straightness", "--setup", "docs/setup-straightness.toml", "--out", str(st),
                        "--simulate", "--auto", "--seed", "4"]),
        ("acquire-pos", ["acquire", "positioning", "--setup", "docs/setup-positioning.toml", "--out", str(pos),
                         "--simulate", "--auto", "--seed", "6"]),
        ("acquire-pos-scenario", ["acquire", "positioning", "--setup", "docs/setup-positioning.toml",
                                  "--out", str(w / "pos-scn"), "--simulate", "--auto", "--seed", "1",
                                  "--scenario", "docs/scenario-positioning.toml"]),
        ("acquire-resume-done", ["acquire", "--resume", str(st), "--simulate", "--auto"]),
    ]
    for method in ("exact", "first-order", "patent"):
        cmds.append((f"process-st-{method}", ["process", str(st), "--json", "--no-write", "--method", method,
                                              "--mc-trials", "2000"]))
    cmds += [
        ("process-st", ["process", str(st)]),
        ("process-pos", ["process", str(pos)]),
        ("process-pos-json", ["process", str(pos), "--json", "--no-write", "--k", "3",
                              "--edition", "ISO 230-2:2006"]),
        ("process-demo-json", ["process", str(w / "demo"), "--json", "--no-write"]),
        ("process-v1", ["process", str(checkout / "tests/data/runs/v1-straightness"), "--json", "--no-write"]),
        ("process-tui-runs", ["process", str(checkout / "tests/data/tui-runs/positioning-x"), "--json", "--no-write"]),
        ("process-aborted", ["process", str(checkout / "tests/data/tui-runs/straightness-aborted"), "--no-write"]),
        ("report-st", ["report", str(st)]),
        ("report-pos", ["report", str(pos), "--out", str(w / "pos-report.html")]),
    ]
    for fmt in ("linuxcnc", "fanuc", "siemens", "csv"):
        for model in ("linear", "spline", "segments", "polynomial"):
            cmds.append((f"export-{fmt}-{model}", ["export", str(pos), "--format", fmt, "--model", model,
                                                    "--out", str(w / f"table-{fmt}-{model}.txt")]))
    cmds += [
        ("export-json", ["export", str(pos), "--format", "linuxcnc", "--json", "--out", str(w / "table.json.txt")]),
        ("export-stdout", ["export", str(pos), "--format", "fanuc", "--step", "50"]),
        ("gcode-fanuc", ["gcode", "--setup", "docs/setup-positioning.toml", "--dialect", "fanuc"]),
        ("gcode-linuxcnc", ["gcode", "--setup", "docs/setup-positioning.toml", "--dialect", "linuxcnc",
                            "--out", str(w / "program.ngc")]),
        ("simulate-pos", ["simulate", "docs/scenario-positioning.toml", "--out", str(w / "sim-pos"), "--seed", "7"]),
        ("simulate-st", ["simulate", "docs/scenario-straightness.toml", "--out", str(w / "sim-st"), "--seed", "8"]),
        ("diagnose-pos", ["diagnose", str(w / "sim-pos"), "--model", "docs/model-positioning.toml",
                          "--report", str(w / "diag-pos.html"), "--out", str(w / "diag-pos-model.toml")]),
        ("diagnose-pos-json", ["diagnose", str(w / "sim-pos"), "--json"]),
        ("diagnose-st-json", ["diagnose", str(w / "sim-st"), "--json", "--report", str(w / "diag-st.html")]),
        ("volumetric-example", ["volumetric", "docs/machine-example.toml", "--out", str(w / "vol"), "--grid", "4"]),
        ("volumetric-exact", ["volumetric", "docs/machines/seed004-5axis.toml", "--out", str(w / "vol-exact"),
                              "--grid", "3", "--exact"]),
        ("volumetric-runs", ["volumetric", str(w / "machine.toml"), "--out", str(w / "vol-runs"), "--grid", "4"]),
        ("volumetric-at", ["volumetric", str(w / "machine.toml"), "--at", "100", "50", "--json"]),
        ("volumetric-export", ["volumetric", str(w / "machine.toml"), "--export", "linuxcnc",
                               "--out", str(w / "vol-tables")]),
        ("volumetric-export-csv", ["volumetric", "docs/machine-example.toml", "--export", "csv",
                                   "--out", str(w / "vol-tables-csv")]),
        ("import", ["import", "positioning", str(w / "data.csv"), "--out", str(w / "imported"), "--axis", "Y",
                    "--machine", "M1"]),
        ("process-imported", ["process", str(w / "imported"), "--json"]),
        ("export-imported", ["export", str(w / "imported"), "--format", "siemens", "--model", "spline"]),
        ("air-index", ["air-index", "--t-c", "20", "--p-pa", "101325", "--rh", "50", "--json"]),
        ("air-index-ciddor", ["air-index", "--t-c", "22.5", "--p-pa", "99000", "--rh", "30",
                              "--equation", "ciddor"]),
        # refusals: one line, exit 2
        ("bad-process", ["process", str(w / "missing")]),
        ("bad-export-straightness", ["export", str(st), "--format", "linuxcnc"]),
        ("bad-import", ["import", "positioning", str(w / "machine.toml"), "--out", str(w / "bad-import")]),
        ("bad-diagnose", ["diagnose", str(st), "--model", "docs/model-positioning.toml"]),
        ("bad-volumetric", ["volumetric", "docs/setup-positioning.toml", "--out", str(w / "bad-vol")]),
        ("bad-acquire", ["acquire", "straightness", "--setup", "docs/setup-positioning.toml",
                         "--out", str(w / "bad-acq"), "--simulate", "--auto"]),
    ]
    return cmds


# What varies by itself from one recording to the next, masked in every text file and stream.
MASKS = [
    (re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}:\d{2}(\.\d+)?(Z|[+-]\d{2}:?\d{2})?"), "<TIME>"),
    (re.compile(r"\d{8}T\d{6}Z?"), "<TIME>"),
    (re.compile(r"/dev/pts/\d+"), "/dev/pts/<N>"),
    (re.compile(r"/tmp/guideway-sim-[\w]+"), "/tmp/guideway-sim-<X>"),
    (re.compile(r"(127\.0\.0\.1|localhost):\d+"), r"\1:<PORT>"),
    (re.compile(r"\b[0-9a-f]{32}\b|\b[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}\b"), "<UID>"),
    (re.compile(r"pid \d+"), "pid <PID>"),
]
# JSON keys whose values are wall-clock quantities
CLOCK_KEYS = {"created", "ended", "duration_s", "uid", "elapsed_s", "started", "start_time_s"}
# points.csv columns of a live run that follow the wall clock: the capture time, and the simulated air and
# material, which drift with real time (and, in a scenario run with thermal effects, the readings too)
CLOCK_COLUMNS = ("time_s", "air_temp_c", "air_pressure_hpa", "humidity_pct", "material_temp_c")


def mask_text(text: str, roots: dict[str, str]) -> str:
    for path, name in roots.items():
        text = text.replace(path, name)
    for rx, repl in MASKS:
        text = rx.sub(repl, text)
    return text


def mask_json(obj: object) -> object:
    if isinstance(obj, dict):
        return {k: ("<CLOCK>" if k in CLOCK_KEYS else mask_json(v)) for k, v in obj.items()}
    if isinstance(obj, list):
        return [mask_json(v) for v in obj]
    return obj


def mask_csv(text: str, columns: tuple[str, ...]) -> str:
    """Blank the columns of a run's points.csv that follow the wall clock."""
    lines = text.split("\n")
    header = lines[0].split(",")
    cols = [header.index(c) for c in columns if c in header]
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for col in cols:
            if len(cells) > col:
                cells[col] = "<T>"
        out.append(",".join(cells))
    return "\n".join(out)


def normalised(path: Path, roots: dict[str, str], live_runs: dict[Path, tuple[str, ...]]) -> bytes:
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return data
    if path.suffix == ".json":
        with contextlib.suppress(ValueError):  # not JSON after all: masked as text
            text = json.dumps(mask_json(json.loads(text)), indent=1, sort_keys=True)
    if path.name == "points.csv" and path.parent in live_runs:
        text = mask_csv(text, live_runs[path.parent])
    return mask_text(text, roots).encode("utf-8")


def record(out: Path, checkout: Path) -> int:
    guideway = checkout / ".venv" / "bin" / "guideway"
    if not guideway.exists():
        print(f"outputs_snapshot: {guideway} not found; run ./scripts/test there first", file=sys.stderr)
        return 2
    work = out / "work"
    if out.exists():
        if not out.is_dir() or {p.name for p in out.iterdir()} - {"streams", "files", "work"}:
            print(f"outputs_snapshot: {out} holds other files; give a new directory or an earlier recording",
                  file=sys.stderr)
            return 2
        shutil.rmtree(out)  # an earlier recording: replaced
    work.mkdir(parents=True)
    (work / "data.csv").write_text(import_csv())
    (work / "machine.toml").write_text(machine_toml(work / "st", work / "pos"))
    roots = {str(work): "<W>", str(checkout): "<ROOT>"}
    # runs recorded live against the wall clock (their capture times vary); simulate's are synthetic
    live_runs = {work / n: CLOCK_COLUMNS for n in ("st", "pos", "demo", "demo-hlg1", "demo-ild", "demo-fault")}
    live_runs[work / "pos-scn"] = (*CLOCK_COLUMNS, "reading_mm")
    env = dict(os.environ, COLUMNS="100", LC_ALL="C.UTF-8", TZ="UTC", PYTHONHASHSEED="0")
    streams = out / "streams"
    streams.mkdir()
    for name, argv in commands(work, checkout):
        res = subprocess.run([str(guideway), *argv], cwd=checkout, env=env, capture_output=True, text=True,
                             stdin=subprocess.DEVNULL, timeout=600)
        body = (f"$ guideway {' '.join(argv)}\nexit {res.returncode}\n--- stdout\n{res.stdout}\n"
                f"--- stderr\n{res.stderr}")
        (streams / f"{name}.txt").write_text(mask_text(body, roots))
        print(f"{name}: exit {res.returncode}", file=sys.stderr)
    files = out / "files"
    for path in sorted(work.rglob("*")):
        if path.is_file():
            dest = files / path.relative_to(work)
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(normalised(path, roots, live_runs))
    shutil.rmtree(work)
    return 0


def compare(a: Path, b: Path) -> int:
    def listing(root: Path) -> set[Path]:
        return {p.relative_to(root) for p in root.rglob("*") if p.is_file()}

    la, lb = listing(a), listing(b)
    bad = 0
    for rel in sorted(la - lb):
        print(f"only in {a}: {rel}")
        bad += 1
    for rel in sorted(lb - la):
        print(f"only in {b}: {rel}")
        bad += 1
    for rel in sorted(la & lb):
        da, db = (a / rel).read_bytes(), (b / rel).read_bytes()
        if da == db:
            continue
        bad += 1
        print(f"differs: {rel}")
        try:
            diff = difflib.unified_diff(da.decode().splitlines(), db.decode().splitlines(), lineterm="", n=1)
            for i, line in enumerate(diff):
                if i >= 12:
                    print("    ...")
                    break
                print(f"    {line[:200]}")
        except UnicodeDecodeError:
            print("    (binary)")
    print(f"{len(la & lb)} files compared, {bad} difference(s)")
    return 1 if bad else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="verb", required=True)
    r = sub.add_parser("record")
    r.add_argument("out", type=Path)
    r.add_argument("--checkout", type=Path, default=HERE)
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = p.parse_args()
    if args.verb == "record":
        return record(args.out.resolve(), args.checkout.resolve())
    return compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
