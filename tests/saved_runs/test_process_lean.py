"""``process`` of a straightness run without pandas, scipy or matplotlib (issue 28: its time is close to a
plain numpy script's), with the same numbers and files as the DataFrame code it replaced.

The references here are what the tool used before: pandas (``to_csv``, ``groupby``/``merge``),
scipy (``sparse`` averaging matrix, ``fft.next_fast_len``/``rfft``) and matplotlib, computed in the test.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from processing.passes import return_pass_summary, station_groups
from processing.wavelength import next_fast_len, spectrum
from saved_runs.results.straightness import csv_text
from saved_runs.store.reader import load_run

from ..cli import ROOT, guideway

V1 = ROOT / "tests" / "data" / "runs" / "v1-straightness"
HEAVY = ("pandas", "scipy", "matplotlib")


@pytest.fixture()
def run(tmp_path: Path) -> Path:
    dest = tmp_path / "run"
    res = guideway("simulate", ROOT / "docs" / "scenario-straightness.toml", "--out", dest)
    assert res.returncode == 0, res.stderr
    shutil.rmtree(dest / "results", ignore_errors=True)
    return dest


def test_process_of_a_straightness_run_imports_no_pandas_scipy_or_matplotlib(run: Path) -> None:
    code = ("import sys; sys.path.insert(0, sys.argv.pop(1)); from tui.cli import main; rc = main(); "
            f"print(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r})), file=sys.stderr); "
            "sys.exit(rc)")
    res = subprocess.run([sys.executable, "-c", code, str(ROOT), "process", str(run), "--mc-trials", "200"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stderr.strip().splitlines()[-1] == "[]"
    assert sorted(p.name for p in (run / "results").iterdir()) == ["profile.csv", "summary.json"]


def test_plot_on_request_and_a_plain_process_leaves_no_older_plot(run: Path) -> None:
    assert guideway("process", run, "--mc-trials", "0", "--plot").returncode == 0
    assert (run / "results" / "profile.png").read_bytes()[:4] == b"\x89PNG"
    assert guideway("process", run, "--mc-trials", "0").returncode == 0
    assert not (run / "results" / "profile.png").exists()  # the set is profile.csv + summary.json now


def test_profile_csv_is_what_pandas_wrote(run: Path) -> None:
    """profile.csv equals pandas' ``to_csv(index=False, float_format="%.6f")`` of its own columns."""
    assert guideway("process", run, "--mc-trials", "50").returncode == 0
    text = (run / "results" / "profile.csv").read_text()
    df = pd.read_csv(run / "results" / "profile.csv")
    assert list(df.columns) == ["station", "x_mm", "height_um", "dev_endpoint_um", "dev_least_squares_um",
                                "dev_minimum_zone_um", "u_um"]
    assert df.to_csv(index=False, float_format="%.6f") == text
    rng = np.random.default_rng(5)
    cols = {"k": np.arange(7), "a": rng.normal(0, 1e3, 7), "b": np.array([np.nan, -0.0, np.inf, -np.inf,
                                                                          -4e-7, 5e-7, 1.2345675e8])}
    assert csv_text(cols) == pd.DataFrame(cols).to_csv(index=False, float_format="%.6f")


def test_loaded_columns_and_the_dataframe_agree() -> None:
    r = load_run(V1)
    df = pd.read_csv(V1 / "points.csv")
    assert list(r.columns) == [*df.columns, "pass", "not_still"]  # version 1: the v2 columns by default
    for c in df.columns:
        np.testing.assert_array_equal(r.columns[c], df[c].to_numpy())
        assert r.columns[c].dtype == (np.int64 if c == "station" else np.float64)
        assert not r.columns[c].flags.writeable
    assert (r.columns["pass"] == 0).all() and r.columns["pass"].dtype == np.int64
    assert r.points.equals(pd.DataFrame({c: np.asarray(v) for c, v in r.columns.items()}))
    assert r.n_points == len(df)


