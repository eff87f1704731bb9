"""Time of ``guideway process`` on a straightness run against a numpy lower bound, and its peak memory.

For 20, 200 and 2,000-station runs (written by ``guideway simulate`` from docs/scenario-straightness.toml,
forward pass only, as benchmarks/bench_process_memory.py) it times, each in a fresh process (wall clock,
interpreter start and imports included on both sides):

* the tool: ``guideway process RUN --mc-trials T`` (results/ written: profile.csv, summary.json, and
  profile.png where ``process`` writes it);
* the bound: a plain numpy script (:data:`BOUND`) that makes the same draws (the tool's seeded streams,
  one per input), decouples every trial by the exact method with the datum pitch re-estimated per trial,
  evaluates the three reference lines per trial and the per-station spread, and writes nothing.  It
  reads the run's channels from an .npz made beforehand (no CSV parsing, no pandas).  Its minimum zone
  per trial is ``processing.reference_lines.minimum_zone_many`` (the vectorised exact width: numpy only),
  the rest is written out here; its results are checked against the tool's summary.json (the per-line
  Monte Carlo U to 1e-9 um).

and prints tool / bound at each size, then ``--mc-trials 10000`` against ``--mc-trials 0`` at 200
stations, and the Monte Carlo's own cost (tool: 10000 less 0 trials) against the bound's (its run less
its interpreter start and imports).  Medians of ``--runs`` runs (>= 5 recommended), tool and bound
alternated so that a change of the machine's load hits both; peak RSS of the tool from ``os.wait4`` (its ``ru_maxrss``).
``--source DIR`` measures the tool from another checkout (e.g. an older commit unpacked there).

On machines that set OPENBLAS_CORETYPE (see the environment notes), unset it together with
OPENBLAS_L2_SIZE for the benchmark command alone: ``env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE python ...``.

    python benchmarks/bench_process_speed.py [--runs 5] [--sizes 20,200,2000] [--work DIR] [--source DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_process_memory import ROOT, guideway, make_run  # noqa: E402

TARGET_RATIO = 1.5  # issue 28
LIMIT_MB = 300.0

BOUND = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from processing.reference_lines import minimum_zone_many  # numpy only

d = np.load(sys.argv[2])
trials, seed, chunk = int(sys.argv[3]), 0, 250_000
x, lin, stry, strz = d["x_mm"], d["lin_um"], d["stry_um"], d["strz_um"]
pitch, yaw, roll, sensor = d["pitch_urad"], d["yaw_urad"], d["roll_urad"], d["sensor_mm"]
P, Q, B, sgn = d["mirror"], d["sensor"], d["beam"], float(d["sign"])
u = d["inputs"]  # sensor_noise, sensor_resolution, straightness, angle, position, offset, step
n = len(x)
names = ("sensor_noise", "sensor_resolution", "stry", "strz", "pitch", "yaw", "roll", "offset", "x")
rng = dict(zip(names, (np.random.default_rng(c) for c in np.random.SeedSequence(seed).spawn(9))))

def rot(ex, ey, ez, v):
    x_, y_, z_ = v
    c, s = np.cos(ex), np.sin(ex); y_, z_ = c * y_ - s * z_, s * y_ + c * z_
    c, s = np.cos(ey), np.sin(ey); x_, z_ = c * x_ + s * z_, -s * x_ + c * z_
    c, s = np.cos(ez), np.sin(ez); return c * x_ - s * y_, s * x_ + c * y_, z_

def exact(sen, sy, sz, pi, ya, ro, p, q):
    # heights (um) by exact kinematics, datum pitch re-estimated from the first step (3 iterations):
    # the chord O1 - O0 = (d1 - d0) - (dR1 - dR0) R0 P seen from the datum capture's frame (dR0^T)
    s = sgn * (sen - sen[:, :1]) * 1000.0
    dl = -s * 1e-3
    ex, ey, ez = ro * 1e-6, ya * 1e-6, pi * 1e-6
    dx = x[1] - x[0] + (lin[1] - lin[0]) * 1e-3
    dy = (sy[:, 1:2] - sy[:, :1]) * 1e-3
    dz = (sz[:, 1:2] - sz[:, :1]) * 1e-3
    def rows(a, b, c):
        cx, sx, cy, sy_, cz, sz_ = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
        return ((cz * cy, cz * sy_ * sx - sz_ * cx, cz * sy_ * cx + sz_ * sx),
                (sz_ * cy, sz_ * sy_ * sx + cz * cx, sz_ * sy_ * cx - cz * sx), (-sy_, cy * sx, cy * cx))
    r1, r0 = rows(ex[:, 1:2], ey[:, 1:2], ez[:, 1:2]), rows(ex[:, :1], ey[:, :1], ez[:, :1])
    m = [[a - b for a, b in zip(ra, rb)] for ra, rb in zip(r1, r0)]
    wx, wy, wz = p
    ez0 = 0.0
    for _ in range(3):
        c, s_ = np.cos(ez0), np.sin(ez0)
        px, py = c * wx - s_ * wy, s_ * wx + c * wy
        ch = [d - (row[0] * px + row[1] * py + row[2] * wz) for d, row in zip((dx, dy, dz), m)]
        ux = r0[0][0] * ch[0] + r0[1][0] * ch[1] + r0[2][0] * ch[2]
        uy = r0[0][1] * ch[0] + r0[1][1] * ch[1] + r0[2][1] * ch[2]
        ez0 = np.arctan2(uy, ux)
    cx, cy, cz = rot(0.0, 0.0, ez0, (q[0] - p[0], q[1] - p[1], q[2] - p[2]))
    bx, by, bz = rot(0.0, 0.0, ez0, tuple(B))
    wx, wy, _ = rot(ex, ey, ez, (cx + dl * bx, cy + dl * by, cz + dl * bz))
    wx = wx + (x - x[0]) + (lin - lin[0]) * 1e-3
    wy = wy + (sy - sy[:, :1]) * 1e-3
    return wx - wx[:, :1], (wy - wy[:, :1]) * 1e3

one = lambda a: a[None, :]
xo, h0 = exact(one(sensor), one(stry), one(strz), one(pitch), one(yaw), one(roll), [np.array([[v]]) for v in P],
               [np.array([[v]]) for v in Q])
xo, h0 = xo[0], h0[0]
slope = np.gradient(h0, xo)
m_chunk = max(1, chunk // n)
vals = {k: np.empty(trials) for k in ("endpoint", "least_squares", "minimum_zone")}
s1 = s2 = 0.0
first = None
for t0 in range(0, trials, m_chunk):
    m = min(m_chunk, trials - t0)
    g = lambda k, sig: rng[k].normal(0.0, sig, (m, n))
    sen = sensor + g("sensor_noise", u[0]) * 1e-3 + rng["sensor_resolution"].uniform(-0.5, 0.5, (m, n)) * u[1] * 1e-3
    sy = stry + g("stry", u[2]); sz = strz + g("strz", u[2])
    pi, ya, ro = pitch + g("pitch", u[3]), yaw + g("yaw", u[3]), roll + g("roll", u[3])
    off = rng["offset"].normal(0.0, u[5], (m, 6))
    p = [P[i] + off[:, i:i + 1] for i in range(3)]
    q = [Q[i] + off[:, 3 + i:4 + i] for i in range(3)]
    _, h = exact(sen, sy, sz, pi, ya, ro, p, q)
    dxs = rng["x"].normal(0.0, u[4] * 1e-3, (m, n)); dxs -= dxs[:, :1]
    h = h + slope * dxs
    b = (h[:, -1] - h[:, 0]) / (xo[-1] - xo[0])
    r = h - b[:, None] * xo
    vals["endpoint"][t0:t0 + m] = r.max(1) - r.min(1)
    xm = xo - xo.mean()
    r = h - ((h * xm).sum(1) / (xm @ xm))[:, None] * xm
    vals["least_squares"][t0:t0 + m] = r.max(1) - r.min(1)
    vals["minimum_zone"][t0:t0 + m] = minimum_zone_many(xo, h)
    if first is None:
        first = h[0].copy()
    dh = h - first
    s1 = s1 + dh.sum(0); s2 = s2 + (dh * dh).sum(0)
spread = np.sqrt(np.maximum((s2 - s1 * s1 / trials) / (trials - 1), 0.0))
print(json.dumps({k: float(v.std(ddof=1)) for k, v in vals.items()} | {"spread_max": float(spread.max())}))
"""


