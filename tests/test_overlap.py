"""Figures drawn in the solving pool while a run solves (reports/run/overlap.py)."""

from __future__ import annotations

import copy
import re

import pytest

from reports.run import overlap, runner, store
from tests.test_report import MODELS, PNG, dummies  # noqa: F401  (fixture)
from tests.test_runner import dummy_scene


@pytest.fixture
def spy(monkeypatch):
    """The EarlyFigures of the run, with each queued job's case and records kept."""
    made = []

    class Spy(overlap.EarlyFigures):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.jobs: dict[str, tuple] = {}
            made.append(self)

        def pair_done(self, rec, queue):
            n = len(queue)
            super().pair_done(rec, queue)
            if len(queue) > n:
                self.jobs[queue[0]["case"]] = copy.deepcopy(queue[0]["args"])  # as sent

    monkeypatch.setattr(overlap, "EarlyFigures", Spy)
    return made


def test_case_figures_drawn_while_solving_equal_the_final_ones(dummies, spy, tmp_path):  # noqa: F811
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    res = runner.run_matrix(scenes, MODELS, tmp_path, workers=2, render_shapes=False)
    assert res.report_error is None
    (early,) = spy
    assert sorted(early.figures) == sorted(early.jobs) == ["dummy-a", "dummy-b"]
    for name, (_, case, recs, *_rest) in early.jobs.items():
        # the case's errors and records as the final payload has them (grades come later)
        assert case == res.payload["cases"][name]
        final = [r for r in res.payload["results"] if r["case"] == name]
        assert [{k: v for k, v in r.items() if k != "grade"} for r in final] == recs
        for kind in ("pareto", "path", "shapes"):
            assert (tmp_path / early.figures[name][kind]).read_bytes()[:8] == PNG
    html = (tmp_path / "report.html").read_text()
    assert "figures/dummy-a-pareto.png" in html and "figures/dummy-b-path.png" in html


def test_sweep_points_are_planned_last_and_get_no_figure_job(tmp_path):
    import collections

    import cases

    scenes = [cases.load("thesis-sixbar-config4-sweep-rest"), cases.load("thesis-sixbar-config4")]
    tasks, _, metas = runner.plan(scenes, quick=True)
    is_point = [t["scene"].sweep_parent is not None for t in tasks]
    assert any(is_point) and is_point == sorted(is_point)  # every point after every case
    queue: collections.deque = collections.deque()
    early = overlap.EarlyFigures(tasks, [], metas, tmp_path)
    for t in tasks:
        base = {k: t[k] for k in ("key", "case", "model", "role")}
        early.pair_done(store.record(base, "failed", "not solved in this test"), queue)
    assert [j["case"] for j in queue] == ["thesis-sixbar-config4"]


def test_sweep_points_are_one_section_with_a_row_each(tmp_path):
    from reports.render import build_document
    from reports.render.html import to_html
    from tests.test_stability_report import small_sweep

    res = runner.run_matrix(
        [small_sweep()], ["kinetostatic"], tmp_path, workers=1, export=None, render=False
    )
    html = to_html(build_document(res.payload, {}), "t")
    assert html.count("<h2") - html.count("Sweep thesis-sixbar") < 10  # no section per point
    assert html.count("Sweep thesis-sixbar-config4-sweep-rest: 8 points") == 1
    for r in res.payload["results"]:  # every point's row holds each model's numbers
        assert f"<td>{r['case'].rsplit('/', 1)[-1]}</td>" in html
    ids = set(re.findall(r'id="([^"]+)"', html))
    assert set(re.findall(r'href="#([^"]+)"', html)) <= ids  # points link to the sweep


def test_final_scenes_are_rendered_at_the_end_not_in_the_pool(dummies, spy, tmp_path):  # noqa: F811
    # a pyvista render keeps VTK (~240 MB) in the process that draws it: figure jobs must
    # not render; the final render draws those cases' scenes (render/scenes.py)
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    res = runner.run_matrix(scenes, MODELS, tmp_path, workers=2, render_shapes=True)
    assert res.report_error is None
    (early,) = spy
    assert sorted(early.jobs) == ["dummy-a", "dummy-b"]
    assert all(args[5] is None for args in early.jobs.values())  # no backend in the pool
    html = (tmp_path / "report.html").read_text()
    for name in ("dummy-a", "dummy-b"):
        assert "render" not in early.figures[name] or early.figures[name]["render"] is None
        assert f"figures/{name}-render.png" in html
        assert (tmp_path / "figures" / f"{name}-render.png").read_bytes()[:8] == PNG
