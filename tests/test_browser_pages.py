"""Both pages of a run in headless Chromium at 1400 px: every in-page anchor resolves, nothing
is wider than the window, and the report's answer (one pick row per case, a sweep one row)
ends within two screens however many sweep points a run has."""

from __future__ import annotations

import copy
import json
import shutil

import pytest

from reports.bench import browser
from reports.render import build_document
from reports.render.html import to_html

pytestmark = pytest.mark.skipif(
    browser.find_chromium() is None, reason="no chromium (CI installs Debian's chromium)"
)


@pytest.mark.parametrize("page", ["report.html", "teaching.html"])
def test_page_anchors_resolve_and_nothing_overflows_at_1400px(teaching_run, page):
    out = teaching_run[0]
    res = browser.check_report(out / page)
    assert res.ok, res.summary()  # console, network, anchors, images, overflow
    assert res.missing_anchors == [] and res.overflow_px == 0, res.summary()
    html = (out / page).read_text()
    assert res.n_links == html.count('href="#')  # every in-page link was checked
    if page == "report.html":
        assert res.n_links >= 8 and {"pick", "accuracy", "overall", "time"} <= set(res.section_tops)


def test_planted_overflow_and_dead_anchor_are_caught(teaching_run, tmp_path):
    out = teaching_run[0]
    bad = tmp_path / "bad"
    shutil.copytree(out, bad, ignore=shutil.ignore_patterns("paraview", "teaching-cache"))
    html = (out / "report.html").read_text()
    planted = html.replace(
        "</main>",
        '<div id="wide" style="width:3000px">x</div><a href="#nowhere">dead</a></main>',
    )
    (bad / "report.html").write_text(planted)
    res = browser.check_report(bad / "report.html")
    assert not res.ok
    assert res.missing_anchors == ["#nowhere"]
    assert res.overflow_px >= 3000 - browser.VIEWPORT[0]
    assert any(w.startswith("div#wide") for w in res.wide_elements), res.wide_elements


def _with_sweep(payload: dict, case: str, n: int) -> dict:
    """``payload`` with ``n`` copies of ``case`` as the points of one sweep (the case's
    records copied to each point): 5 x 5 x 5 points like thesis-sixbar-config4's."""
    data = copy.deepcopy(payload)
    recs = [r for r in payload["results"] if r["case"] == case]
    for i in range(n):
        name = f"many-points/p{i:03d}"
        point = {"a.k1": float(i % 5), "a.k2": float(i // 5 % 5), "a.k3": float(i // 25)}
        meta = {**payload["cases"][case], "name": name}
        data["cases"][name] = meta | {"sweep": {"parent": "many-points", "point": point}}
        data["results"] += [{**r, "case": name, "key": f"{name}|{r['model']}"} for r in recs]
    return data


def test_front_page_fits_two_screens_with_125_sweep_points(teaching_run):
    """The old pick table had a row per sweep point (250 rows for the default run); the
    answer now ends within two screens, and the planted sweep is one row of each table."""
    out = teaching_run[0]
    payload = json.loads((out / "results.json").read_text())
    data = _with_sweep(payload, "cantilever-tip-load", 125)
    page = out / "front-many-points.html"
    page.write_text(to_html(build_document(data, {}), "FlexBench report"))
    res = browser.check_report(page)
    assert not res.missing_anchors and res.overflow_px == 0, res.summary()
    assert res.section_tops["accuracy"] <= browser.FRONT_PAGE_MAX_PX, res.section_tops
    html = page.read_text()
    assert html.count('href="#case-many-points"') == 3  # pick row, map row, contents
    assert "p124" not in html.split('id="accuracy"')[0]  # no point row on the front page
