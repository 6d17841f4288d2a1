"""Report, store and compare on a small matrix of dummy models with known errors."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import sqlite3

import numpy as np
import pytest

from reports import cli
from reports.render import build_document, figures, paths
from reports.run import compare, runner, store
from tests.test_runner import DUMMIES, EPS, P, dummy_scene

MODELS = ["dummy-scaled", "dummy-half", "dummy-crash", "dummy-na"]
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def dummies(monkeypatch):
    from reduced_models import registry

    for name, target in DUMMIES.items():
        monkeypatch.setitem(registry.MODELS, name, target)


def _scaled(name: str, scale: float):
    """The dummy case with another ``scale`` option for ``dummy-scaled`` (a worse model)."""
    sc = dummy_scene(name)
    spec = dataclasses.replace(sc.models[0], options={"scale": scale})
    return dataclasses.replace(sc, models=(spec,))


@pytest.fixture
def run(dummies, tmp_path):
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    return runner.run_matrix(scenes, MODELS, tmp_path / "run", workers=1)


def test_report_files_and_content(run):
    out = run.out_dir
    assert run.report_error is None
    html = (out / "report.html").read_text()
    md = (out / "report.md").read_text()
    for case in ("dummy-a", "dummy-b"):
        for kind in ("path", "shapes", "pareto"):
            png = out / "figures" / f"{case}-{kind}.png"
            assert png.read_bytes()[:8] == PNG, png
    # one speed-against-error chart per family of cases (the dummies are single beams)
    assert (out / "figures" / "overall-beams-pareto.png").read_bytes()[:8] == PNG
    # every figure the pages link exists
    for src in re.findall(r'<img src="([^"]+)"', html) + re.findall(r"\]\(([^)]+\.png)\)", md):
        assert (out / src).exists(), src
    for text in (html, md):
        assert "Run environment" in text and "git commit" in text and "CPU" in text
        assert "Dummy cantilever dummy-a" in text
        assert "P L^3 / (3 EI) with P = 0.3" in text  # provenance of the reference
        assert "the dummy reference is exactly linear theory" in text  # tolerance rationale
        assert "Model cards" in text and "test dummy: linear cantilever tip formula" in text
        assert "RuntimeError: boom in the dummy" in text  # failures are listed
        assert "dummy declines every scene" in text  # not-applicable reason
        assert "reached 50% of the reference path" in text
        assert f"{EPS:.1e}" in text  # the scaled model's error on its own scale
    assert "FAIL 1.0e-02" in html and "pass " in html


def test_store_csv_and_sqlite_history(run, dummies):
    out = run.out_dir
    rows = (out / "results.csv").read_text().splitlines()
    assert rows[0].split(",") == list(store.CSV_COLUMNS + store.GRADE_COLUMNS)
    assert len(rows) == 1 + 10
    again = runner.run_matrix(
        [dummy_scene("dummy-a"), dummy_scene("dummy-b")], MODELS, out, workers=1, render=False
    )
    assert again.resumed == 10
    con = sqlite3.connect(out / "history.sqlite")
    try:  # a resumed run replaces its own rows
        assert con.execute("SELECT COUNT(*) FROM runs").fetchone()[0] == 1
        assert con.execute("SELECT COUNT(*) FROM results").fetchone()[0] == 10
    finally:
        con.close()
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    runner.run_matrix(scenes, MODELS, out, workers=1, render=False, fresh=True)
    con = sqlite3.connect(out / "history.sqlite")
    try:  # a fresh run is a new run
        assert con.execute("SELECT COUNT(*) FROM runs").fetchone()[0] == 2
        assert con.execute("SELECT COUNT(*) FROM results").fetchone()[0] == 20
        (err,) = con.execute(
            "SELECT error_rel FROM results WHERE case_name = 'dummy-a'"
            " AND model = 'dummy-scaled' ORDER BY run_id DESC"
        ).fetchone()
        commit = con.execute("SELECT cpu, python FROM runs WHERE id = 1").fetchone()
    finally:
        con.close()
    assert err == pytest.approx(EPS)
    assert all(commit)
    hist = store.history_rows(out / "history.sqlite", "dummy-a", "dummy-scaled")
    assert [h[3] for h in hist] == ["converged", "converged"]


def test_compare_identical_passes_and_injected_regressions_fail(run, dummies, tmp_path, capsys):
    base = run.out_dir / "results.json"
    assert cli.main(["compare", str(base), str(base)]) == 0
    assert "no regression" in capsys.readouterr().out

    # a real regression through the whole pipeline: the model gets 3x worse
    worse = runner.run_matrix(
        [_scaled("dummy-a", 1 + 3 * EPS), dummy_scene("dummy-b")], MODELS, tmp_path / "w",
        workers=1, render=False,
    )  # fmt: skip
    assert cli.main(["compare", str(base), str(worse.paths["results.json"])]) == 1
    out = capsys.readouterr().out
    assert "REGRESSION" in out and "dummy-scaled" in out and "error grew" in out
    assert "dummy-b" not in out.split("REGRESSION")[1].split("note:")[0]  # only dummy-a

    # a status regression and a lost published-reference pass, injected in the JSON
    data = json.loads(base.read_text())
    for rec in data["results"]:
        if rec["case"] == "dummy-b" and rec["model"] == "dummy-exact":
            rec["refchecks"][0]["passed"] = False
        if rec["case"] == "dummy-a" and rec["model"] == "dummy-scaled":
            rec["status"], rec["message"] = "failed", "diverged"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    result = compare.compare(store.read_results(base), store.read_results(bad))
    reasons = {(r["case"], r["model"]): r["reason"] for r in result.regressions}
    assert reasons[("dummy-a", "dummy-scaled")].startswith("status converged -> failed")
    assert "no longer passes" in reasons[("dummy-b", "dummy-exact")]

    # growth inside the tolerance is not a regression; a subset run gives notes only
    data = json.loads(base.read_text())
    for rec in data["results"]:
        for k, v in ((rec.get("errors") or {}).get("per_output") or {}).items():
            rec["errors"]["per_output"][k] = None if v is None else v * 1.2
    data["results"] = [r for r in data["results"] if r["case"] == "dummy-a"]
    slight = tmp_path / "slight.json"
    slight.write_text(json.dumps(data))
    result = compare.compare(store.read_results(base), store.read_results(slight))
    assert result.ok and any("only in BASE: dummy-b" in n for n in result.notes)


def test_rerender_from_results_json(run, capsys):
    shutil.rmtree(run.out_dir / "figures")
    (run.out_dir / "report.html").unlink()
    assert cli.main(["report", str(run.out_dir)]) == 0
    assert (run.out_dir / "report.html").exists()
    assert (run.out_dir / "figures" / "dummy-a-path.png").exists()
    # `report` without --pyvista draws the render with matplotlib (no VTK needed)
    assert (run.out_dir / "figures" / "dummy-a-render.png").read_bytes()[:8] == PNG


def test_hooks_error_bars_history_and_pareto_front(tmp_path):
    steps = [{"factor": f, "outputs": {"tip.ux": -f / 10, "tip.uy": -f / 3, "tip.rot": -f / 2}}
             for f in (0.0, 0.5, 1.0)]  # fmt: skip
    ref = {"model": "fem-auto", "status": "converged", "steps": steps, "shapes": {},
           "extras": {"error_estimate": {"tip.uy": [0.0, 1e-3, 2e-3], "tip.rot": 1e-3},
                      "history": {"t": [0, 1, 2], "tip.uy": [0, -0.2, -0.33]}}}  # fmt: skip
    other = {**ref, "model": "m", "extras": {}}
    meta = {"primary_output": "tip", "units": "nondim"}
    cmap = figures.colours(["fem-auto", "m"])
    assert paths.path_figure(meta, [ref, other], "fem-auto", cmap, tmp_path / "p.png")
    assert paths.history_figure(meta, [ref], tmp_path / "h.png")
    assert paths.history_figure(meta, [other], tmp_path / "none.png") is None
    pts = [(1.0, 0.5), (2.0, 0.1), (3.0, 0.2), (0.5, 0.9), (2.0, 0.05)]
    assert figures.pareto_front(pts) == [3, 0, 4]


def test_report_when_every_judged_model_fails(dummies, tmp_path):
    res = runner.run_matrix([dummy_scene()], ["dummy-crash", "dummy-na"], tmp_path, workers=1)
    assert res.report_error is None
    text = (tmp_path / "report.md").read_text()
    assert "dummy-crash" in text
    blocks = build_document(res.payload, {})
    assert blocks[0] == ("h1", "FlexBench report")


def test_real_models_on_a_catalog_case(tmp_path):
    """The pipeline with real models: the elastica reference reproduces Mattiasson's table
    (published values, checked at load factors 0.1 and 1 that the quick grid must keep), and
    linear theory at PL^2/EI = 10 is off by more than twice the tip's own motion (10/3 L
    against 0.81 L of the exact tip deflection)."""
    import cases

    scene = cases.load("cantilever-tip-load")
    res = runner.run_matrix([scene], ["linear-1"], tmp_path, workers=1, quick=True)
    recs = {r["model"]: r for r in res.payload["results"]}
    assert res.payload["cases"]["cantilever-tip-load"]["reference"] == "elastica"
    checks = recs["elastica"]["refchecks"]
    assert len(checks) == len(scene.references) and all(c["passed"] for c in checks)
    assert recs["linear-1"]["summary_basis"] == "path"
    assert recs["linear-1"]["errors"]["per_output"]["tip.uy"] > 2.0
    assert (tmp_path / "figures" / "cantilever-tip-load-path.png").exists()


# -- ParaView files, renders and the replay animation ------------------------------------------
GIF = b"GIF89a"


def _nonwhite_fraction(png) -> float:
    import matplotlib.image as mpimg

    img = mpimg.imread(png)[..., :3]
    return float((img.min(axis=-1) < 0.9).mean())


def test_paraview_series_of_the_reference_hold_its_closed_form_shapes(run):
    """The reference (dummy-exact: y = uy (3 s^2 - s^3) / 2, uy = -lambda P L^3 / 3EI) is
    exported per step: the last VTU, the PVD's step count and the XDMF displacement field all
    give the closed-form tip (1, -0.1); a judged model (dummy-scaled) exports nothing."""
    import meshio

    out = run.out_dir
    recs = {(r["case"], r["model"]): r for r in run.payload["results"]}
    ex = recs[("dummy-a", "dummy-exact")]["exports"]["paraview"]
    assert ex["n_vtu"] == 9  # 8 load steps + the unloaded state
    assert recs[("dummy-a", "dummy-scaled")]["exports"] == {}
    assert not (out / "paraview" / "dummy-a" / "dummy-scaled").exists()
    pvd = (out / ex["pvd"]).read_text()
    files = re.findall(r'file="([^"]+)"', pvd)
    assert len(files) == 9
    last = meshio.read(out / ex["dir"] / files[-1])
    assert last.cells[0].type == "line" and last.points.shape == (11, 3)
    s = np.linspace(0.0, 1.0, 11)
    exact = np.column_stack([s, -P / 3 * (3 * s**2 - s**3) / 2, 0 * s])
    np.testing.assert_allclose(last.points, exact, atol=1e-12)
    with meshio.xdmf.TimeSeriesReader(out / ex["xdmf"]) as reader:
        points, _ = reader.read_points_cells()
        assert reader.num_steps == 9
        _, pdata, _ = reader.read_data(reader.num_steps - 1)
    np.testing.assert_allclose(points + pdata["displacement"], exact, atol=1e-12)
    assert pdata["load_factor"][0] == pytest.approx(1.0)
    # the report links both files
    for text in ((out / "report.html").read_text(), (out / "report.md").read_text()):
        assert ex["pvd"] in text and ex["xdmf"] in text and "ParaView files" in text


def test_render_of_the_final_scene_is_in_the_report(run):
    out = run.out_dir
    html, md = (out / "report.html").read_text(), (out / "report.md").read_text()
    for case in ("dummy-a", "dummy-b"):
        png = out / "figures" / f"{case}-render.png"
        assert png.read_bytes()[:8] == PNG
        assert f'src="figures/{case}-render.png"' in html and f"(figures/{case}-render.png)" in md
        assert 0.001 < _nonwhite_fraction(png) < 0.5  # something drawn, not a blank or a blot


def test_render_figure_argument_order_and_fallback(tmp_path):
    """``render_png(path, shapes, reference_shapes, title)``: the old hook passed (shapes,
    path); the matplotlib backend draws the deformed beam where its closed form says."""
    s = np.linspace(0.0, 1.0, 11)
    rec = {"model": "ref", "shapes": {"beam": np.column_stack([s, -0.5 * s**2]).tolist()}}
    meta = {"name": "c", "undeformed": {"beam": [[0.0, 0.0], [1.0, 0.0]]}}
    png = figures.render_figure(meta, rec, tmp_path / "r.png", backend="matplotlib")
    assert png == tmp_path / "r.png" and png.read_bytes()[:8] == PNG
    assert _nonwhite_fraction(png) > 0.001
    assert figures.render_figure(meta, {"model": "ref", "shapes": {}}, tmp_path / "n.png") is None


def test_replay_writes_series_and_a_small_gif_but_not_in_quick_mode(dummies, tmp_path):
    """A real replay on the tiny dummy cantilever: full mode writes its settled-state and
    time-history series plus a GIF that the report embeds; --quick writes the series of the
    settled states only.  The exported last settled state is the solution's own tip."""
    import meshio
    from PIL import Image

    once = runner.TimingPolicy(min_total_s=0.0, max_runs=1, cold_cap_s=0.0, min_runs=1)
    scene = dummy_scene("dummy-replay")
    quick = runner.run_matrix([scene], ["replay"], tmp_path / "q", workers=1, quick=True,
                              timing=once)  # fmt: skip
    rq = {r["model"]: r for r in quick.payload["results"]}["replay"]
    assert rq["status"] == "converged", rq["message"]
    assert set(rq["exports"]) == {"paraview", "export_s"}
    assert not list((tmp_path / "q" / "figures").glob("*.gif"))
    assert not list((tmp_path / "q" / "figures").glob("*-render.png"))

    full = runner.run_matrix([scene], ["replay"], tmp_path / "f", workers=1, timing=once)
    out = tmp_path / "f"
    rec = {r["model"]: r for r in full.payload["results"]}["replay"]
    ex = rec["exports"]
    assert ex["animation"] == "figures/dummy-replay-replay.gif"
    gif = out / ex["animation"]
    assert gif.read_bytes()[:6] == GIF
    with Image.open(gif) as im:
        assert 2 <= im.n_frames <= runner.DEFAULT_EXPORT.gif_frames
        assert im.size[0] <= 400  # small: 5 in at the GIF dpi
    assert 2 <= ex["paraview_frames"]["n_vtu"] <= runner.DEFAULT_EXPORT.max_frames
    last = meshio.read(out / ex["paraview"]["dir"] / f"dummy-replay_replay_{8:04d}.vtu")
    tip = rec["steps"][-1]["outputs"]
    np.testing.assert_allclose(last.points[-1, :2], [tip["tip.x"], tip["tip.y"]], atol=1e-9)
    html = (out / "report.html").read_text()
    assert f'<img src="{ex["animation"]}"' in html
    assert html.index("dummy-replay-time-history.png") < html.index(ex["animation"])
    assert ex["paraview_frames"]["pvd"] in html
