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
def test_page_in_headless_chromium(page):
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
    models = sum(len(f[1]) for f in teaching.FAMILIES.values())
    assert verdict["atlases"] == 3 * models  # force, follower, moment per model
    mech = data_of(page)["mech_atlas"]["das2d-ex2-parallelogram"]
    assert verdict["mech_atlases"] == len(mech["models"])  # one re-coloured canvas per model
    console = [ln for ln in res.stderr.splitlines() if "CONSOLE" in ln and "ERROR" in ln.upper()]
    assert not console, console
