"""A run folder as DataFrames (``reports.load_run``) and the sweep columns of results.csv."""

import itertools
import json
import sqlite3

import numpy as np
import pandas as pd
import pytest

import cases
import reports
from cases.sweep import expand
from reports.run import runner, store, sweep

P, L, EI = 10.0, 1.0, 1.0  # cases/catalog/cantilever-tip-load.toml


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("frames-run")
    kw = dict(quick=True, workers=1, render=False, progress=False, export=None)
    runner.run_matrix([cases.load("cantilever-tip-load")], ["linear-1"], out, **kw)
    return reports.load_run(out)


def test_load_run_steps_hold_the_closed_form_tip_deflection(run):
    pair = run.path("cantilever-tip-load", "linear-1")
    f = pair["factor"].to_numpy()
    assert f[-1] == 1.0 and list(pair["step"]) == list(range(len(f)))
    np.testing.assert_allclose(pair["tip.uy"], -f * P * L**3 / (3 * EI), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(pair["tip.rot"], -f * P * L**2 / (2 * EI), rtol=1e-9, atol=1e-12)
    tidy = run.steps.query("model == 'linear-1' and output == 'tip.uy'")
    np.testing.assert_allclose(tidy["value"], pair["tip.uy"])
    with pytest.raises(KeyError, match="no steps"):
        run.path("cantilever-tip-load", "prb-9r")


def test_load_run_tables(run):
    # linear-1, the reference (elastica) and the speed baseline
    assert set(run.results["model"]) >= {"linear-1", "elastica"}
    assert run.results.set_index("model").loc["linear-1", "status"] == "converged"
    assert set(run.errors["model"]) >= {"linear-1"}
    assert run.cases.set_index("case").loc["cantilever-tip-load", "units"] == "nondim"
    assert set(run.history["model"]) == set(run.results["model"])
    assert reports.load_run(run.folder / "results.json").folder == run.folder


def test_load_run_without_results_says_so(tmp_path):
    with pytest.raises(FileNotFoundError, match="no results.json"):
        reports.load_run(tmp_path)


def test_results_csv_has_the_sweep_parameters_as_columns(tmp_path):
    scene = cases.load("thesis-sixbar-config2-sweep-rest")
    points = expand(scene)
    metas = {p.name: sweep.point_meta(p) for p in points} | {"cantilever-tip-load": {}}
    records = [{"case": n, "model": "kinetostatic", "status": "converged"} for n in metas]
    df = pd.read_csv(store.write_csv(tmp_path / "results.csv", records, metas))
    # the grid of cases/catalog/thesis-sixbar-config2-sweep-rest.toml
    keys = [f"torsion_springs.S{i}.rest_angle_deg" for i in (1, 2, 3)]
    assert list(df.columns[-4:]) == ["sweep_parent", *keys]
    grid = set(itertools.product((20.0, 30.0, 40.0), (110.0, 120.0, 130.0), (20.0, 30.0, 40.0)))
    swept = df[df["sweep_parent"] == scene.name]
    assert set(map(tuple, swept[keys].to_numpy())) == grid and len(swept) == len(grid) == 27
    assert df.set_index("case").loc["cantilever-tip-load", keys].isna().all()


def test_report_footer_names_loaders_that_work(run):
    from reports.render.document import environment_blocks

    payload = json.loads((run.folder / "results.json").read_text())
    text = " ".join(b[1] for b in environment_blocks(payload) if b[0] == "p")
    assert "pandas.read_csv('results.csv')" in text and "reports.load_run('.')" in text
    with pytest.raises(ValueError):  # as the footer says: results.json is not a flat table
        pd.read_json(run.folder / "results.json")
    with sqlite3.connect(run.folder / "history.sqlite") as con:
        assert len(pd.read_sql_query("SELECT * FROM results", con)) == len(run.results)
