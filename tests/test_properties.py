"""Invariants every model must keep, whatever its family.

* rigid rotation of the whole scene changes no relative output (objectivity of the model and
  of the frame handling around it);
* zero load gives zero displacement;
* small loads agree with linear beam theory, y = P L^3 / (3 EI) for the cantilever (the PRB
  family within its documented small-load bias, see tests/test_verify_prb.py).
"""

from __future__ import annotations

import dataclasses
import math

import pytest

import cases
import reports
from tests.test_conformance import concrete_models

BASE = cases.load("cantilever-tip-load")


def rotated(scene: cases.Scene, beta: float) -> cases.Scene:
    """The scene turned rigidly by beta (rad) about the origin (loads turn with it)."""
    c, s = math.cos(beta), math.sin(beta)
    nodes = tuple(
        dataclasses.replace(n, x=c * n.x - s * n.y, y=s * n.x + c * n.y) for n in scene.nodes
    )
    loads = tuple(
        dataclasses.replace(ld, fx=c * ld.fx - s * ld.fy, fy=s * ld.fx + c * ld.fy)
        for ld in scene.loads
    )
    return dataclasses.replace(scene, nodes=nodes, loads=loads)


def scaled(scene: cases.Scene, factor: float, steps: int = 2) -> cases.Scene:
    loads = tuple(
        dataclasses.replace(ld, fx=ld.fx * factor, fy=ld.fy * factor, moment=ld.moment * factor)
        for ld in scene.loads
    )
    return dataclasses.replace(
        scene, loads=loads, analysis=dataclasses.replace(scene.analysis, steps=steps)
    )


def applicable(scene: cases.Scene) -> list[str]:
    out = []
    for name in concrete_models():
        model = reports.api.make_model(name, scene)
        if model.applies_to(scene) is None:
            out.append(name)
    return out


MODELS = applicable(BASE)


def test_single_beam_models_exist():
    assert "elastica" in MODELS and any(m.startswith("linear-") for m in MODELS)


@pytest.mark.parametrize("model", MODELS)
def test_rigid_rotation_changes_nothing(model):
    scene = scaled(BASE, 0.3, steps=4)
    beta = math.radians(37.0)
    a = reports.solve(scene, model)
    b = reports.solve(rotated(scene, beta), model)
    assert a.status == b.status == "converged", (a.message, b.message)
    c, s = math.cos(beta), math.sin(beta)
    for sa, sb in zip(a.steps, b.steps):
        ux, uy = sa.outputs["tip.ux"], sa.outputs["tip.uy"]
        # displacements turn with the scene; rotations do not change
        assert sb.outputs["tip.ux"] == pytest.approx(c * ux - s * uy, abs=1e-9)
        assert sb.outputs["tip.uy"] == pytest.approx(s * ux + c * uy, abs=1e-9)
        assert sb.outputs["tip.rot"] == pytest.approx(sa.outputs["tip.rot"], abs=1e-9)


@pytest.mark.parametrize("model", MODELS)
def test_zero_load_zero_displacement(model):
    sol = reports.solve(scaled(BASE, 0.0), model)
    assert sol.status == "converged", sol.message
    for step in sol.steps:
        for key in ("tip.ux", "tip.uy", "tip.rot"):
            assert abs(step.outputs[key]) < 1e-12
        assert abs(step.energy) < 1e-12 or math.isnan(step.energy)


@pytest.mark.parametrize("model", MODELS)
def test_small_load_matches_linear_beam(model):
    p = 1e-3  # P L^2 / EI
    sol = reports.solve(scaled(BASE, p / 10.0), model)
    assert sol.status == "converged", sol.message
    y = sol.steps[-1].outputs["tip.uy"]
    y_lin = -p / 3.0
    # The PRB family trades small-load accuracy for large deflections.  Its small-load
    # compliance follows from the model's geometry, derived by hand here (not taken from the
    # model): a rigid link of length gamma L on a spring K gives y = gamma^2 L^2 P / K.
    #   prb-short: pivot at L/2, K = EI/L, rigid link L/2 (Howell 2001 Sec. 5.2) -> 0.75 y_lin
    #   prb-1r: gamma = 0.852144, K_Theta = 2.654855 (Howell curve fit at n = 0) -> 3 gamma/K
    #   prb-fsm-N: N springs N EI/L at element midpoints -> (1 - 1/(4 N^2)) y_lin
    expected = {"prb-short": 0.75, "prb-1r": 3 * 0.852144 / 2.654855}
    if model.startswith("prb-fsm-") and model[-1].isdigit():  # not prb-fsm-auto
        n = int(model.rsplit("-", 1)[1])
        expected[model] = 1.0 - 1.0 / (4 * n * n)
    ratio = expected.get(model, 1.0)
    # every other PRB model: optimised for large deflection, within 5 % at small loads;
    # every non-PRB model is a consistent discretisation of the beam and must match to 2e-3.
    tol = 2e-3 if (model in expected or not model.startswith("prb")) else 0.05
    assert y / y_lin == pytest.approx(ratio, rel=tol)
