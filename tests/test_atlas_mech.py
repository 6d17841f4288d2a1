"""Mechanism validity atlases: values equal individual solves, axis transforms change only
what they claim to, member measures match a circular arc's closed form."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import cases
import reports
from reports.verdicts import atlas_mech as AM
from reports.verdicts import atlas_mech_axes as AX


@pytest.fixture(scope="module")
def ex2_atlas():
    return AM.compute("das2d-ex2-parallelogram", models=("cbcm-2", "prb-3r"), n_axis=3)


def test_atlas_values_equal_individual_solves(ex2_atlas):
    """Sampled atlas states against separate fem-auto / model solves of the turned load,
    the error recomputed here on each output's own scale along the reference path
    (translations over the point's largest displacement, rotations over the point's largest
    rotation, floored at 1e-3 of the scene's motion over L, or 1e-6 rad)."""
    at = ex2_atlas
    base = cases.load("das2d-ex2-parallelogram")
    L = max(base.member_length(m.id) for m in base.members)
    (ld,) = base.loads
    mag, ang = math.hypot(ld.fx, ld.fy), math.atan2(ld.fy, ld.fx)
    for i, j in ((0, len(at.drive) - 1), (2, 10)):
        a = ang + math.radians(at.values[i])
        load = dataclasses.replace(ld, fx=mag * math.cos(a), fy=mag * math.sin(a))
        scene = dataclasses.replace(base, loads=(load,))
        path = reports.solve(scene, "fem-auto").steps
        ref = path[j]
        assert ref.factor == pytest.approx(at.drive[j])
        points = {k.rsplit(".", 1)[0] for k in ref.outputs}
        move = {
            p: max(math.hypot(s.outputs[f"{p}.ux"], s.outputs[f"{p}.uy"]) for s in path)
            for p in points
        }
        turn = {p: max(abs(s.outputs[f"{p}.rot"]) for s in path) for p in points}
        motion = max(move.values())
        floor_r = max(1e-3 * max(max(turn.values()), motion / L), 1e-6)
        for name in ("cbcm-2", "prb-3r"):
            st = reports.solve(scene, name).steps[j]
            err = max(
                abs(st.outputs[k] - v)
                / (max(turn[p], floor_r) if q == "rot" else max(move[p], 1e-3 * motion))
                for k, v in ref.outputs.items()
                for p, q in [k.rsplit(".", 1)]
                if q in ("ux", "uy", "rot")
            )
            assert at.error[name][i, j] == pytest.approx(err, rel=1e-6, abs=1e-12)


def test_atlas_shape_claims_and_cost(ex2_atlas):
    at = ex2_atlas
    assert at.axis == "direction" and at.error["cbcm-2"].shape == (3, 21)
    assert at.ref_ok.all() and np.all(at.error["cbcm-2"][:, 0] < 1e-9)  # unloaded: no error
    # the seed's BCM claim covers small loads, not the full 30 N (coupler at 63 % of L)
    seed = next(c for c in at.claims if c["model"] == "cbcm-2" and "seed" in c["label"])
    assert seed["region"][:, 1].all() and not seed["region"][:, -1].any()
    assert AM.cost_ratio(at, "cbcm-2") > 0


def test_slenderness_changes_only_the_axial_stiffness():
    """Thickness x s with loads x s^3: an inextensible member law (linear-N) gives the same
    path, an extensible one (cbcm-N) does not."""
    scene = cases.load("das2d-ex2-parallelogram")
    thin = AX.thin(scene, 0.5)
    assert thin.members[0].EI == pytest.approx(scene.members[0].EI / 8)
    assert thin.members[0].EA == pytest.approx(scene.members[0].EA / 2)
    for name, same in (("linear-4", True), ("cbcm-4", False)):
        a, b = (reports.solve(s, name).steps[-1].outputs["coupler_low.uy"] for s in (scene, thin))
        assert (abs(a - b) <= 1e-9 * abs(a)) == same, (name, a, b)


def test_lengthen_moves_only_the_ground_end():
    scene = cases.load("das2d-ex4-bistable-fourbar")
    longer = AX.lengthen(scene, 1.3)
    for m in scene.members:
        ratio = longer.member_length(m.id) / scene.member_length(m.id)
        assert ratio == pytest.approx(1.3 if m.id == "rocker" else 1.0)
    assert longer.node("N3") == scene.node("N3")


@pytest.mark.parametrize("theta", [0.3, 1.0])
def test_member_measures_on_a_circular_arc(theta: float):
    """A circular arc of angle theta: per segment of angle phi, y / L = (1 - cos phi) / phi and
    the largest slope tan(phi); Howell's Theta from the pivot at 0.15 L."""
    s = np.linspace(0.0, theta, 4001)
    pts = np.column_stack([np.sin(s), 1.0 - np.cos(s)])  # R = 1, L = theta
    for n in (1, 2):
        phi = theta / n
        y, slope, big_theta = AM._segment_measures(pts, n)
        assert y == pytest.approx((1 - math.cos(phi)) / phi, rel=1e-3)
        assert slope == pytest.approx(math.tan(phi), rel=1e-3)
    expect = math.atan2(1 - math.cos(theta), math.sin(theta) - 0.15 * theta)
    assert big_theta == pytest.approx(math.degrees(expect), rel=1e-3)


@pytest.mark.parametrize(
    "case, why",
    [("das2d-ex5-constant-force", "kinetostatic"), ("das2d-ex6-bistable-synthesis", "synthesis")],
)
def test_cases_without_an_atlas_say_why(case: str, why: str):
    with pytest.raises(AX.NoAtlas, match=why):
        AM.compute(case)