# the bound's interpreter start and imports alone
BOUND_START = "import sys; import numpy as np; sys.path.insert(0, sys.argv[1]); import processing.reference_lines"


def write_npz(run: Path, path: Path) -> None:
    """The run's channels, geometry and uncertainty inputs as arrays for :data:`BOUND` (untimed)."""
    import numpy as np

    from saved_runs.evaluation.straightness import run_geometry
    from saved_runs.store.reader import load_run

    loaded = load_run(run)
    g = run_geometry(loaded)
    u = loaded.meta["setup"].get("uncertainty") or {}
    from processing.uncertainty import UncertaintyInputs

    ui = UncertaintyInputs.from_dict(u)
    if g.datum_angles_urad.as_tuple() != (None, None, None):
        raise SystemExit("the bound assumes no measured datum angles")
    cols = {c: loaded.points[c].to_numpy(dtype=float) for c in ("x_mm", "lin_um", "stry_um", "strz_um",
                                                                "pitch_urad", "yaw_urad", "roll_urad",
                                                                "sensor_mm")}
    np.savez(path, **cols, mirror=np.array(g.mirror_mm), sensor=np.array(g.sensor_mm),
             beam=np.array(g.sensor_beam), sign=1.0 if g.sensor_sign == "height" else -1.0,
             inputs=np.array([ui.sensor_noise_um, ui.sensor_resolution_um, ui.straightness_um, ui.angle_urad,
                              ui.position_um, ui.offset_mm, ui.step_mm]))


