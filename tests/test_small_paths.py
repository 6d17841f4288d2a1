"""The plain-float arithmetic of the continuation engine equals its array arithmetic on
every catalog single-beam case.

Short inextensible PRB chains (``prb-1r``, ``prb-2r``, ``prb-3r``: tridiagonal ``L D L^T`` on
floats) and one BCM or linear segment (``bcm``, ``linear-1``: a closed-form tangent solve,
``chain_small``) follow their path on lists of floats.  Each must give the array path -- same
reported factors, states within the solvers' tolerances, same stability verdicts -- on
every catalog case the model solves.  The array path is the independent side: its Hessians
are the numpy ones of ``PRBChain.grad_hess`` and ``ChainProblem.grad_hess`` (banded), its
solves LAPACK's, not the float code under test.
"""

from __future__ import annotations

import numpy as np
import pytest

import cases
from reduced_models.base import load_factors
from reduced_models.beam import single_beam
from reduced_models.beam.bcm import BCM
from reduced_models.beam.chain_small import single_segment_functions, solve_single_segment
from reduced_models.beam.linear import LinearChain
from reduced_models.beam.prb import PRB1R, PRB2R, PRB3R
from reduced_models.beam.prb_chain import RESIDUAL_TOL, PRBChain, equilibrium_path
from reduced_models.paths.engine import minimize_path


def _beam_cases() -> list[str]:
    return [
        c
        for c in cases.catalog_names()
        if not isinstance(single_beam.cantilever_of(cases.load(c)), str)
    ]


BEAM_CASES = _beam_cases()


def _same_path(fast, ref, atol: float) -> None:
    assert fast.ok == ref.ok, (fast.reason, ref.reason)
    assert np.array_equal(fast.factors, ref.factors)
    assert np.allclose(fast.states, ref.states, rtol=0.0, atol=atol)
    assert list(fast.stable) == list(ref.stable)


def _prb_general(chain: PRBChain, f1: np.ndarray, factors: np.ndarray, guided: bool):
    """``equilibrium_path`` on arrays (numpy Hessians, LAPACK solves)."""
    f1 = np.array([f1[0], f1[1], 0.0]) if guided else f1
    gh, lg = chain.path_functions(f1)
    return minimize_path(
        gh,
        np.zeros(chain.n),
        factors,
        scale=chain.scale,
        xtol=1e-6,
        gtol=RESIDUAL_TOL * chain.EI / chain.L,
        fixed=[chain.nj - 1] if guided else None,
        load_gradient=lg,
        symmetric=True,
    )


@pytest.mark.parametrize("model", [PRB1R(), PRB2R(), PRB3R()], ids=["prb-1r", "prb-2r", "prb-3r"])
@pytest.mark.parametrize("case", BEAM_CASES)
def test_prb_float_paths_equal_general_path(case: str, model) -> None:
    scene = cases.load(case)
    ready = model._prepare(scene)
    if isinstance(ready, str):
        pytest.skip(ready)
    beam, (matrix, _, _) = ready
    chain = PRBChain(matrix, beam.L, beam.EI, beam.EA)
    f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
    factors = load_factors(scene)
    fast = equilibrium_path(chain, f1, factors, guided=beam.guided)
    ref = _prb_general(chain, f1, factors, beam.guided)
    # both accept states whose residual is below 1e-8 EI/L: angles agree to ~1e-8 / k
    _same_path(fast, ref, atol=1e-7)


@pytest.mark.parametrize("model", [BCM(), LinearChain(1)], ids=["bcm", "linear-1"])
@pytest.mark.parametrize("case", BEAM_CASES)
def test_single_segment_path_equals_banded_path(case: str, model) -> None:
    scene = cases.load(case)
    beam = single_beam.cantilever_of(scene)
    if model.applies_to(scene) or beam.follower or scene.analysis.kind != "load":
        pytest.skip("not a dead-load ramp this model solves on the float path")
    prob = model.problem(beam)
    factors = load_factors(scene)
    fast = solve_single_segment(prob, factors)
    ref = model._path(prob, factors)
    # xtol 1e-10 on both: the states agree far below 1e-8
    _same_path(fast, ref, atol=1e-8)


@pytest.mark.parametrize("case", ["cantilever-tip-load", "fixed-guided-beam"])
def test_single_segment_stability_equals_condensed_banded_test(case: str) -> None:
    """The closed form (K = G + pP + p^2 Q positive definite) against ``ChainProblem.
    stability`` (p condensed, banded Cholesky) across the segment's buckling loads."""
    prob = BCM().problem(single_beam.cantilever_of(cases.load(case)))
    _, _, stab = single_segment_functions(prob)
    verdicts = set()
    for p in np.linspace(-40.0, 10.0, 101):
        y = [0.97, 0.12, 0.0 if prob.guided else 0.2, p]
        full = np.concatenate([prob.x0[:4], y])
        ref = prob.stability(full, 0.5, None)
        assert stab(y, 0.5, None) == ref, p
        verdicts.add(ref)
    assert verdicts == {True, False}  # both sides of the buckling loads were visited
