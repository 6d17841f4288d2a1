"""The generic path follower of ``engine.minimize_path``: one continuation (tangent or secant
predictor, Newton corrector, step cuts, branch watch) on any arithmetic of ``floats`` /
``linalg`` (the algorithm and its options: ``engine``'s docstring).  Its own module so that
the specialised followers (``engine._ScalarPath``, ``floats_path.FloatsPath``) subclass it
without an import circle."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from reduced_models.paths.path_result import PathResult, limit_note


def positive_definite(x: Any, lam: float, H: object) -> bool | None:
    """The default stability test of pure energy minimisation: is the Hessian positive
    definite?  (Decided by the Newton solve's factorisation where it can be; this call is
    the fallback, ``linalg.hessian_positive_definite``.)"""
    from reduced_models.paths.linalg import hessian_positive_definite

    return hessian_positive_definite(H)


class _Path:
    """One path's Newton solves, predictor and branch test in any arithmetic ``A``."""

    def __init__(self, A: Any, grad_hess: Callable, opts: dict, x0: Any, lam0: float) -> None:
        self.A, self.gh = A, grad_hess
        self.xtol, self.gtol, self.max_iter = opts["xtol"], opts["gtol"], opts["max_iter"]
        self.update, self.stability = opts["update"], opts["stability"]
        self.keep_branch, self.load_gradient = opts["keep_branch"], opts["load_gradient"]
        # a Cholesky in the Newton solves decides positive definiteness on the way
        self.chol = self.stability is positive_definite and opts["symmetric"] is True
        self.x0, self.lam0 = x0, lam0
        # what every Newton solve reads, looked up once (fixed unknowns: identity equations)
        evaluate = A.evaluate if A.has_fixed else None
        self._newton = (A, grad_hess, self.xtol, self.gtol, self.update, self.chol, evaluate,
                        A.absmax, A.factor_solve, A.size)  # fmt: skip
        self.f: list[float] = []
        self.x: list = []
        self.its: list[int] = []
        self.cuts: list[int] = []
        self.res: list[float] = []
        self.stable: list = []

    # -- Newton at one load factor --------------------------------------------------------------
    def solve(self, x: Any, lam: float) -> tuple[tuple | None, int, str]:
        """Newton from ``x`` at factor ``lam``: ((x, residual, stable, factor) or None,
        iterations, reason)."""
        A, gh, xtol, gtol, update, chol, evaluate, absmax, factor_solve, size_of = self._newton
        if A.n == 0:
            return (x, 0.0, None, None), 0, ""
        prev_res, isfinite = math.inf, math.isfinite
        for it in range(1, self.max_iter + 1):
            g, H = gh(x, lam) if evaluate is None else evaluate(gh, x, lam)
            res = absmax(g)
            if not isfinite(res):
                return None, it, "non-finite residual"
            try:
                sol, pd, factor = factor_solve(H, g, chol)
            except (ArithmeticError, ValueError) as exc:  # LinAlgError is a ValueError
                return None, it, f"singular tangent ({exc})"
            size = size_of(sol)
            if not isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    return (x, res, self._stable(x, lam, H, pd), factor), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            elif A.cap is not None:
                sol = A.damp(sol)
            prev_res = res
            x = A.sub(x, sol) if update is None else update(x, A.neg(sol))
        return None, self.max_iter, f"no convergence in {self.max_iter} its"

    def _stable(self, x: Any, lam: float, H: object, pd: bool | None) -> bool | None:
        if self.stability is None:
            return None
        if pd is not None and self.stability is positive_definite:
            return pd  # the factorisation of the last solve decided it
        return self.stability(x, lam, H)

    # -- between converged states --------------------------------------------------------------
    def tangent(self, c: tuple, lam: float) -> Any:
        """dx/dlam at a converged state from the factorisation of its last solve, or None."""
        A = self.A
        if self.load_gradient is None or A.n == 0:
            return None
        t = A.neg(A.resolve(c[3], A.zero_fixed(self.load_gradient(c[0], lam))))
        return t if A.finite(t) else None

    def predict(
        self, x: Any, x_prev: Any, t: Any, t_prev: Any, s: float, lam: float, lam_prev: Any
    ) -> Any:
        """Start for an increment ``s`` from ``x``: cubic Hermite, tangent line or secant
        (module docstring); None: from ``x`` itself."""
        A = self.A
        if x_prev is None or lam == lam_prev:
            return None if t is None else A.add(x, A.times(t, s))
        h = lam - lam_prev
        back = A.sub(x_prev, x)
        secant = A.times(back, -s / h)
        if t is not None:
            # cubic Hermite through the previous and current states and tangents (the
            # quadratic through the previous state if its tangent is unknown), written as
            # a1 t + a2 (x_prev - x) + a3 t_prev, u = s / h
            u = s / h
            c2 = u * u
            c3 = c2 + c2 * u if t_prev is not None else 0.0
            poly = A.comb(t, s + h * (c2 + c3), back, c2 + 2.0 * c3, t_prev, h * c3)
            # next to a bifurcation or limit point the tangent blows up: keep the secant
            # when the polynomial runs far beyond it (scaled 2-norms); the polynomial is
            # accurate in x itself, a retraction would add its own second-order terms
            if A.wdot(poly, poly) <= 9.0 * A.wdot(secant, secant):
                return A.add(x, poly)
        return A.add(x, secant) if self.update is None else self.update(x, secant)

    def branch_jump(self, cur: tuple, conv: tuple, x: Any, x_prev: Any, lam: float,
                    lam_prev: Any) -> str:  # fmt: skip
        """Why ``conv`` left the branch of ``cur`` ("" if it did not): a stable state followed
        by an unstable one, or a path that turns back on itself."""
        if not self.keep_branch:
            return ""
        if cur[2] is True and conv[2] is False:
            return "the step left the stable branch"
        if x_prev is not None and lam != lam_prev:
            A = self.A
            if A.wdot(A.sub(conv[0], x), A.sub(x, x_prev)) < 0:
                return "the path turned back (branch jump)"
        return ""

    def diagnose(self, c: tuple, lam: float) -> str:
        """Why load control stopped at ``c``: the model's own limit point (smallest
        |eigenvalue| of its tangent below 1 % of the unloaded state's) or not."""
        A = self.A
        try:
            here = A.min_abs_eig(A.evaluate(self.gh, A.vector(c[0]), lam)[1])
            start = A.min_abs_eig(A.evaluate(self.gh, A.vector(self.x0), self.lam0)[1])
            ratio = here / max(start, 1e-300)
        except (ArithmeticError, ValueError):
            ratio = float("nan")
        return limit_note(ratio, lam)

    def record(self, c: tuple, lam: float, its: int, cuts: int) -> None:
        """Keep one reported state."""
        self.f.append(float(lam))
        self.x.append(c[0])
        self.its.append(its)
        self.cuts.append(cuts)
        self.res.append(c[1])
        self.stable.append(c[2])

    def result(self, ok: bool, reason: str) -> PathResult:
        """The ``PathResult`` of the states kept so far."""
        return PathResult(
            factors=np.array(self.f),
            states=np.array(self.x, dtype=float).reshape(len(self.x), self.A.n),
            iterations=np.array(self.its, dtype=int),
            cuts=np.array(self.cuts, dtype=int),
            residuals=np.array(self.res),
            stable=self.stable,
            ok=ok,
            reason=reason,
        )

    # -- the load stepping ---------------------------------------------------------------------
    def follow(self, x0: Any, factors: Sequence[float], max_cuts: int) -> tuple[bool, str]:
        """Walk the path through ``factors`` (module docstring); (ok, reason it stopped)."""
        if len(factors) == 0:
            return True, ""
        conv, its, why = self.solve(x0, factors[0])
        if conv is None:
            return False, f"no equilibrium at factor {factors[0]:.6g}: {why}"
        self.record(conv, factors[0], its, 0)
        x_prev, lam_prev = None, None  # the converged state before the current one
        cur, lam_cur = conv, float(factors[0])
        t_cur, t_prev = self.tangent(cur, lam_cur), None
        dlam = None  # size of the last successful increment (carried to the next factor)
        for target in factors[1:]:
            target = float(target)
            its_total, cuts_total, consecutive = 0, 0, 0
            span = target - lam_cur
            direction = 1.0 if span >= 0 else -1.0
            step = abs(span) if dlam is None else min(dlam, abs(span))
            shortest = abs(span) * 0.5**max_cuts
            while abs(target - lam_cur) > 1e-14 * max(1.0, abs(target)):
                lam_try = lam_cur + direction * step
                if direction * (target - lam_try) < 1e-9 * step:
                    lam_try = target  # do not leave a sliver before the reported factor
                x_cur = cur[0]
                s = lam_try - lam_cur
                start = self.predict(x_cur, x_prev, t_cur, t_prev, s, lam_cur, lam_prev)
                conv, its, why = self.solve(x_cur if start is None else start, lam_try)
                its_total += its
                if conv is None and start is not None:
                    # the predictor can overshoot near a limit: retry from the last state
                    conv, its, why = self.solve(x_cur, lam_try)
                    its_total += its
                if conv is not None and 0.5 * abs(s) >= shortest:
                    jump = self.branch_jump(cur, conv, x_cur, x_prev, lam_cur, lam_prev)
                    if jump:
                        conv, why = None, jump
                if conv is None:
                    cuts_total += 1
                    consecutive += 1
                    step = 0.5 * abs(s)
                    if consecutive > max_cuts or step < shortest:
                        return False, (
                            f"Newton failed between factors {lam_cur:.6g} and {lam_try:.6g} "
                            f"after {cuts_total} step cuts ({why}); " + self.diagnose(cur, lam_cur)
                        )
                    continue
                consecutive = 0
                x_prev, lam_prev = x_cur, lam_cur
                step = abs(s)
                cur, lam_cur = conv, lam_try
                t_prev, t_cur = t_cur, self.tangent(cur, lam_cur)
                if its <= 4:  # easy step: allow a larger increment next time (carried on)
                    step *= 2.0
                dlam = step
            self.record(cur, lam_cur, its_total, cuts_total)
        return True, ""