def timed(cmd: list[str]) -> tuple[float, float, str]:
    """(seconds, peak RSS MB, stdout) of one command in a fresh process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out = proc.stdout.read().decode() if proc.stdout else ""
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        err = proc.stderr.read().decode() if proc.stderr else ""
        raise SystemExit(f"{' '.join(cmd[-3:])} failed: {err.strip()[-500:]}")
    return seconds, usage.ru_maxrss / 1024.0, out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", default="20,200,2000")
    ap.add_argument("--trials", default="10000,10000,1000", help="Monte Carlo trials per size")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "guideway-bench-process")
    ap.add_argument("--source", type=Path, default=ROOT, help="checkout whose tool is measured (default: this one)")
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(ROOT))
    load = os.getloadavg()[0]
    print(f"tool: {args.source.resolve()}; runs in {args.work}; {args.runs} runs each; load {load:.1f}")
    print(f"{'stations':>8} {'trials':>7} {'tool s':>8} {'bound s':>8} {'ratio':>6} {'tool MB':>8}  check")
    worst = 0.0
    ok = True
    for n, trials in zip((int(s) for s in args.sizes.split(",")), (int(t) for t in args.trials.split(",")),
                         strict=True):
        run = make_run(n, args.work)
        npz = args.work / f"bound-{n}.npz"
        write_npz(run, npz)
        tool = guideway(args.source, "process", str(run), "--mc-trials", str(trials))
        bound = [sys.executable, "-c", BOUND, str(ROOT), str(npz), str(trials)]
        ts, bs, peak = [], [], 0.0
        for _ in range(args.runs):
            t, mb, _ = timed(tool)
            b, _, out = timed(bound)
            ts.append(t)
            bs.append(b)
            peak = max(peak, mb)
        summary = json.loads((run / "results" / "summary.json").read_text())
        mc = summary["uncertainty_um"]["straightness"]  # U = 2 u
        got = json.loads(out)
        diff = max(abs(mc[k] - 2.0 * got[k]) for k in ("endpoint", "least_squares", "minimum_zone"))
        check = f"U agree to {diff:.1e} um" if diff < 1e-9 else f"U DIFFER by {diff:.3g} um"
        ok &= diff < 1e-9
        ratio = statistics.median(ts) / statistics.median(bs)
        worst = max(worst, ratio)
        print(f"{n:>8} {trials:>7} {statistics.median(ts):>8.3f} {statistics.median(bs):>8.3f} {ratio:>6.2f} "
              f"{peak:>8.0f}  {check}", flush=True)
    run = make_run(200, args.work)
    npz = args.work / "bound-200.npz"
    write_npz(run, npz)
    on, off, bound_full, bound_start = [], [], [], []
    for _ in range(args.runs):
        on.append(timed(guideway(args.source, "process", str(run), "--mc-trials", "10000"))[0])
        off.append(timed(guideway(args.source, "process", str(run), "--mc-trials", "0"))[0])
        bound_full.append(timed([sys.executable, "-c", BOUND, str(ROOT), str(npz), "10000"])[0])
        bound_start.append(timed([sys.executable, "-c", BOUND_START, str(ROOT)])[0])
    mc_ratio = statistics.median(on) / statistics.median(off)
    print(f"200 stations: --mc-trials 10000 {statistics.median(on):.3f} s, --mc-trials 0 "
          f"{statistics.median(off):.3f} s, ratio {mc_ratio:.2f}")
    # the Monte Carlo's own cost against the bound's (its run less its interpreter and imports)
    tool_mc = statistics.median(on) - statistics.median(off)
    bound_mc = statistics.median(bound_full) - statistics.median(bound_start)
    print(f"200 stations, 10,000 trials: Monte Carlo {tool_mc:.3f} s (tool, on - off), bound {bound_mc:.3f} s "
          f"(its run - its start {statistics.median(bound_start):.3f} s), ratio {tool_mc / bound_mc:.2f}")
    print(f"worst tool/bound {worst:.2f} (target {TARGET_RATIO}), MC on/off {mc_ratio:.2f} (target {TARGET_RATIO}); "
          f"load now {os.getloadavg()[0]:.1f}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
