"""One-segment chains (``bcm``, ``linear-1``) on plain floats through ``small_path``.

With one segment clamped at the origin the chain's unknowns reduce to the tip state and the
axial force, y = [X, Y, phi, p] (normalised as in ``reduced_models.chain``; the segment
frame is the beam frame, so ux = X - 1, w = (Y, phi) and the retraction is plain addition).
The mixed Lagrangian of ``chain.SegmentLaw``

    l(ux, w, p) = 1/2 w.G.w + p (ux + 1/2 w.P.w) - 1/2 p^2 (k - w.Q.w)

has the gradient [p, (G + p P + p^2 Q) w, ux + 1/2 w.P.w - p (k - w.Q.w)] and a 4x4 Hessian
written out below; stability is ``ChainProblem.stability``'s test for this case: p condensed
(its pivot capped at -1e-9, as there) and the 3x3 (guided: 2x2) remainder positive definite,
which reduces to the transverse stiffness K = G + p P + p^2 Q being positive definite.
A handful of floats per iteration instead of the band machinery of N segments: the path
costs what its equations cost.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from reduced_models.chain import ChainProblem
from reduced_models.path_result import PathResult
from reduced_models.small_path import minimize_path_small


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

    guided = prob.guided

    def grad_hess(x: list, lam: float) -> tuple[list, Callable]:
        _, K, Kw, dp, cross, D = terms(x)
        g = [x[3] - lam * fX, Kw[0] - lam * fY, Kw[1] - lam * m, dp]
        if guided:  # phi held: its equation is an identity row
            g[2] = 0.0
        (k00, k01), (k10, k11) = K
        c0, c1 = cross
        det = k00 * k11 - k01 * k10

        def solve(b: list) -> list:
            """H s = b for H = [[0, 0, 0, 1], [0, K, c], [1, c^T, -D]] (rows X, Y, phi, p):
            the X row gives s_p, the (Y, phi) rows a 2x2 solve with K, the p row s_X."""
            sp = b[0]
            r0, r1 = b[1] - c0 * sp, b[2] - c1 * sp
            if guided:
                s1, s2 = r0 / k00, 0.0
            else:
                s1, s2 = (k11 * r0 - k01 * r1) / det, (k00 * r1 - k10 * r0) / det
            return [b[3] - c0 * s1 - c1 * s2 + D * sp, s1, s2, sp]

        return g, solve

    def load_gradient(x: list, lam: float) -> list:
        return [-fX, -fY, -m, 0.0]

    def stability(x: list, lam: float) -> bool:
        # p condensed (pivot hpp = min(-D, -1e-9) < 0) leaves M = Hg - c c^T / hpp in (X, Y,
        # phi) with M_XX = -1/hpp > 0; the Schur complement of M_XX is K itself (the c c^T
        # terms cancel), so by Sylvester's criterion M is positive definite iff K is
        p = x[3]
        k00 = G[0][0] + p * P[0][0] + p * p * Q[0][0]
        if guided:
            return k00 > 0.0
        k01 = G[0][1] + p * P[0][1] + p * p * Q[0][1]
        k11 = G[1][1] + p * P[1][1] + p * p * Q[1][1]
        return k00 > 0.0 and k00 * k11 - k01 * k01 > 0.0

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
