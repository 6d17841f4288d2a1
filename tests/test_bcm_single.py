"""``bcm`` under dead loads solves each step directly (``reduced_models.beam.bcm_single``).

Checked against what does not share its code: the Euler buckling loads bound the range of
p where the BCM stiffness is positive definite, and on every catalog single-beam case the
direct answer is the continuation engine's (``ChainModel.solve``: Newton on the mixed
Lagrangian with LAPACK-free float solves) to the engine's tolerance, with the same
stability verdicts, warnings, shapes and stress; where K(p) leaves its positive-definite
range the continuation runs as before.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cases
from reduced_models.beam import single_beam
from reduced_models.beam.bcm import BCM
from reduced_models.beam.chain_model import ChainModel

BEAM_CASES = [
    c
    for c in cases.catalog_names()
    if not isinstance(single_beam.cantilever_of(cases.load(c)), str)
]


def test_positive_definite_range_ends_near_the_euler_loads() -> None:
    """K(p) = G + pP + p^2 Q is the Taylor series of the beam-column stiffness: it turns
    singular next to the clamped-free (pi^2/4) and, with the tip angle held, the sway
    (pi^2) buckling loads of the exact beam-column."""
    lo, hi = BCM.pd_range(False)
    assert lo == pytest.approx(-(math.pi**2) / 4, rel=1e-3) and hi > 10.0
    lo, hi = BCM.pd_range(True)
    assert lo == pytest.approx(-(math.pi**2), rel=3e-3) and hi > 10.0


@pytest.mark.parametrize("case", BEAM_CASES)
def test_direct_solve_is_the_continuation(case: str) -> None:
    scene = cases.load(case)
    model = BCM()
    if model.applies_to(scene):
        pytest.skip(model.applies_to(scene))
    new, old = model.solve(scene), ChainModel.solve(model, scene)
    assert new.status == old.status
    assert [s.factor for s in new.steps] == [s.factor for s in old.steps]
    assert [s.stable for s in new.steps] == [s.stable for s in old.steps]
    assert new.extras.get("validity_message") == old.extras.get("validity_message")
    L = single_beam.cantilever_of(scene).L
    for a, b in zip(new.steps, old.steps):
        for key, v in a.outputs.items():
            size = 1.0 if key.endswith("rot") else L
            assert v == pytest.approx(b.outputs[key], rel=0, abs=1e-9 * size)
        assert a.energy == pytest.approx(b.energy, rel=1e-9, abs=1e-12)
        if "2x2 solve" in new.message:  # the direct route: its equations hold to round-off
            assert a.info["residual"] <= 1e-12 * max(1.0, abs(a.info["tip.fy"]))
    if new.steps and new.status == "converged":
        pa, pb = model.postprocess(scene, new), ChainModel.postprocess(model, scene, old)
        member = single_beam.cantilever_of(scene).member
        for a, b in zip(pa.steps, pb.steps):
            assert np.allclose(a.shapes[member], b.shapes[member], rtol=0, atol=1e-9 * L)
            assert (a.max_stress is None) == (b.max_stress is None)
            if a.max_stress is not None:
                assert a.max_stress == pytest.approx(b.max_stress, rel=1e-8)


def test_past_the_buckling_load_the_continuation_runs() -> None:
    """A compressive ramp past the BCM's clamped-free buckling load is the engine's."""
    scene = cases.load("cantilever-inclined-compression")
    sol = BCM().solve(scene)
    assert sol.status == "failed" and "Newton failed" in sol.message
