"""The thesis's force method answers the same in any unit system (issue 23, item 5).

Its Part 2 runs while ``|U_m' Load_0| >= 1e-6`` (the Appendix C listing, in newtons): taken in
the scene's own force unit, a scene written in lbf stopped one increment elsewhere and its
final joint rotations moved by 2e-7 of their excursion.  The scene converted exactly (NIST SP
811 factors, ``tests/scene_transforms.py``) must give the same outputs, converted back, to
round-off.
"""

from __future__ import annotations

import pytest

import cases
import reports
from tests.scene_transforms import Encoding

UNITS = {
    "mm": ("mm-N-MPa", 1e3, 1.0),
    "in": ("in-lbf-psi", 1 / 0.0254, 1 / 4.4482216152605),
}


@pytest.mark.parametrize("units", sorted(UNITS))
@pytest.mark.parametrize("config", [2, 3, 4, 6])
def test_force_method_same_answer_in_other_units(config, units):
    scene = cases.load(f"thesis-sixbar-config{config}")
    enc = Encoding(units, units={"m-N-Pa": UNITS[units]}).for_scene(scene)
    a = reports.solve(scene, "thesis-force-method")
    b = reports.solve(enc.scene(scene), "thesis-force-method")
    assert a.status == b.status == "converged", (a.message, b.message)
    assert len(a.steps) == len(b.steps)
    for sa, sb in zip(a.steps, b.steps):
        back = enc.outputs_back(scene, dict(sb.outputs))
        for key, v in sa.outputs.items():
            assert back[key] == pytest.approx(v, rel=1e-12, abs=1e-12), (sa.factor, key)
