"""Conformance: every registered model on every catalog case keeps the Solution contract.

A model either declines with a one-line reason, converges with finite outputs for every step
(the first step of a load ramp at factor 0 being the undeformed scene when nothing is
preloaded), or fails with a reason.  Load ramps are shortened so the matrix stays quick.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import cases
import reports
from reduced_models.base import STATUSES

# parametrised families are exercised with a small, cheap N
SMALL_N = {"fem-N": 4, "prb-fsm-N": 4, "linear-N": 2, "cbcm-N": 2}
# too slow for a full matrix; each has its own verification file
SKIP = {"replay", "fem-auto"}


def concrete_models() -> list[str]:
    names = []
    for key in reports.api.model_names():
        if key in SKIP:
            continue
        names.append(key.replace("-N", f"-{SMALL_N.get(key, 2)}") if key.endswith("-N") else key)
    return names


def short(scene: cases.Scene) -> cases.Scene:
    a = scene.analysis
    steps = min(a.steps, 4)
    return dataclasses.replace(
        scene, analysis=dataclasses.replace(a, steps=steps, max_steps=min(a.max_steps, 60))
    )


SCENES = {name: short(cases.load(name)) for name in cases.catalog_names()}
MODELS = concrete_models()


def test_registry_is_populated():
    for required in ("elastica", "linear-N"):
        assert required in reports.api.model_names()


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("case", sorted(SCENES))
def test_contract(case, model):
    scene = SCENES[case]
    sol = reports.solve(scene, model)
    assert sol.status in STATUSES
    assert sol.case == scene.name and sol.model == model
    if sol.status != "converged":
        assert sol.message.strip() and "\n" not in sol.message, "one-line reason"
        if sol.status == "not-applicable":
            assert not sol.steps
        return
    assert sol.steps, "a converged solution has steps"
    keys = scene.output_keys()
    for step in sol.steps:
        assert math.isfinite(step.factor)
        for k in keys:
            assert k in step.outputs, f"missing output {k}"
            assert math.isfinite(step.outputs[k]), f"{k} not finite"
        for pts in step.shapes.values():
            assert np.asarray(pts).ndim == 2 and np.asarray(pts).shape[1] == 2
    first = sol.steps[0]
    preloaded = any(t.free_angle_deg for t in scene.torsion_springs)
    if scene.analysis.kind == "load" and first.factor == 0.0 and not preloaded:
        scale = max(scene.member_length(m.id) for m in scene.members)
        for k in keys:
            if k.endswith((".ux", ".uy", ".rot")):
                assert abs(first.outputs[k]) <= 1e-9 * scale, f"zero load moved {k}"
