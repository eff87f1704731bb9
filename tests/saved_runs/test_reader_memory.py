"""Reading a long run holds the points once as numbers, not as a list of rows of strings."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import numpy as np

from processing.columns import STRAIGHTNESS_POINTS_V2
from saved_runs.store.reader import load_run


def test_a_50000_point_run_is_read_in_bounded_memory(tmp_path: Path) -> None:
    n = 50_000
    rng = np.random.default_rng(0)
    cols = list(STRAIGHTNESS_POINTS_V2)
    values = rng.normal(0.0, 100.0, (n, len(cols)))
    values[:, cols.index("station")] = np.arange(n)
    values[:, cols.index("pass")] = 0
    values[:, cols.index("not_still")] = 0
    lines = [",".join(cols)] + [",".join(repr(float(v)) for v in row) for row in values]
    run = tmp_path / "run"
    run.mkdir()
    (run / "points.csv").write_text("\n".join(lines) + "\n")
    (run / "run.json").write_text(json.dumps({"format": "guideway-run", "version": 2, "kind": "straightness",
                                              "status": "complete", "setup": {}}))
    size_mb = (run / "points.csv").stat().st_size / 1e6
    del lines
    tracemalloc.start()
    try:
        loaded = load_run(run)
        peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()
    got = loaded.points[cols].to_numpy(dtype=float)
    assert np.array_equal(got, values)  # every value read back exactly
    # the text (~12 MB) and its lines once, the numbers (3 MB) twice; a list of rows of strings was ~110 MB
    assert peak_mb < 5 * size_mb, f"read {size_mb:.0f} MB of points with a peak of {peak_mb:.0f} MB"
