"""A dead-load chain's stable load path by Newton in the chain's own coordinates
(``linear-N``, ``cbcm-N``, N > 1; the fast path of ``ChainModel.solve``).

Same equilibrium equations as ``chain.ChainProblem`` (the segment Lagrangian ``SegmentLaw``
with the tip loads), written in minimal coordinates: per segment i = 1..N its deformation
``(u_i, y_i, p_i)`` (ux, y and axial force in its base frame, as in ``chain``) and the
absolute node angle phi_i, with a_i = phi_i - phi_{i-1} and the node positions given by
forward kinematics, r_i = r_{i-1} + h e^{i phi_{i-1}} (1 + u_i + i y_i) (exactly: no
retraction).  Under dead tip loads (F, m) the total potential

    Pi = N sum_i l(u_i, y_i, a_i, p_i) - lam (F . r_N + m phi_N)

couples segment i to phi_{i-1} only through its tip-force work h F e^{-i phi_{i-1}} (forces
are transmitted: every segment sees the tip force in its own frame), and the angle phi_m
to segment m + 1 only (the moment of the load about node m accumulates into the curvature
term -d2(F . r_N)/dphi_m^2 = F . (r_{m+1} - r_m)).  So Newton's matrix in (u, y, p | phi) is
block-tridiagonal with 3x3 segment blocks that need no factorisation (their rows are
[[0, 0, N], [0, N K00, .], [N, ., -N D]]: solved in closed form); condensing them leaves an
N x N symmetric tridiagonal matrix in the angles, solved and factorised by LAPACK
``dptsv`` -- O(N) per iteration, one LAPACK call.

Stability: the mixed Hessian is stable iff it has exactly N negative eigenvalues (one per
axial multiplier, ``ChainProblem.stability``); by inertia additivity (Haynsworth) that is
every segment block having exactly one (its determinant is -N^3 K00: K00 > 0) and the angle
matrix positive definite, which ``dptsv`` decides on the way.  At an equilibrium the
minimal coordinates' Hessian is congruent to the node coordinates' one, so the verdict is
``ChainProblem.stability``'s (which caps the axial pivot of an inextensible segment at
-1e-9 N^3, an axial penalty EA = 1e9 EI/L^2 this exact elimination does not need).

This path follows the load ramp one increment per reported factor, Newton from the Hermite
polynomial through the last three converged states and their exact tangents (``predict``),
with the engine's convergence test (scaled update <= xtol; here in these coordinates, u
and y per segment length, p per unit global force: a bound on the node update) and its
branch test.  The reported residual is max |g| in these coordinates.  Iterates on the way
may be indefinite (solved by tridiagonal LU); anything else -- a Newton failure also from
the last converged state, an accepted state that is not stable, a path turning back --
returns None, and
``ChainModel`` follows the path with the general continuation
(``paths.engine.minimize_path``) from the start: off this path, states, verdicts, critical
points and messages are the general engine's.  On this path the equilibria are the same to
the convergence tolerance (answers within 1e-10 of the engine's); the Newton iteration
counts are lower (cantilever-tip-load: 48 instead of 72 for cbcm-16).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.linalg import lapack

from reduced_models.beam.chain import NB, ChainProblem
from reduced_models.paths.path_result import PathResult

_dptsv, _dpttrs, _dgtsv = lapack.dptsv, lapack.dpttrs, lapack.dgtsv
_ZERO = np.zeros(1)
_GRAD_ROWS = (0, 1, 3)  # state rows u, y, p (row 2: phi)


@functools.lru_cache(maxsize=64)
def _hermite_weights(v: tuple[float, ...], at: float) -> tuple[list, list]:
    """Weights of the values and of the slopes (times the step) at nodes ``v`` that give the
    Hermite interpolant's value at ``at`` (all in units of the last step): the transposed
    confluent Vandermonde system, exact for every polynomial of degree < 2 len(v).  Equal
    steps hit the cache."""
    n = 2 * len(v)
    powers = np.arange(n)
    V = np.empty((n, n))
    V[0::2] = np.power.outer(v, powers)
    V[1::2] = powers * np.power.outer(v, np.maximum(powers - 1, 0))
    wts = np.linalg.solve(V.T, np.power(at, powers))
    return wts[0::2].tolist(), wts[1::2].tolist()


class ChainPath:
    """Newton in minimal coordinates along a load ramp (module docstring).

    Parameters
    ----------
    prob : a dead-load chain (``prob.follower`` False, N > 1).
    xtol, max_iter : the engine's convergence tolerance on the scaled update and Newton
        iterations per attempt.

    States are (4, N) arrays, rows ``(u, y, phi, p)`` over the segments (phi: the segment's
    tip node angle); ``nodes`` turns them into ``ChainProblem``'s layout.
    """

    def __init__(self, prob: ChainProblem, xtol: float = 1e-10, max_iter: int = 25) -> None:
        self.xtol, self.max_iter = xtol, max_iter
        self.N, self.h = prob.N, prob.h
        fX, fY, self.m = (float(v) for v in prob.loads)
        self.hF = complex(fX, fY) * prob.h
        self.free = prob.N - 1 if prob.guided else prob.N  # angles solved for
        # scaled size of an update: geometry as it is, p per unit of the global force
        self.w = np.array([1.0, 1.0, 1.0, prob.N**2])[:, None]
        self._coef = prob.N * prob.law.coefficients(prob.k).T  # (20, 18)
        self._mono = np.ones((3, 6, prob.N))

    def _law(self, u: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``N SegmentLaw.block`` as rows: (20, N), row 5 r + c = entry (r, c) of the
        segment's ``[d2l | dl]`` in (ux, y, a, p) (one matrix product, contiguous rows):
        rows 4, 9, 19, 14 the gradient in (ux, y, p, a), rows 6, 8, 18, 7, 17, 12 the
        segment block's entries (y, y), (y, p), (p, p), (y, a), (p, a), (a, a)."""
        mono = self._mono  # p^i (1, y, a, y^2, y a, a^2), i = 0, 1, 2; row 0 holds ones
        m0 = mono[0]
        m0[1], m0[2] = y, a
        np.multiply(y, m0[1:3], out=m0[3:5])
        np.multiply(a, a, out=m0[5])
        np.multiply(p, m0, out=mono[1])
        np.multiply(p, mono[1], out=mono[2])
        E = self._coef @ mono.reshape(18, -1)
        E[19] += self.N * u  # dl/dp = ux + ...
        return E

    def _system(self, s: np.ndarray, lam: float) -> tuple:
        """Residual and the condensed angle system at state ``s`` (4, N) (module docstring).

        Returns the segment blocks' solutions S^-1 [g, v, w, dW] as rows (u, y, p), each
        (4, N) (dW: minus the load rate of g), the angle matrix (diagonal (N,),
        off-diagonal (N - 1,)), the condensed angle residual (N,), the residual g (4, N),
        the condensed angle load rate (N,) and whether every segment block has exactly one
        negative eigenvalue (K00 > 0).
        """
        N = self.N
        u, y, phi, p = s
        prev = np.concatenate((_ZERO, phi[:-1]))
        E = self._law(u, y, phi - prev, p)
        floc = self.hF * np.exp(-1j * prev)  # h F in each segment's base frame (lam = 1)
        work = floc * ((1.0 + u) - 1j * y)  # h F conj(segment vector)
        # load derivative of the residual (lam = 1), rows u, y, p, phi: minus the work rates
        dW = np.zeros((4, N))
        dW[:2] = floc.view(float).reshape(N, 2).T
        dW[3, :-1] = work.imag[1:]  # d(F . r_N)/dphi_m = F . (i h e^{i phi_m} z_{m+1})
        dW[3, -1] = self.m
        g = np.empty((4, N))
        g[0], g[1], g[2], g[3] = E[4], E[9], E[19], E[14]  # dl/d(ux, y, p, a)
        g[3, :-1] -= E[14, 1:]  # d/dphi_m = d/da_m - d/da_{m+1}
        g -= lam * dW
        if self.free < N:
            g[3, -1] = 0.0
        byy, byp, bpp, bya, bpa, baa = E[6], E[8], E[18], E[7], E[17], E[12]
        blocks_ok = float(byy.min()) > 0.0  # each segment block has one negative eigenvalue
        # right-hand sides [g, v, w, dW] by rows u, y, p; v, w: couplings of (u, y, p)_i to
        # phi_i and phi_{i-1} (w with the load's -d2(F . r_N)/d(u, y)_i dphi_{i-1})
        wu, wy = -lam * dW[1], lam * dW[0] - bya
        rhs = np.empty((3, 4, N))  # rows u, y, p x columns [g, v, w, dW]
        rhs[:, 0], rhs[:, 3] = g[:3], dW[:3]
        rhs[0, 1], rhs[1, 1], rhs[2, 1] = 0.0, bya, bpa
        rhs[0, 2], rhs[1, 2], rhs[2, 2] = wu, wy, -bpa
        # S = [[0, 0, N], [0, byy, byp], [N, byp, bpp]] (d2l/dux dp = 1): closed form
        sol = np.empty((3, 4, N))
        su, sy, sp_ = sol
        np.divide(rhs[0], N, out=sp_)
        np.divide(rhs[1] - byp * sp_, byy, out=sy)
        np.divide(rhs[2] - byp * sy - bpp * sp_, N, out=su)
        vs = bya * sy + bpa * sp_  # v . S^-1 [g, v, w, dW]
        ws = wu * su + wy * sy - bpa * sp_  # w . S^-1 [g, v, w, dW]
        d = baa - vs[1]
        d[:-1] += baa[1:] - ws[2, 1:] + lam * work.real[1:]  # -d2(F . r_N)/dphi_m^2
        off = -baa[1:] - vs[2, 1:]
        r = g[3] - vs[0]  # condensed angle residual (Newton) and load rate (tangent)
        r[:-1] -= ws[0, 1:]
        rt = dW[3] - vs[3]
        rt[:-1] -= ws[3, 1:]
        return sol, d, off, r, g, rt, blocks_ok

    def _back(self, sol: np.ndarray, dphi: np.ndarray, col: int, sign: float) -> np.ndarray:
        """Update (4, N) from the angle update dphi (N,): (u, y, p) from the segment blocks
        (``sol``: S^-1 [g, v, w, dW] by rows u, y, p), ``sign`` times column ``col`` their own
        part (-S^-1 g for Newton, col 0; S^-1 dW for the tangent, col 3)."""
        out = np.empty((NB, self.N))
        for row, part in zip(_GRAD_ROWS, sol):  # 1-D rows: numpy's fast path
            o = out[row]
            np.multiply(part[1], dphi, out=o)
            np.subtract(part[col] * sign, o, out=o)
            o[1:] -= part[2, 1:] * dphi[:-1]  # phi_{i-1}: none for the first segment
        out[2] = dphi
        return out

    def _solve_angles(self, d: np.ndarray, off: np.ndarray, r: np.ndarray) -> tuple:
        """(factor or None, solution (N,)) of the angle system (a guided tip's angle held):
        the L D L^T factor if it is positive definite, else None and the solution by
        tridiagonal LU (an iterate on the way may be indefinite; a singular system gives a
        non-finite solution)."""
        n = self.free
        out = np.zeros(self.N)
        if n == 1:  # LAPACK wants at least one off-diagonal entry
            out[0] = r[0] / d[0] if d[0] != 0.0 else np.inf
            return (d[:1] if d[0] > 0.0 else None), out
        df, ef, x, info = _dptsv(d[:n], off[: n - 1], r[:n])
        if info == 0:
            out[:n] = x
            return (df, ef), out
        x, info = _dgtsv(off[: n - 1], d[:n], off[: n - 1], r[:n])[3:]
        out[:n] = x if info == 0 else np.inf
        return None, out

    def _resolve_angles(self, factor: tuple | np.ndarray, r: np.ndarray) -> np.ndarray:
        """The angle system solved again with a factor of ``_solve_angles``."""
        out = np.zeros(self.N)
        n = self.free
        out[:n] = r[0] / factor[0] if n == 1 else _dpttrs(*factor, r[:n])[0]
        return out

    def newton(self, s: np.ndarray, lam: float) -> tuple[tuple | None, int]:
        """Newton from ``s`` at factor ``lam``: ((s, residual, tangent ds/dlam) or None,
        iterations)."""
        xtol, w = self.xtol, self.w
        for it in range(1, self.max_iter + 1):
            sol, d, off, r, g, rt, blocks_ok = self._system(s, lam)
            ang = self._solve_angles(d, off, -r)
            ds = self._back(sol, ang[1], 0, -1.0)
            size = float(np.abs(ds * w).max())
            if not size < 1e6:  # diverged or not finite
                return None, it
            if size <= xtol:
                if ang[0] is None or not blocks_ok:  # not stable: the general path decides
                    return None, it
                dphi = self._resolve_angles(ang[0], rt)
                res = float(np.abs(g).max())
                return (s, res, self._back(sol, dphi, 3, 1.0)), it
            geo = float(np.abs(ds[:3]).max())
            if geo > 0.5:  # the engine's damping: at most 0.5 per update in geometry
                ds *= 0.5 / geo
            s = s + ds
        return None, self.max_iter

    def wdot(self, a: np.ndarray, b: np.ndarray) -> float:
        """Scaled dot product of two (N, 4) states."""
        w = self.w
        return float(((a * w) * (b * w)).sum())

    def predict(self, hist: list, lam: float) -> np.ndarray:
        """Start at factor ``lam`` from the last (up to) three converged states and their
        tangents ``hist`` = [(factor, state, tangent), ...]: the Hermite polynomial through
        them (degree 5, 3 or 1: the tangent line on the first increment) or, where it runs
        more than 3 times further than the secant (next to a limit point; the engine's
        test), the secant.  Three states rather than the engine's two: the quintic's start
        is 10-40 times closer on a smooth path (measured: 1e-5..1e-7 scaled on
        cantilever-tip-load), which saves about one Newton iteration per step."""
        lam0, x, _ = hist[-1]
        if len(hist) == 1:
            return x + hist[0][2] * (lam - lam0)
        h = lam0 - hist[-2][0]
        v = tuple(round((f - lam0) / h, 12) for f, _, _ in hist)
        wx, wt = _hermite_weights(v, round((lam - lam0) / h, 12))
        poly = -x
        for (_, xs, ts), a, b in zip(hist, wx, wt):
            poly = poly + xs * a + ts * (b * h)
        secant = (x - hist[-2][1]) * ((lam - lam0) / h)
        if self.wdot(poly, poly) <= 9.0 * self.wdot(secant, secant):
            return x + poly
        return x + secant

    def nodes(self, states: np.ndarray) -> np.ndarray:
        """``ChainProblem`` layout (m, 4 (N + 1)) of states (m, 4, N) by forward kinematics."""
        m, N = states.shape[0], self.N
        u, y, phi, p = states.transpose(1, 0, 2)
        prev = np.zeros((m, N))
        prev[:, 1:] = phi[:, :-1]
        r = np.cumsum(self.h * np.exp(1j * prev) * (1.0 + u + 1j * y), axis=1)
        out = np.zeros((m, N + 1, NB))
        out[:, 1:, 0], out[:, 1:, 1] = r.real, r.imag
        out[:, 1:, 2], out[:, 1:, 3] = phi, p
        return out.reshape(m, -1)

    def follow(self, factors: list[float]) -> PathResult | None:
        """The path through ``factors``, one increment per reported factor; None where the
        fast path does not apply (module docstring)."""
        conv, its = self.newton(np.zeros((NB, self.N)), factors[0])
        if conv is None:
            return None
        xs, its_all, res = [conv[0]], [its], [conv[1]]
        hist = [(factors[0], conv[0], conv[2])]
        for target in factors[1:]:
            conv, its = self.newton(self.predict(hist, target), target)
            if conv is None:  # the predictor can overshoot near a limit: from the last state
                conv, more = self.newton(hist[-1][1], target)
                its += more
            if conv is None:
                return None
            x = hist[-1][1]
            if len(hist) > 1 and self.wdot(conv[0] - x, x - hist[-2][1]) < 0:
                return None  # turned back: the engine's branch test
            hist = hist[-2:] + [(target, conv[0], conv[2])]
            xs.append(conv[0])
            its_all.append(its)
            res.append(conv[1])
        m = len(xs)
        return PathResult(
            np.array(factors, dtype=float), self.nodes(np.array(xs)),
            np.array(its_all, dtype=int), np.zeros(m, dtype=int), np.array(res),
            [True] * m, True, "",
        )  # fmt: skip
