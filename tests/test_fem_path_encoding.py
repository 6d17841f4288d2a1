"""The FE's arc-length path is sampled at the same points however the scene is drawn.

DAD-eppo's 215-degree arch (catalog ``dadeppo-arch-215``) is stiff (its tangent's condition
number ~1e8): the first arc-length step, sized from K^-1 f at the start, carried 3e-8 of
round-off, which moved every later sample along the curve (in mm instead of m: up to 2e-7
of the load factor by the end; the outside review's flags on fem-auto).  Rounded to two
significant digits (``FEM.ds0``), the path is sampled at the same points to 1e-10.  Limit
points, refined as roots of d lam / dv, are located along the curve only to the round-off
of that slope next to the fold (~1e-8 here): compared at 1e-6.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import cases
import reports
from tests.hostile_review_lib import scale_units, to_toml


@pytest.mark.parametrize("model", ["fem-8"])
def test_arch_path_is_sampled_the_same_in_other_units(model):
    drawn_scene = tomllib.loads(Path("cases/catalog/dadeppo-arch-215.toml").read_text())
    for key in ("references", "tolerances"):
        drawn_scene.pop(key, None)
    drawn_scene["case"].pop("reference_model", None)
    scaled_scene = scale_units(drawn_scene, 1000.0, 1.0, drawn_scene["case"]["units"])
    drawn = reports.solve(cases.loads(to_toml(drawn_scene)), model)
    scaled = reports.solve(cases.loads(to_toml(scaled_scene)), model)
    assert drawn.status == scaled.status == "converged", scaled.message
    assert len(scaled.steps) == len(drawn.steps) > 50
    for a, b in zip(drawn.steps, scaled.steps):
        rel = 1e-6 if dict(a.info).get("limit_point") else 1e-10
        assert b.factor == pytest.approx(a.factor, rel=rel, abs=rel)
        assert b.outputs["crown.uy"] / 1000.0 == pytest.approx(a.outputs["crown.uy"], abs=rel)
