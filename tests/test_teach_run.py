"""``flexbench run`` writes the teaching page (validity atlases, worked advice) and links it
from the report; atlases are cached by code version; the run's advice never picks a model whose
independently re-measured error exceeds the tolerance, nor passes over a cheaper one that is
within it."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import reports
from reports.render import mech_atlas
from reports.run import runner, teach_run
from reports.verdicts import atlas
from reports.verdicts.pick import TIE

GRID = (5, 3)  # as conftest.teaching_run
CASE = "cantilever-tip-load"
MODELS = ["prb-1r", "bcm", "linear-8"]


def page_data(path) -> dict:
    text = path.read_text()
    return json.loads(re.search(r'id="data">(.*?)</script>', text, re.S)[1].replace("<\\/", "</"))


@pytest.fixture(scope="module")
def run(teaching_run):
    return teaching_run  # conftest.py: one small run with its teaching page


def test_report_links_the_teaching_page_with_atlases(run):
    out, res, _ = run
    assert res.report_error is None
    assert res.paths["teaching.html"] == out / "teaching.html"
    html, md = (out / "report.html").read_text(), (out / "report.md").read_text()
    assert 'href="teaching.html"' in html and "teaching.html" in md
    data = page_data(out / "teaching.html")
    assert set(data["atlas"]) == set(atlas.FAMILIES)
    force = data["atlas"]["force"]
    assert len(force["mags"]) == GRID[0] and len(force["angles"]) == GRID[1]
    assert set(force["models"]) == set(atlas.MODELS)
    assert {(a["case"], a["tol"]) for a in data["advice"]} == {(CASE, t) for t in ("1%", "0.1%")}
    assert data["shapes"]["models"] and data["cost"]["families"]
    assert set(data["mech_atlas"]) == set(mech_atlas.TEACH_CASES)
    assert (out / mech_atlas.FILE).is_file()  # the report's case sections show them too
    assert f"{GRID[0]} load magnitudes x {GRID[1]} directions" in data["note"]


def test_atlases_are_cached_by_code_version(run, tmp_path):
    import cases

    out, _, kw = run
    cached = sorted(p.name for p in (out / teach_run.CACHE_DIR).glob("*.json"))
    assert len(cached) == len(teach_run.parts())
    again = runner.run_matrix([cases.load(CASE)], MODELS, out, **kw)
    assert again.solved == 0  # resumed pairs ...
    assert "reused from teaching-cache" in page_data(out / "teaching.html")["note"]  # atlases too
    assert sorted(p.name for p in (out / teach_run.CACHE_DIR).glob("*.json")) == cached
    jobs, hits = teach_run.plan_jobs(out, GRID, "another-code-version")
    assert not hits and len(jobs) == len(teach_run.parts())


def path_error(model: str, reference) -> float:
    """Largest |d ux|/L, |d uy|/L, |d rot| over the path, from separate solves (no run code)."""
    import cases

    sol = reports.solve(cases.load(CASE), model)
    if sol.status != "converged":
        return np.inf
    worst = 0.0
    for s, r in zip(sol.steps, reference.steps, strict=True):
        assert s.factor == pytest.approx(r.factor)
        worst = max(worst, *(abs(s.outputs[k] - r.outputs[k]) for k in ("tip.ux", "tip.uy")))
        worst = max(worst, abs(s.outputs["tip.rot"] - r.outputs["tip.rot"]))
    return worst  # L = 1


def test_run_advice_agrees_with_independent_errors(run):
    import cases

    out, res, _ = run
    reference = reports.solve(cases.load(CASE), "elastica")
    errs = {m: path_error(m, reference) for m in MODELS} | {"elastica": 0.0}  # exact: the ref
    est = {r["model"]: r["cost"] for r in res.payload["results"] if r.get("cost")}
    assert set(est) == {*MODELS, "elastica"}  # the runner's shared estimates

    def beyond_noise(m: str, pick: str) -> bool:  # m cheaper than pick by more than a tie
        band = max(TIE * est[m]["cpu_s"], est[m]["noise_s"] + est[pick]["noise_s"])
        return est[pick]["cpu_s"] - est[m]["cpu_s"] > band

    for a in page_data(out / "teaching.html")["advice"]:
        tol = float(a["tol"].rstrip("%")) / 100
        pick = a["recommended"]
        if pick is not None:
            assert errs[pick] <= tol * (1 + 1e-9), (a["tol"], pick, errs[pick])
            cheaper = [m for m in errs if beyond_noise(m, pick)]
        else:
            cheaper = list(errs)
        for m in cheaper:  # none of them is within the tolerance
            assert errs[m] > tol, (a["tol"], pick, m, errs[m])
