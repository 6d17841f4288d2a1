"""``fem-auto`` meshes each flexible member as its own error asks (issue 14 item 2, FE side):
the per-member indicator converges at the element's order, refinement goes where the error
is, and the answer meets an independent reference within its estimate."""

from __future__ import annotations

import math

import pytest

import cases
from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support
from fem_reference.error import adaptive
from reports import api


@pytest.mark.parametrize(
    "name", ["das2d-ex2-parallelogram", "das2d-parallel-guide-26dof", "das2d-ex3-bistable-switch"]
)
def test_every_member_converges_at_the_element_order(name):
    """The per-member change between N and 2N falls 4x per doubling (order 2): the
    indicator's assumption, observed member by member."""
    scene = cases.load(name)
    d1 = adaptive.member_changes(scene, 8, 16, {})
    d2 = adaptive.member_changes(scene, 16, 32, {})
    assert set(d1) == set(adaptive.flexible_ids(scene))
    for m in d1:
        assert math.log2(d1[m] / d2[m]) == pytest.approx(2.0, abs=0.15), m


def _stub_and_slender(P: float = 2.0) -> Scene:
    """A stubby, very stiff member (0.3 long, EI = 1e6) clamped at A, a slender one (1 long,
    EI = 1) welded on at B, tip load P down at C (PL^2/EI = 2: large deflection)."""
    return Scene(
        name="stub-slender",
        title="stubby + slender member",
        units="nondim",
        nodes=(Node("A", 0.0, 0.0), Node("B", 0.3, 0.0), Node("C", 1.3, 0.0)),
        members=(
            Member("stub", "A", "B", "flexible", E=1.0, I=1e6, A=1e8),
            Member("slender", "B", "C", "flexible", E=1.0, I=1.0, A=1e8),
        ),
        supports=(Support("A", "clamp"),),
        loads=(Load("P", fy=-P, node="C"),),
        analysis=Analysis(kind="load", steps=4),
        outputs=(Output("tip", "C"),),
    )


def _cantilever(P: float = 2.0) -> Scene:
    """The slender member alone, clamped (the stub's compliance is ~1e-6)."""
    return Scene(
        name="slender",
        title="slender cantilever",
        units="nondim",
        nodes=(Node("B", 0.0, 0.0), Node("C", 1.0, 0.0)),
        members=(Member("slender", "B", "C", "flexible", E=1.0, I=1.0, A=1e8),),
        supports=(Support("B", "clamp"),),
        loads=(Load("P", fy=-P, node="C"),),
        analysis=Analysis(kind="load", steps=4),
        outputs=(Output("tip", "C"),),
    )


def test_refinement_goes_where_the_error_is_and_meets_the_elastica():
    scene = _stub_and_slender()
    sol = api.solve(scene, "fem-auto")
    assert sol.status == "converged", sol.message
    fid = sol.extras["fidelity"]
    assert fid["n"] == {"slender": 64, "stub": 8}  # the stub barely bends
    ind = sol.extras["per_member"]["indicator"]
    assert ind["slender"] > 1e3 * ind["stub"]
    ref = api.solve(_cantilever(), "elastica")  # independent: elliptic integrals
    assert ref.status == "converged"
    est = sol.extras["error_estimate"]
    for q in ("ux", "uy"):
        got, want = sol.steps[-1].outputs[f"tip.{q}"], ref.steps[-1].outputs[f"tip.{q}"]
        # the stub's own compliance (M a / EI ~ 6e-7 rad at B) is the model difference
        assert abs(got - want) <= est[f"tip.{q}"] + 2e-6
    assert max(est[f"tip.{q}"] for q in ("ux", "uy")) < 1e-6


def test_a_target_extends_the_sequence_until_it_is_met():
    scene = cases.load("das2d-ex3-bistable-switch")
    loose = api.solve(scene, "fem-auto", options={"target": 1e-5})
    tight = api.solve(scene, "fem-auto", options={"target": 1e-7})
    assert loose.status == tight.status == "converged"
    for sol, target in ((loose, 1e-5), (tight, 1e-7)):
        fid = sol.extras["fidelity"]
        assert fid["target_reached"] and fid["estimate"] <= target
    assert tight.extras["fidelity"]["sequence"][-1] > loose.extras["fidelity"]["sequence"][-1]
    # the short links bend little: they keep 1/8 of the long links' elements
    n = tight.extras["fidelity"]["n"]
    assert n["short_bottom"] * 8 == n["long_bottom"] == tight.extras["fidelity"]["sequence"][-1]


def test_single_beam_fem_auto_keeps_its_uniform_sequence():
    sol = api.solve(_cantilever(), "fem-auto")
    assert sol.extras["sequence"] == [8, 16, 32, 64]
    assert "per_member" not in sol.extras
