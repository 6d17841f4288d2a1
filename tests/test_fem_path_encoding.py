"""The FE's arc-length path is sampled at the same points however the scene is drawn.

DAD-eppo's 215-degree arch (catalog ``dadeppo-arch-215``) is stiff (its tangent's condition
number ~1e8): the first arc-length step, sized from K^-1 f at the start, carried 3e-8 of
round-off, which moved every later sample along the curve (in mm instead of m: up to 2e-7
of the load factor by the end; the outside review's flags on fem-auto).  Rounded to two
significant digits (``FEM.ds0``), the path is sampled at the same points to 1e-10.  Limit
points were located as roots of the bordered tangent's d lam / dv, which scatters by 1e-7
next to the fold (the tangent carries EA times the element lengths' round-off): the
crown's rotation there differed by 3e-8 of its excursion between units.  Polished on lam
itself (``static._polish_extremum``) they agree to 1e-9.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import cases
import reports
from tests.hostile_review_lib import scale_units, to_toml


@pytest.mark.parametrize("model", ["fem-8", "fem-16"])
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
    n_limit = 0
    for a, b in zip(drawn.steps, scaled.steps):
        rel = 1e-9 if dict(a.info).get("limit_point") else 1e-10
        n_limit += bool(dict(a.info).get("limit_point"))
        assert b.factor == pytest.approx(a.factor, rel=rel, abs=rel)
        assert b.outputs["crown.uy"] / 1000.0 == pytest.approx(a.outputs["crown.uy"], abs=rel)
        assert b.outputs["crown.rot"] == pytest.approx(a.outputs["crown.rot"], abs=rel)
    assert n_limit >= 2  # the limit load and the turning point of the crown's travel
