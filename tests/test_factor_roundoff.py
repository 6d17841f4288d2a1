"""A located critical factor states how far round-off alone moves it (``factor_roundoff``,
``fem_reference/statics/conditioning.py``), and that bound is honest: the same scene with its
node coordinates moved by 4e-16 (relative: what writing it in other coordinates or units
does) locates its factor within the two bounds, and the bound is not vacuous."""

from __future__ import annotations

import re

import numpy as np
import pytest

import cases
from reports.api import make_model

SCENE = "das2d-ex3-bistable-switch-load"  # symmetric switch: a located bifurcation


def _perturbed(seed: int) -> cases.Scene:
    """The scene with every node coordinate scaled by 1 + 4e-16 N(0, 1)."""
    rng = np.random.default_rng(seed)
    text = cases.resolve(SCENE).read_text()

    def move(m: re.Match) -> str:
        return f"{m.group(1)}{float(m.group(2)) * (1 + 4e-16 * rng.standard_normal())!r}"

    moved = re.sub(r"^(\s*[xy]\s*=\s*)(-?[0-9.eE+-]+)\s*$", move, text, flags=re.M)
    assert moved != text
    return cases.loads(moved, SCENE)


@pytest.mark.parametrize("model", ["fem-16", "replay"])
def test_located_factor_moves_within_its_roundoff_bound(model):
    found = []
    for scene in [cases.load(SCENE)] + [_perturbed(seed) for seed in (1, 2, 3)]:
        sol = make_model(model, scene).solve(scene)
        assert sol.ok, sol.message
        (snap,) = [p for p in sol.extras["critical_points"] if p["kind"] == "snap"]
        found.append((snap["factor"], snap["factor_roundoff"]))
    lam, bound = np.array(found).T
    # the case's bifurcation (fem-auto Richardson 0.432073): the mesh's, not round-off's, error
    assert lam == pytest.approx(0.432073, rel=3e-3)
    assert np.all(bound < 1e-5 * lam)  # not vacuous
    for i in range(len(lam)):
        for j in range(i):
            assert abs(lam[i] - lam[j]) <= bound[i] + bound[j], (lam, bound)
