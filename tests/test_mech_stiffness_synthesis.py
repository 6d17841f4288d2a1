"""Flexural-stiffness synthesis as a catalog case (``das2d-ex2-stiffness-synthesis``).

Reference: fem-auto's own answer to the synthesis, found by secant iterations on fem-auto
(quoted with provenance in the case file): the links' EI scaled by 1.580064 gives a 20 mm
coupler rise at 30 N.  A converged beam model must find that scale, and the report's fem-auto
re-solve of its synthesised scene must land on the target.
"""

from __future__ import annotations

import pytest

from reports.api import solve
from reports.render import synthnote
from reports.run.store import extras_json

FE_SCALE = 1.580064


@pytest.mark.parametrize(("model", "tol"), [("cbcm-8", 5e-3), ("cbcm-2", 0.15)])
def test_stiffness_synthesis_against_the_fe_check(model: str, tol: float) -> None:
    sol = solve("das2d-ex2-stiffness-synthesis", model)
    assert sol.ok, sol.message
    syn = sol.extras["synthesis"]
    assert syn["achieved"] == pytest.approx(20.0, rel=1e-6)
    assert syn["scale"] == pytest.approx(FE_SCALE, rel=tol)
    fe = syn["fem-auto"]
    assert fe["status"] == "converged"
    # the FE rise of the synthesised scene misses the target by about the scale's error
    assert fe["relative_error"] <= 1.5 * abs(syn["scale"] / FE_SCALE - 1.0) + 1e-4
    lines = synthnote.notes(extras_json(sol.extras))  # the report: target beside the FE
    assert any("target 20" in ln for ln in lines)
    assert any(ln.startswith("fem-auto on the synthesised scene: ") for ln in lines)
