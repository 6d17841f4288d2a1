"""One-segment chains (``bcm``, ``linear-1``) on plain floats through ``small_path``.

With one segment clamped at the origin the chain's unknowns reduce to the tip state and the
axial force, y = [X, Y, phi, p] (normalised as in ``reduced_models.chain``; the segment
frame is the beam frame, so ux = X - 1, w = (Y, phi) and the retraction is plain addition).
The mixed Lagrangian of ``chain.SegmentLaw``

    l(ux, w, p) = 1/2 w.G.w + p (ux + 1/2 w.P.w) - 1/2 p^2 (k - w.Q.w)

has the gradient [p, (G + p P + p^2 Q) w, ux + 1/2 w.P.w - p (k - w.Q.w)] and a 4x4 Hessian
written out below; stability is ``ChainProblem.stability``'s test for this case: p condensed
(its pivot capped at -1e-9, as there) and the 3x3 (guided: 2x2) remainder positive definite.
A handful of floats per iteration instead of the band machinery of N segments: the path
costs what its equations cost.
"""

from __future__ import annotations

import math

import numpy as np

from reduced_models.chain import ChainProblem
from reduced_models.path_result import PathResult
from reduced_models.small_path import minimize_path_small


def _pd(A: list) -> bool:
    """Positive definiteness of a small symmetric matrix (Cholesky succeeds)."""
    n = len(A)
    L = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = A[i][j] - sum(L[i][q] * L[j][q] for q in range(j))
            if i == j:
                if not s > 0.0:
                    return False
                L[i][i] = math.sqrt(s)
            else:
                L[i][j] = s / L[j][j]
    return True


def single_segment_functions(prob: ChainProblem) -> tuple:
    """``(grad_hess, load_gradient, stability)`` of a one-segment, dead-load chain."""
    G, P, Q = (np.asarray(M, dtype=float).tolist() for M in (prob.law.G, prob.law.P, prob.law.Q))
    k = prob.k
    fX, fY, m = (float(v) for v in prob.loads)

    def terms(x: list) -> tuple:
        X, Y, phi, p = x
        w = (Y, phi)
        Pw = [P[i][0] * Y + P[i][1] * phi for i in range(2)]
        Qw = [Q[i][0] * Y + Q[i][1] * phi for i in range(2)]
        wQw = Y * Qw[0] + phi * Qw[1]
        K = [[G[i][j] + p * P[i][j] + p * p * Q[i][j] for j in range(2)] for i in range(2)]
        Kw = [K[i][0] * Y + K[i][1] * phi for i in range(2)]
        dp = X - 1.0 + 0.5 * (Y * Pw[0] + phi * Pw[1]) - p * (k - wQw)
        cross = [Pw[i] + 2.0 * p * Qw[i] for i in range(2)]
        return w, K, Kw, dp, cross, k - wQw

    def grad_hess(x: list, lam: float) -> tuple[list, list]:
        _, K, Kw, dp, cross, D = terms(x)
        g = [x[3] - lam * fX, Kw[0] - lam * fY, Kw[1] - lam * m, dp]
        H = [
            [0.0, 0.0, 0.0, 1.0],
            [0.0, K[0][0], K[0][1], cross[0]],
            [0.0, K[1][0], K[1][1], cross[1]],
            [1.0, cross[0], cross[1], -D],
        ]
        return g, H

    def load_gradient(x: list, lam: float) -> list:
        return [-fX, -fY, -m, 0.0]

    def stability(x: list, lam: float) -> bool:
        _, K, _, _, cross, D = terms(x)
        hpp = min(-D, -1e-9)
        c = [1.0, cross[0], cross[1]]
        Hg = [[0.0, 0.0, 0.0], [0.0, K[0][0], K[0][1]], [0.0, K[1][0], K[1][1]]]
        keep = (0, 1) if prob.guided else (0, 1, 2)
        return _pd([[Hg[i][j] - c[i] * c[j] / hpp for j in keep] for i in keep])

    return grad_hess, load_gradient, stability


def solve_single_segment(prob: ChainProblem, factors: np.ndarray) -> PathResult:
    """``continuation.minimize_path`` of a one-segment dead-load chain on floats; states in
    the chain's full layout (m, 8) with the clamped root node first."""
    gh, lg, stab = single_segment_functions(prob)
    res = minimize_path_small(
        gh,
        [1.0, 0.0, 0.0, 0.0],
        factors,
        scale=prob.scale[4:].tolist(),
        fixed=(2,) if prob.guided else (),
        load_gradient=lg,
        max_step=prob.max_step[4:].tolist(),
        stability=stab,
    )
    states = np.zeros((len(res.factors), prob.n))
    states[:, 4:] = res.states
    return PathResult(
        res.factors, states, res.iterations, res.cuts, res.residuals, res.stable, res.ok,
        res.reason,
    )  # fmt: skip
