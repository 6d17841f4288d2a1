"""A driven rigid link of the replay (a stiff element, ``fem_reference.assembly``) is driven
at the end every drawing agrees on (``_driven_end``: the chains' ``orient.root_at_b``), so
reversing it in the scene file does not move the answer.

DAS-2D Ex. 4 (bistable four-bar): its crank drawn from the coupler pin to the ground pin was
driven at the coupler end, and the link's 1 / rigid_factor bending turned the crank tip by
1.6e-7 rad (2.9e-7 of the excursion) away from the crank drawn from the ground.  A 1-ulp
perturbation of the drawn coordinates moves the same output by 4e-16 rad: not round-off.
The answer checked: the case's closed-form zero torque at the rocker's rest (-90 deg) and its
FE torque at -120 deg.
"""

from __future__ import annotations

import cases
from tests.scene_transforms import Encoding
from tests.test_metamorphic import mismatch, solve


def _at(sol, factor: float, key: str) -> float:
    return next(s.outputs[key] for s in sol.steps if abs(s.factor - factor) < 1e-9)


def test_reversed_driven_link_gives_the_drawn_answer():
    scene = cases.load("das2d-ex4-bistable-fourbar")
    enc = Encoding("reverse", reverse=True, rename=True).for_scene(scene)
    a = solve(scene, "replay")
    b = solve(enc.scene(scene), "replay")
    assert not mismatch(scene, enc, a, b, 1e-10)
    for sol in (a, b):
        assert sol.status == "converged", sol.message
        # at the case's tolerances: closed form 0 (absolute 1e-6), FE -29.71963 (1e-2)
        assert abs(_at(sol, -90.0, "driver.torque")) <= 1e-6
        assert abs(_at(sol, -120.0, "driver.torque") + 29.71963) <= 1e-2 * 29.71963
