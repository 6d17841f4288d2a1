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


def test_member_law_in_all_six_end_unknowns():
    """Both ends free (the scenes above hold end a): the frame-rotation terms are checked."""
    L, EI, EA = 40.0, 1400.0 * 5 * 1.5**3 / 12, 1400.0 * 5 * 1.5
    term = ElasticaTerm(range(6), L, EI, EA, 0.4, np.nan, "m")
    rng = np.random.default_rng(5)
    base = np.array([1.0, -2.0, 0.0, 1.0 + L * np.cos(0.4), -2.0 + L * np.sin(0.4), 0.0])
    for _ in range(3):
        q = base + rng.uniform(-1, 1, 6) * np.array([2.0, 2.0, 0.4, 2.0, 2.0, 0.6])
        q[3:5] = q[0:2] + (q[3:5] - q[0:2]) * L / np.hypot(*(q[3:5] - q[0:2]))  # chord ~ L
        _, g, H = term.local(q)
        h = 1e-5
        for i in range(6):
            e = np.zeros(6)
            e[i] = h
            dE = (term.energy(q + e) - term.energy(q - e)) / (2 * h)
            assert dE == pytest.approx(g[0, i], rel=1e-6, abs=1e-6 * np.abs(g).max())
            dg = (term.local(q + e)[1][0] - term.local(q - e)[1][0]) / (2 * h)
            np.testing.assert_allclose(dg, H[0, :, i], rtol=1e-5, atol=1e-6 * np.abs(H).max())
            term.local(q)  # back to q (warm start along the way)
        # free body: end forces balance, moments balance about end a
        assert g[0, 0] + g[0, 3] == pytest.approx(0.0, abs=1e-9 * np.abs(g).max())
        assert g[0, 1] + g[0, 4] == pytest.approx(0.0, abs=1e-9 * np.abs(g).max())
        d = q[3:5] - q[0:2]
        m = g[0, 2] + g[0, 5] + d[0] * g[0, 4] - d[1] * g[0, 3]
        assert m == pytest.approx(0.0, abs=1e-9 * L * np.abs(g).max())


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


def test_lee_frame_limit_points_through_the_snap_back():
    """Lee's frame by arc length with elastica members: both load-factor extrema, against the
    published first limit load (18.5, Lee, Manuel & Rossow 1968; the case's reference) and
    fem-auto's Richardson values (18.5569 +- 0.0023 and -9.4148 +- 0.0046, in the FE's own
    extras).  Without the path's jump guard the corrector landed past the snap-back and the
    run 'converged' with no limit point."""
    el = reports.solve("lee-frame", "elastica")
    assert el.status == "converged", el.message
    lp = [(p["kind"], p["factor"]) for p in el.extras["limit_points"]]
    assert [k for k, _ in lp] == ["max", "min"]
    assert lp[0][1] == pytest.approx(18.5, rel=5e-3)  # printed to 3 digits (case tolerance)
    assert lp[0][1] == pytest.approx(18.5569, abs=3 * 0.0023)
    assert lp[1][1] == pytest.approx(-9.4148, abs=3 * 0.0046)


def test_shallow_arch_snap_through_is_followed_not_jumped():
    """Two straight bars snapping through: the limit loads +-0.381087190418 of fem-auto (its
    Richardson error estimate 1e-15) and the case's closed-form end factor 1.8302512025075
    (von Mises truss law at w = 0.25).  Before the path's secant guard the elastica stepped
    across the snap-through in 6 steps and reported no limit point."""
    el = reports.solve("shallow-arch-snap", "elastica")
    assert el.status == "converged", el.message
    lp = [(p["kind"], p["factor"]) for p in el.extras["limit_points"]]
    assert [k for k, _ in lp] == ["max", "min"]
    assert lp[0][1] == pytest.approx(0.381087190418, rel=1e-8)
    assert lp[1][1] == pytest.approx(-0.381087190418, rel=1e-8)
    assert el.steps[-1].factor == pytest.approx(1.8302512025075, rel=1e-9)


def test_a_member_beyond_the_strain_bound_is_refused_not_walked():
    """Ex. 2 with its links 1e4 times softer: 30 N would stretch them ~10x (the axially
    extensible elastica followed it to a 300 mm rise of a coupler on 40 mm links, and with
    them 1e6 times softer walked for minutes).  The member law refuses a chord beyond
    (1 + STRAIN_MAX) L, and the analysis fails with that reason."""
    text = cases.resolve("das2d-ex2-parallelogram").read_text()
    assert text.count("E = 2300.0") == 2
    scene = cases.loads(text.replace("E = 2300.0", "E = 0.23"), "soft")
    sol = reports.make_model("elastica", scene).solve(scene)
    assert sol.status == "failed"
    assert "strained by at least" in sol.message and "(bound 0.2)" in sol.message
    rise = [st.outputs["coupler_low.uy"] for st in sol.steps]
    assert max(rise) < 2.0 * 40.0  # no state it kept stretches a member to twice its length
