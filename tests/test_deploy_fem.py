"""``fem-auto`` and ``replay`` on deploy scenes against ``kinetostatic``.

Stated error: rigid links are FE stiff elements with compliance ~1e-6 of the scene's
stiffness (``assembly.build``), so joint positions agree with the rigid-link answer to
~1e-6 of the 0.3 m links (3e-7 m); we allow 1e-6 m.  The replay settles to 1e-7 L
(``ReplayOptions.settle_tol``) on the same FE system: 1e-6 m as well.
"""

from __future__ import annotations

import dataclasses

import pytest

import cases
from cases.sweep import expand
from reports import api

TOL = 1e-6  # m


def positions(sol):
    return {k: v for k, v in sol.steps[-1].outputs.items() if k.endswith((".x", ".y"))}


def close(a, b):
    pa, pb = positions(a), positions(b)
    return max(abs(pa[k] - pb[k]) for k in pb)


@pytest.fixture(scope="module")
def point():
    """A sweep point with a loaded locked boom (bar force ~ -27 N)."""
    return expand(cases.load("thesis-sixbar-config4-sweep-rest"))[24]


def test_fem_auto_matches_kinetostatic(point):
    kin = api.solve(point, "kinetostatic")
    fem = api.solve(point, "fem-auto")
    assert kin.status == fem.status == "converged", (kin.message, fem.message)
    assert fem.steps[-1].factor == 2.0 and fem.steps[-1].stable == kin.steps[-1].stable
    assert close(fem, kin) < TOL
    assert fem.extras["boom_bar_force"][0] == pytest.approx(kin.extras["boom_bar_force"][0], 1e-5)


def test_fem_auto_stall():
    scene = cases.load("thesis-sixbar-config4")
    springs = tuple(
        dataclasses.replace(t, free_angle_deg=0.0, rest_angle_deg=None)
        for t in scene.torsion_springs
    )
    weak = dataclasses.replace(scene.booms[0], force=20.0)
    s2 = dataclasses.replace(scene, torsion_springs=springs, booms=(weak,))
    kin, fem = api.solve(s2, "kinetostatic"), api.solve(s2, "fem-auto")
    assert "stalled" in fem.message and fem.steps[-1].factor < 1.0
    assert close(fem, kin) < TOL


def test_replay_locks_and_settles():
    scene = cases.load("thesis-sixbar-config4")
    rep, kin = api.solve(scene, "replay"), api.solve(scene, "kinetostatic")
    assert rep.status == "converged", rep.message
    assert len(rep.extras["events"]) == 1 and rep.extras["events"][0]["kind"] == "lock"
    last = rep.steps[-1]
    assert last.factor == 2.0 and last.outputs["boom.length"] == pytest.approx(0.3, abs=1e-9)
    assert last.stable is True and last.stable == kin.steps[-1].stable  # probe vs reduced Hessian
    assert close(rep, kin) < TOL
