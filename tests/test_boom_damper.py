"""The thesis's ADAMS collision-damper boom (seed 001, Chapter 5; issue 25).

A damper stop never latches: the 100 N push stays on and an elastic stop of k = 1e5 N/m holds
the boom past its length, at most by F / k = 1 mm (the springs take the rest of the push).
Under the 1 N impulse on J4 the damper boom's length moves (the perturbation is partly taken
up by the boom, the thesis's artefact) while a locked boom's does not.
"""

from __future__ import annotations

import numpy as np
import pytest

import cases
from reports import api


def _boom_range_after_impulse(sol: object) -> float:
    th = sol.extras["time_history"]
    t = np.array(th["t"])
    ell = np.array(th["boom_length"]["boom"])[t >= th["perturbation"]["t"]]
    return float(np.ptp(ell))


def test_damper_holds_the_boom_within_push_over_stiffness():
    scene = cases.load("thesis-sixbar-config4-damper")
    (boom,) = scene.booms
    assert (boom.stop, boom.stop_stiffness) == ("damper", 1e5)
    sol = api.solve(scene, "replay")
    assert sol.status == "converged", sol.message
    ell = sol.steps[-1].outputs["boom.length"]
    assert 0.3 < ell <= 0.3 + boom.force / boom.stop_stiffness
    assert sol.extras["time_history"]["locks"] == []  # never latched
    assert sol.extras["boom_reached"] is True


def test_damper_absorbs_the_impulse_the_lock_does_not():
    damper = api.solve(cases.load("thesis-sixbar-config4-damper"), "replay")
    locked = api.solve(cases.load("thesis-sixbar-config4"), "replay")
    assert _boom_range_after_impulse(locked) < 1e-9
    assert _boom_range_after_impulse(damper) > 1e-6


@pytest.mark.parametrize("model", ["kinetostatic", "fem-auto", "thesis-force-method"])
def test_static_models_decline_a_damper(model):
    sol = api.solve(cases.load("thesis-sixbar-config4-damper"), model)
    assert sol.status == "not-applicable" and "damper" in sol.message


@pytest.mark.parametrize(
    ("extra", "key"),
    [('stop = "spring"', "stop"), ("stop_stiffness = 1.0", "stop_stiffness"),
     ('stop = "damper"', "stop_stiffness")],
)  # fmt: skip
def test_bad_stop_keys_are_one_line_errors(extra, key):
    text = cases.resolve("thesis-sixbar-config4").read_text()
    text = text.replace("length = 0.3\n", f"length = 0.3\n{extra}\n", 1)
    with pytest.raises(cases.CaseError) as err:
        cases.loads(text, source="x.toml")
    assert f"booms[0].{key}" in str(err.value)
