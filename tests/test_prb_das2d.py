"""DAS-2D's PRB shape and accuracy indicator (``reduced_models/beam/prb_das2d.py``, option
``das2d``) and its report section (``reports/render/das2d_note.py``), issue 21.

References: the exact elastica (``elastica`` model, elliptic integrals) and statics.  A
cantilever under a dead tip load is statically determinate: the end loads a PRB in equilibrium
recovers from its springs are the applied ones, so the Euler beam under them is the elastica's
answer, its tip the elastica's tip, and DAS-2D's indicator (PRB-vs-Euler tip gap) is the PRB's
own tip error against the elastica; the Euler beam's largest bending stress is at the root,
sigma = M t / (2 I) with M = P times the tip's horizontal distance from the root.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

import cases
from reports.api import make_model, solve
from reports.render import das2d_note

BASE = cases.load("cantilever-tip-load")
SCENE = dataclasses.replace(
    BASE,
    members=(dataclasses.replace(BASE.members[0], thickness=0.02),),
    analysis=dataclasses.replace(BASE.analysis, steps=5),
    references=(),
)
PRB = ["prb-1r", "prb-2r", "prb-3r", "prb-2rpr", "prb-fsm-6"]


@pytest.fixture(scope="module")
def exact():
    sol = solve(SCENE, "elastica")
    assert sol.ok, sol.message
    return sol


@pytest.mark.parametrize("model", PRB)
def test_indicator_of_a_cantilever_is_the_prb_tip_error(exact, model: str) -> None:
    sol = solve(SCENE, make_model(model, SCENE, {"das2d": True}))
    assert sol.ok, sol.message
    ind = sol.extras["das2d_indicator"]
    assert ind["failed"] == [] and ind["length"] == 1.0
    for k, (a, b) in enumerate(zip(sol.steps, exact.steps)):
        o, e = a.outputs, b.outputs
        gap = math.hypot(o["tip.x"] - e["tip.x"], o["tip.y"] - e["tip.y"])
        assert ind["tip_gap"][k] == pytest.approx(gap, abs=1e-7)
        assert ind["rot_gap"][k] == pytest.approx(abs(o["tip.rot"] - e["tip.rot"]), abs=1e-7)
        # the shape drawn is the Euler beam's: it ends at the elastica's tip, not the PRB's
        end = a.shapes["beam"][-1]
        assert math.hypot(end[0] - e["tip.x"], end[1] - e["tip.y"]) <= 1e-7
        # its stress: root moment of the tip force, P x_tip, over the section modulus
        P, t = 10.0 * a.factor, 0.02
        assert a.max_stress == pytest.approx(P * e["tip.x"] * t / 2.0, rel=1e-6, abs=1e-12)
    assert ind["max_tip_gap"] == pytest.approx(max(ind["tip_gap"]))


def test_without_the_option_the_prb_draws_its_own_links() -> None:
    sol = solve(SCENE, "prb-3r")
    assert "das2d_indicator" not in sol.extras
    assert len(sol.steps[-1].shapes["beam"]) == 5  # root, three pivots, tip


def test_the_option_is_declared_and_checked() -> None:
    with pytest.raises(ValueError, match="das2d"):
        make_model("prb-3r", SCENE, {"das2d": "yes"})


def test_report_section_sets_the_indicator_beside_the_measured_error() -> None:
    """A synthetic run: the reference at (1, 0) then (0.6, -0.8); the PRB 0.03 off at the
    last step (measured 0.03 / L, L = 1); its indicator 0.015: ratio 0.5."""

    def rec(model, pts, **kw):
        steps = [{"factor": f, "outputs": {"tip.x": x, "tip.y": y}} for f, (x, y) in pts]
        return {"case": "c", "model": model, "status": "converged", "steps": steps, **kw}

    ref = rec("elastica", [(0.0, (1.0, 0.0)), (1.0, (0.6, -0.8))], is_reference=True)
    ind = {"max_tip_gap": 0.015, "length": 1.0}
    prb = rec("prb-3r", [(0.0, (1.0, 0.0)), (1.0, (0.6, -0.77))], extras={"das2d_indicator": ind})
    payload = {"results": [ref, prb]}
    assert das2d_note.rows(payload) == [("c", "prb-3r", 0.015, pytest.approx(0.03))]
    (h2, _, _), _, (kind, headers, cells) = das2d_note.blocks(payload)
    assert kind == "table" and cells == [("c", "prb-3r", "0.015", "0.03", "0.5")]
    assert das2d_note.blocks({"results": [ref]}) == []
