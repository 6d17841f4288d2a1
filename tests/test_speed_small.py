"""Closed-form tangent solves of the plain-float paths against finite differences.

``chain_small`` solves the one-segment (bcm, linear-1) tangent system in closed form instead
of a dense LU; the check here is independent of that derivation: the Hessian is built by
central differences of the gradient, and the closed-form solution must satisfy it.
"""

from __future__ import annotations

import numpy as np
import pytest

import cases
from reduced_models.beam import single_beam
from reduced_models.beam.bcm import BCM
from reduced_models.beam.chain_small import single_segment_functions


@pytest.mark.parametrize("case", ["cantilever-tip-load", "fixed-guided-beam"])
@pytest.mark.parametrize("p", [-2.0, 0.0, 3.0])
def test_closed_form_solve_matches_finite_difference_hessian(case: str, p: float) -> None:
    model = BCM()
    prob = model.problem(single_beam.cantilever_of(cases.load(case)))
    gh, _, _ = single_segment_functions(prob)
    x = [0.93, 0.21, 0.37 if not prob.guided else 0.0, p]
    lam, eps = 0.7, 1e-6
    H = np.zeros((4, 4))
    for j in range(4):
        xp, xm = list(x), list(x)
        xp[j] += eps
        xm[j] -= eps
        H[:, j] = (np.array(gh(xp, lam)[0]) - np.array(gh(xm, lam)[0])) / (2 * eps)
    if prob.guided:  # phi held: identity row and column
        H[2, :] = H[:, 2] = 0.0
        H[2, 2] = 1.0
    b = [0.3, -1.1, 0.0 if prob.guided else 0.5, 0.8]
    s = gh(x, lam)[1](b)
    assert np.allclose(H @ np.array(s), b, rtol=0, atol=1e-6)
