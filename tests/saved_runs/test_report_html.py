"""The HTML builder escapes text and embeds images; the environment summary is min/max/mean/start/end."""

from __future__ import annotations

import base64
import math
import re

import pandas as pd
import pytest

from saved_runs.report.common import environment_summary
from saved_runs.report.html import HtmlPage, fmt


def test_page_is_self_contained_and_escaped() -> None:
    page = HtmlPage("Run <1> & co")
    page.heading("A <b>")
    page.table(("name", "value"), [("x<y", 1.23456), ("nan", math.nan), ("none", None)], digits=2)
    png = b"\x89PNG\r\n\x1a\nfake"
    page.image(png, "plot \"quoted\"")
    doc = page.render()
    assert "<title>Run &lt;1&gt; &amp; co</title>" in doc and "<h2>A &lt;b&gt;</h2>" in doc
    assert "<td>1.23</td>" in doc and doc.count("<td>—</td>") == 2 and "x&lt;y" in doc
    (data,) = re.findall(r'src="data:image/png;base64,([^"]+)"', doc)
    assert base64.b64decode(data) == png
    assert "http://" not in doc and "https://" not in doc  # nothing to fetch


@pytest.mark.parametrize(("v", "s"), [(True, "yes"), (3, "3"), (2.0, "2.000"), (math.inf, "—"), ("t", "t"),
                                         (-1e-9, "0.000"), (-0.0005, "-0.001")])
def test_fmt(v: object, s: str) -> None:
    assert fmt(v) == s


def test_environment_summary() -> None:
    df = pd.DataFrame({"air_temp_c": [20.1, 20.4, 20.2], "humidity_pct": [40.0, float("nan"), 44.0]})
    rows = {r["column"]: r for r in environment_summary(df)}
    assert set(rows) == {"air_temp_c", "humidity_pct"}
    t = rows["air_temp_c"]
    assert (t["min"], t["max"], t["start"], t["end"]) == (20.1, 20.4, 20.1, 20.2)
    assert t["mean"] == pytest.approx((20.1 + 20.4 + 20.2) / 3)
    assert rows["humidity_pct"]["mean"] == 42.0