def _points_with_return_pass(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    fwd = np.arange(n)
    back = rng.permutation(n)[: n - 2]  # not every station revisited, out of order
    st = np.concatenate([fwd, back, back[:2]])  # two stations visited twice on the way back
    p = np.concatenate([np.zeros(n, int), np.ones(len(back) + 2, int)])
    return {"station": st, "pass": p, "time_s": np.arange(len(st)) * 60.0 + rng.uniform(0, 5, len(st))}


def test_station_averages_are_the_sparse_matrix_bits() -> None:
    from scipy import sparse

    rng = np.random.default_rng(11)
    pts = _points_with_return_pass(rng, 40)
    st = pts["station"]
    values = rng.normal(0, 30, (6, len(st)))  # 6 trials, as the Monte Carlo averages them
    order = pd.unique(np.concatenate([st[pts["pass"] == 0], st[pts["pass"] == 1]]))
    group = pd.Index(order).get_indexer(st)
    counts = np.bincount(group)
    m = sparse.csr_matrix((1.0 / counts[group], (group, np.arange(len(st)))), shape=(len(order), len(st)))
    g = station_groups(pts)
    np.testing.assert_array_equal(g.stations, order)
    assert np.array_equal(g.average(values), np.asarray((m @ values.T).T))  # bit for bit
    assert np.array_equal(g.average(values[0]), np.asarray(m @ values[0]))


def test_return_pass_summary_is_the_pandas_groupby_and_merge() -> None:
    rng = np.random.default_rng(3)
    pts = _points_with_return_pass(rng, 25)
    per = {"station": pts["station"], "x_mm": pts["station"] * 100.0 + rng.normal(0, 1e-3, len(pts["station"])),
           "height_um": rng.normal(0, 5, len(pts["station"]))}
    got = return_pass_summary(pts, per)
    assert got is not None
    prof = pd.DataFrame({**per, "time_s": pts["time_s"]})
    p = pts["pass"]
    fwd = prof[p == 0].reset_index(drop=True)
    ret = prof[p == 1].groupby("station", sort=False).mean(numeric_only=True).reset_index()
    both = fwd.merge(ret, on="station", suffixes=("_f", "_r"))
    d = (both["height_um_r"] - both["height_um_f"]).to_numpy()
    dt_h = (both["time_s_r"] - both["time_s_f"]).to_numpy() / 3600.0
    assert got.drift_um_per_h == pytest.approx(float(np.sum(d * dt_h) / np.sum(dt_h**2)), rel=1e-12)
    assert got.closure_um == pytest.approx(float(d[(both["station"] == 0).to_numpy()][0]), rel=1e-12)
    for c in ("station", "x_mm", "height_um"):
        np.testing.assert_allclose(got.forward[c], fwd[c].to_numpy(), rtol=1e-15)
        np.testing.assert_allclose(got.backward[c], ret[c].to_numpy(), rtol=1e-15)
    assert json.dumps(got.to_dict())  # plain numbers


def test_fft_length_and_spectrum_are_scipys() -> None:
    import scipy.fft as sf

    assert [next_fast_len(t) for t in range(1, 5000)] == [sf.next_fast_len(t, real=True) for t in range(1, 5000)]
    for t in (2**21 - 1, 2**21, 1_000_001, 64 * 2000 + 1):
        assert next_fast_len(t) == sf.next_fast_len(t, real=True)
    rng = np.random.default_rng(2)
    for n in (4, 20, 37, 200, 2000):
        x = np.arange(n) * 95.0
        h = 3.0 * np.sin(2 * np.pi * x / 700.0) + rng.normal(0, 0.2, n)
        f, amp, dx = spectrum(x, h)
        resid = h - np.polyval(np.polyfit(x, h, 1), x)
        nfft = sf.next_fast_len(n * max(1, min(64, 2**21 // n)), real=True)
        p = np.abs(sf.rfft(resid, nfft)) ** 2 / n**2
        p[1:] *= 2.0
        if nfft % 2 == 0:
            p[-1] /= 2.0
        np.testing.assert_allclose(amp, np.sqrt(2.0 * p), rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(f, sf.rfftfreq(nfft, d=dx))
