"""Stable-position synthesis (DAS-2D "Stable Position Synthesis"; ``das2d-ex6-stable-position``).

Reference: closed form.  Ex. 4's rocker is unstressed wherever the crank tip is one coupler
length from node 3; the crank circle and the coupler circle about the moved node 3 meet at
the drawn crank tip and its mirror image across the line node 1 - node 3, so the second
stable crank rotation is 2 phi - 180 deg (phi: direction of node 1 -> node 3).  The coupler
length for a target rotation follows by intersecting the coupler's line with that ray.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cases
from reports.api import solve

CASE = cases.load("das2d-ex6-stable-position")


def closed_form_length(target_deg: float) -> float:
    n1, n2, n3 = (np.array([CASE.node(n).x, CASE.node(n).y]) for n in ("N1", "N2", "N3"))
    u = (n3 - n2) / np.linalg.norm(n3 - n2)
    phi = math.radians((target_deg + 180.0) / 2.0)
    d = np.array([math.cos(phi), math.sin(phi)])
    t, _ = np.linalg.solve(np.column_stack([u, -d]), n1 - n2)
    return float(t)


@pytest.mark.parametrize("model", ["linear-4", "prb-3r"])
def test_coupler_length_puts_the_second_stable_position_on_target(model: str) -> None:
    sol = solve(CASE, model)
    assert sol.ok, sol.message
    syn = sol.extras["synthesis"]
    target = CASE.analysis.synthesis.target
    assert syn["lengths"]["coupler"] == pytest.approx(closed_form_length(target), rel=1e-8)
    assert sol.extras["bistable"]["stable"][1] == pytest.approx(target, abs=1e-6)
    fe = syn["fem-auto"]["bistable"]  # the synthesised scene re-solved by fem-auto
    assert fe["bistable"] and fe["stable"][1] == pytest.approx(target, abs=0.05)


def test_stable_position_synthesis_needs_one_rigid_link(tmp_path) -> None:
    text = (cases.CATALOG / "das2d-ex6-stable-position.toml").read_text()
    p = tmp_path / "bad.toml"
    p.write_text(text.replace('members = ["coupler"]', 'members = ["rocker"]'))
    with pytest.raises(cases.CaseError) as exc:
        cases.load(str(p))
    msg = str(exc.value)
    assert "bad.toml" in msg and "analysis.synthesis.members" in msg and "\n" not in msg
