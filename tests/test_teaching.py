"""The teaching page opens from disk in headless Chromium with no errors, and its tolerance and
load sliders change the drawings (the page's own ``#selftest`` moves them and reports)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import pytest

from reports.render import teaching

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def run_page(teaching_run):
    """The page as ``flexbench run`` writes it (atlases as pool jobs, advice from the run)."""
    return teaching_run[0] / "teaching.html"


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    data = teaching.build_data(
        ["cantilever-tip-load"],
        ("1%",),
        n_mag=6,
        n_ang=5,
        workers=1,
        cost_ns=(1, 2, 4),
        mech_cases=("das2d-ex2-parallelogram",),
        mech_n_axis=3,
    )
    return teaching.write_page(data, tmp_path_factory.mktemp("teach") / "teaching.html")


def data_of(page) -> dict:
    text = page.read_text()
    return json.loads(re.search(r'id="data">(.*?)</script>', text, re.S)[1].replace("<\\/", "</"))


def test_page_is_self_contained(page):
    text = page.read_text()
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", text), "no network resources"
    assert "<script src" not in text and "<link" not in text
    data = json.loads(re.search(r'id="data">(.*?)</script>', text, re.S)[1].replace("<\\/", "</"))
    assert set(data["atlas"]) == {"force", "follower", "moment"}
    assert data["advice"][0]["recommended"] and data["shapes"]["models"]
    assert data["mech_atlas"]["das2d-ex2-parallelogram"]["models"]
    assert (page.parent / "mech_atlas.json").is_file()


@pytest.mark.skipif(CHROMIUM is None, reason="Debian chromium not installed (.ci/run installs it)")
@pytest.mark.parametrize("which", ["page", "run_page"])
def test_page_in_headless_chromium(which, request):
    page = request.getfixturevalue(which)
    cmd = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--enable-logging=stderr",
        "--virtual-time-budget=5000",
        "--dump-dom",
        f"file://{page}#selftest",
    ]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="selftest">(.*?)</pre>', res.stdout, re.S)
    assert m and m[1].strip(), f"self-test did not run: {res.stderr[-2000:]}"
    verdict = json.loads(m[1])
    assert verdict["errors"] == []
    assert verdict["tolerance_changes_atlas"] and verdict["load_changes_shapes"]
    data = data_of(page)
    # one canvas per (family, model) atlas where the model solved any state; declined
    # atlases are named in one line instead
    drawn = sum(
        any(v is not None for row in A["models"][m]["error"] for v in row)
        for F in data["families"]
        for m in F["models"]
        for A in data["atlas"].values()
        if m in A["models"]
    )
    assert verdict["atlases"] == drawn > 0
    mech = data_of(page)["mech_atlas"].values()
    # one re-coloured canvas per model of every mechanism atlas that solved any state
    solved = [
        v
        for m in mech
        for v in m.get("models", {}).values()
        if any(e is not None for row in v["error"] for e in row)
    ]
    assert verdict["mech_atlases"] == len(solved) > 0
    console = [ln for ln in res.stderr.splitlines() if "CONSOLE" in ln and "ERROR" in ln.upper()]
    assert not console, console


def test_page_teaches_first_and_every_heading_is_linked(page):
    text = page.read_text()
    head = text[: text.index('id="data"')]
    ids = set(re.findall(r'id="([^"]+)"', head))
    links = re.findall(r'href="#([^"]+)"', head)
    assert "where-prb-1r-stops" in ids and "where-prb-1r-stops" in links
    assert set(links) <= ids, set(links) - ids  # every in-page link resolves
    heads = re.findall(r'<h[23] id="([^"]+)"', head)
    contents = head[head.index('<nav id="contents">') : head.index("</nav>")]
    assert all(f'href="#{h}"' in contents for h in heads)  # the contents list has them all
    order = [
        head.index(f'id="{h}"')
        for h in (
            "the-short-answer-where-each-model-stops",
            "which-model-for-each-catalog-case",
            "what-each-model-costs",
        )
    ]
    assert order == sorted(order)  # the story first, costs last
    # the load slider sits beside the shapes it moves
    assert 0 < head.index('id="shape"') - head.index('id="load"') < 1000
    # verdicts are tables, not terminal text
    adv = head[head.index('id="advice-cantilever-tip-load"') :]
    assert "<table>" in adv[: adv.index("</details>")] and "<pre>" not in adv
