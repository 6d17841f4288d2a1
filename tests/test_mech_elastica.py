"""The elastica member law in mechanisms (reduced_models/mechanism/elastica_member.py).

References (never the law's own numbers):
* central finite differences of the energy and of the gradient (Hessian) on random states;
* fem-auto (Richardson-extrapolated corotational FE, error estimate ~1e-6 relative) on DAS-2D
  Ex. 2 at every load step and on the Ex. 4 bistable four-bar (equilibria and barrier quoted
  with provenance in the case file: -52.7278 deg, 2.915972 N mm).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import cases
import reports
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.elastica_member import ElasticaTerm
from reduced_models.mechanism.model import member_spec
from tests import mech_scenes as M


@pytest.mark.parametrize("case", ["das2d-ex2-parallelogram", "fourbar"])
def test_member_law_derivatives_match_finite_differences(case):
    scene = M.fourbar() if case == "fourbar" else cases.load(case)
    sysm = build(scene, lambda m: member_spec("elastica"))
    terms = [t for t in sysm.terms if isinstance(t, ElasticaTerm)]
    assert terms
    rng = np.random.default_rng(3)
    f = sysm.free
    kind = np.array(sysm.lay.kind)[f]
    for _ in range(2):
        q = sysm.q0.copy()
        # node moves of 0.2 % L: a member stretched 5 % (as the chain tests use) is no state
        q[f] += np.where(kind == "r", 0.2, 0.002 * sysm.lay.Lref) * rng.uniform(-1, 1, len(f))
        g, H = sysm.grad_hess(q, 0.5)
        h = 1e-5
        for i in f:
            e = np.zeros(sysm.n)
            e[i] = h
            dE = (sysm.potential(q + e, 0.5) - sysm.potential(q - e, 0.5)) / (2 * h)
            assert dE == pytest.approx(g[i], rel=1e-6, abs=1e-7 * sysm.fscale)
            dg = (sysm.grad_hess(q + e, 0.5)[0] - sysm.grad_hess(q - e, 0.5)[0]) / (2 * h)
            np.testing.assert_allclose(dg, H[:, i], rtol=1e-5, atol=1e-6 * np.abs(H).max())


def test_parallelogram_matches_fem_auto_at_every_load():
    fe = reports.solve("das2d-ex2-parallelogram", "fem-auto")
    el = reports.solve("das2d-ex2-parallelogram", "elastica")
    assert el.status == fe.status == "converged", el.message
    for key in ("coupler_low.ux", "coupler_low.uy", "coupler_high.ux"):
        a, b = el.path(key), fe.path(key)
        np.testing.assert_allclose(a, b, rtol=0, atol=2e-5 * np.abs(b).max())
    cb = reports.solve("das2d-ex2-parallelogram", "cbcm-8")
    err_cb = abs(cb.steps[-1].outputs["coupler_low.uy"] - fe.steps[-1].outputs["coupler_low.uy"])
    err_el = abs(el.steps[-1].outputs["coupler_low.uy"] - fe.steps[-1].outputs["coupler_low.uy"])
    assert err_el < 0.1 * err_cb  # the exact law beats the converging chain


def test_bistable_fourbar_equilibria_match_fem_auto():
    scene = cases.load("das2d-ex4-bistable-fourbar")
    scene = dataclasses.replace(scene, analysis=dataclasses.replace(scene.analysis, steps=24))
    sol = reports.solve(scene, "elastica")
    assert sol.status == "converged", sol.message
    eq = sol.extras["equilibria"]
    assert [e["kind"] for e in eq] == ["stable", "unstable", "stable"]
    assert eq[1]["coordinate"] == pytest.approx(-52.7278, abs=2e-3)  # fem-auto bounded search
    assert sol.extras["barrier"] == pytest.approx(2.915972, rel=2e-5)  # fem-auto, err 1.2e-4


def test_elastica_bvp_still_declines_mechanisms_with_reason():
    sol = reports.solve("das2d-ex2-parallelogram", "elastica-bvp")
    assert sol.status == "not-applicable" and "`elastica` carries the member law" in sol.message
