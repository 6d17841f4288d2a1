"""Chained members (linear-N, bcm, cbcm-N) are laid out from the end the scene decides
(``cases.orient``), not from the drawn ``from`` end (issue 23, item 5).

* A bistable switch mirror-symmetric about the x axis, pushed along that axis: before its
  snap the exact path is symmetric, so the shuttle neither turns nor moves off the axis
  (rotation and y-displacement 0).  Laid out from each member's ``from`` end (the two legs
  drawn in the same sense, i.e. not as mirror images) the chained BCM turned the shuttle by
  -1.1e-3 rad at factor 0.2.
* The asymmetric switch with every member reversed (``tests/scene_transforms``) gives the
  same outputs to ``RTOL`` = 1e-8 of each output's excursion, the metamorphic test's bar
  (after the snap linear-8 lands within 4.5e-10: Newton's tolerance); the drawn layout
  differed by 8.8e-6 (cbcm-2), 1.6e-5 (bcm), 1.5e-8 (linear-8).
* The rule itself, on hand-made scenes: the ground end roots the chain whichever way the
  member is drawn; a member whose ends tie on every key keeps its drawn direction.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

import cases
from cases.orient import root_at_b
from cases.schema import Member
from reports import api
from tests.scene_transforms import ENCODINGS
from tests.test_metamorphic import RTOL, mismatch

SYM = "tests/fixtures/bistable-switch-symmetric.toml"
ASYM = "tests/fixtures/bistable-asym-m-n-pa.toml"


def _solve(scene, model):
    return api.run_model(api.make_model(model, scene), scene, post=False)


@pytest.mark.parametrize("model", ["cbcm-8", "cbcm-2", "bcm", "linear-8"])
def test_symmetric_switch_stays_on_its_axis_before_the_snap(model):
    sol = _solve(cases.load(SYM), model)
    assert sol.status == "converged", sol.message
    snap = min(c["factor"] for c in sol.extras["critical_points"] if c["kind"] == "snap")
    before = [s for s in sol.steps if s.factor < snap]
    assert len(before) >= 4
    for s in before:
        assert abs(s.outputs["sh.rot"]) < 1e-12, (s.factor, s.outputs["sh.rot"])
        assert abs(s.outputs["sh.uy"]) < 1e-12 * 0.032, (s.factor, s.outputs["sh.uy"])


@pytest.mark.parametrize("model", ["cbcm-2", "bcm", "linear-8"])
def test_reversed_members_give_the_same_answer(model):
    scene = cases.load(ASYM)
    enc = next(e for e in ENCODINGS if e.name == "reverse").for_scene(scene)
    a, b = _solve(scene, model), _solve(enc.scene(scene), model)
    assert a.status == "converged", a.message
    assert not mismatch(scene, enc, a, b, rtol=RTOL)


def _reversed(m: Member) -> Member:
    return replace(m, a=m.b, b=m.a, end_a=m.end_b, end_b=m.end_a)


def test_the_ground_end_roots_the_chain_either_way_it_is_drawn():
    scene = cases.load(SYM)
    for m in scene.members:
        if m.kind != "flexible":
            continue
        flipped = replace(
            scene, members=tuple(_reversed(o) if o is m else o for o in scene.members)
        )
        root = m.b if root_at_b(scene, m) else m.a
        r = _reversed(m)
        assert (r.b if root_at_b(flipped, r) else r.a) == root
        if m.id.startswith("long"):  # pinned to ground at F1/F2, welded to the knee
            assert root.startswith("F")
        else:  # knee to shuttle: the knee is one member from ground, the shuttle three
            assert root.startswith("K")


def test_a_full_tie_keeps_the_drawn_direction():
    """A beam clamped at both ends of a symmetric scene: no key tells its ends apart."""
    scene = cases.load("fixed-guided-beam")
    m = next(o for o in scene.members if o.kind == "flexible")
    sup = scene.support_at(m.a)
    both = replace(scene, supports=(sup, replace(sup, node=m.b)))
    assert not root_at_b(both, m)
    assert not root_at_b(both, _reversed(m))
