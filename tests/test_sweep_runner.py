"""Sweep cases in the runner: one stored row per grid point and model, points carry their
coordinates, parent-named models only (no default list per point)."""

from __future__ import annotations

import cases
from reports.run import runner


def test_plan_expands_points():
    scene = cases.load("thesis-sixbar-config4-sweep-rest")
    tasks, fixed, metas = runner.plan([scene], models=["thesis-force-method"])
    assert len(tasks) + len(fixed) >= 125
    names = {t["case"] for t in tasks if t["model"] == "thesis-force-method"}
    assert len(names) == 125
    meta = metas["thesis-sixbar-config4-sweep-rest/p124"]
    assert meta["sweep"]["parent"] == "thesis-sixbar-config4-sweep-rest"
    assert meta["sweep"]["point"] == {
        "torsion_springs.S1.rest_angle_deg": 40.0,
        "torsion_springs.S2.rest_angle_deg": 130.0,
        "torsion_springs.S3.rest_angle_deg": 40.0,
    }
    assert all(t["timing"].max_runs == 1 for t in tasks)  # points are timed once


def test_points_skip_default_models():
    scene = cases.load("thesis-sixbar-config4-sweep-stiffness")
    tasks, fixed, _ = runner.plan([scene])
    models = {t["model"] for t in tasks} | {r["model"] for r in fixed}
    assert "thesis-force-method" in models and "prb-3r" not in models


def test_quick_thins_each_axis_to_ends_and_middle():
    scene = cases.load("thesis-sixbar-config4-sweep-rest")
    _, _, metas = runner.plan([scene], models=["thesis-force-method"], quick=True)
    pts = [m["sweep"]["point"] for m in metas.values()]
    assert len(pts) == 27
    s1 = sorted({p["torsion_springs.S1.rest_angle_deg"] for p in pts})
    assert s1 == [20.0, 30.0, 40.0]
