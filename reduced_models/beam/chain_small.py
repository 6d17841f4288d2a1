"""One-segment chains (``bcm``, ``linear-1``) on plain floats (``paths.floats``).

With one segment clamped at the origin the chain's unknowns reduce to the tip state and the
axial force, y = [X, Y, phi, p] (normalised as in ``reduced_models.beam.chain``; the segment
frame is the beam frame, so ux = X - 1, w = (Y, phi) and the retraction is plain addition).
The mixed Lagrangian of ``chain.SegmentLaw``

    l(ux, w, p) = 1/2 w.G.w + p (ux + 1/2 w.P.w) - 1/2 p^2 (k - w.Q.w)

has the gradient [p, (G + p P + p^2 Q) w, ux + 1/2 w.P.w - p (k - w.Q.w)] and a 4x4 Hessian
written out below; stability is ``ChainProblem.stability``'s test for this case: p condensed
(its pivot capped at -1e-9, as there) and the 3x3 (guided: 2x2) remainder positive definite,
which reduces to the transverse stiffness K = G + p P + p^2 Q being positive definite.
A handful of floats per iteration instead of the band machinery of N segments: the path
costs what its equations cost.

With P = Q = 0 (``linear-1``: linear beam theory) those equations are linear in the load
factor -- p = lam fX, G w = lam (fY, m), ux = k p -- so ``solve_linear_segment`` solves them
once (one 2x2 factorisation for the whole path) and scales the solution by each factor.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from reduced_models.beam.chain import ChainProblem
from reduced_models.paths.engine import minimize_path
from reduced_models.paths.path_result import PathResult


def single_segment_functions(prob: ChainProblem) -> tuple:
    """``(grad_hess, load_gradient, stability)`` of a one-segment, dead-load chain."""
    G, P, Q = (np.asarray(M, dtype=float).tolist() for M in (prob.law.G, prob.law.P, prob.law.Q))
    k = prob.k
    fX, fY, m = (float(v) for v in prob.loads)

    (g00, g01), (g10, g11) = G
    (p00, p01), (p10, p11) = P
    (q00, q01), (q10, q11) = Q
    guided = prob.guided

    def grad_hess(x: list, lam: float) -> tuple[list, Callable]:
        X, Y, phi, p = x
        pw0, pw1 = p00 * Y + p01 * phi, p10 * Y + p11 * phi  # P w
        qw0, qw1 = q00 * Y + q01 * phi, q10 * Y + q11 * phi  # Q w
        D = k - (Y * qw0 + phi * qw1)
        pp = p * p
        k00, k01 = g00 + p * p00 + pp * q00, g01 + p * p01 + pp * q01  # K = G + pP + p^2 Q
        k10, k11 = g10 + p * p10 + pp * q10, g11 + p * p11 + pp * q11
        g = [
            p - lam * fX,
            k00 * Y + k01 * phi - lam * fY,
            0.0 if guided else k10 * Y + k11 * phi - lam * m,  # guided: phi held (identity)
            X - 1.0 + 0.5 * (Y * pw0 + phi * pw1) - p * D,
        ]
        c0, c1 = pw0 + 2.0 * p * qw0, pw1 + 2.0 * p * qw1  # c = P w + 2 p Q w
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

    def stability(x: list, lam: float, H: object) -> bool:
        # p condensed (pivot hpp = min(-D, -1e-9) < 0) leaves M = Hg - c c^T / hpp in (X, Y,
        # phi) with M_XX = -1/hpp > 0; the Schur complement of M_XX is K itself (the c c^T
        # terms cancel), so by Sylvester's criterion M is positive definite iff K is
        p = x[3]
        k00 = g00 + p * p00 + p * p * q00
        if guided:
            return k00 > 0.0
        k01, k11 = g01 + p * p01 + p * p * q01, g11 + p * p11 + p * p * q11
        return k00 > 0.0 and k00 * k11 - k01 * k01 > 0.0

    return grad_hess, load_gradient, stability


def solve_single_segment(prob: ChainProblem, factors: np.ndarray) -> PathResult:
    """``engine.minimize_path`` of a one-segment dead-load chain on floats; states in
    the chain's full layout (m, 8) with the clamped root node first."""
    gh, lg, stab = single_segment_functions(prob)
    res = minimize_path(
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


def solve_linear_segment(prob: ChainProblem, factors: np.ndarray) -> PathResult:
    """The path of a one-segment, dead-load chain whose law has P = Q = 0 (module
    docstring): one 2x2 solve, every state proportional to its load factor.  States in the
    chain's full layout (m, 8); one iteration for the path (the factorisation), stable iff
    G is positive definite (``single_segment_functions``' test with p-independent K)."""
    (g00, g01), (g10, g11) = np.asarray(prob.law.G, dtype=float).tolist()
    fX, fY, m = (float(v) for v in prob.loads)
    if prob.guided:  # the tip rotation is held: G00 Y = fY, the moment is a reaction
        Y1, phi1, stable = fY / g00, 0.0, g00 > 0.0
    else:
        det = g00 * g11 - g01 * g10
        Y1, phi1 = (g11 * fY - g01 * m) / det, (g00 * m - g10 * fY) / det
        stable = g00 > 0.0 and det > 0.0
    lam = np.asarray(factors, dtype=float)
    n = lam.size
    states = np.zeros((n, prob.n))
    states[:, 4] = 1.0 + prob.k * fX * lam  # ux = k p
    states[:, 5], states[:, 6], states[:, 7] = Y1 * lam, phi1 * lam, fX * lam
    # the residual of the linear equations at the scaled states (round-off only)
    r1 = max(
        abs(g00 * Y1 + g01 * phi1 - fY), 0.0 if prob.guided else abs(g10 * Y1 + g11 * phi1 - m)
    )
    iterations = np.zeros(n, dtype=int)
    iterations[:1] = 1
    return PathResult(
        lam, states, iterations, np.zeros(n, dtype=int), np.abs(lam) * r1, [stable] * n, True,
        "",
    )  # fmt: skip
