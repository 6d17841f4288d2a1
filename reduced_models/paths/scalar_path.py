"""Load continuation of one unknown on Python floats (``prb-1r``: one pivot angle).

``small_path.minimize_path_small`` with n = 1 written out on scalars: the same Newton test
(the evaluated iterate is accepted when its own correction ``|g / h| <= xtol`` and its
residual ``|g| <= gtol``), step halving and growth, cubic Hermite predictor from the path
tangents ``-g_lam / h``, and branch keeping (a stable state followed by an unstable one, or a
path turning back, is cut and retried).  Stability of a 1-DOF minimum is ``h > 0``.  For one
unknown the list comprehensions, factor tuples and dispatch of the n-unknown code cost more
than the equation itself (a sine, a cosine and a dozen flops); here a 20-step path costs a
few dozen such evaluations.  ``tests/test_speed_small.py`` checks it against the n-unknown
code on every catalog case.

Functions handed in: ``grad_hess(x, lam) -> (g, h)`` (floats: residual and its derivative),
``load_gradient(x, lam) -> dg/dlam`` (float).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from reduced_models.paths.path_result import PathResult, limit_note
from reduced_models.paths.stepper import Recorder, follow


def _newton(
    gh: Callable, x: float, lam: float, xtol: float, gtol: float | None, max_iter: int
) -> tuple[tuple | None, int, str]:
    """Newton at factor ``lam``: ((x, residual, stable, h) or None, iterations, reason)."""
    prev = math.inf
    for it in range(1, max_iter + 1):
        g, h = gh(x, lam)
        res = abs(g)
        if not res < math.inf:
            return None, it, "non-finite residual"
        if h == 0.0 or not abs(h) < math.inf:
            return None, it, "singular tangent"
        dx = g / h
        size = abs(dx)
        if size <= xtol:
            if gtol is None or res <= gtol:
                return (x, res, h > 0.0, h), it, ""
            if res > 0.5 * prev:
                return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
        elif size > 1e6:
            return None, it, "Newton diverged"
        prev = res
        x -= dx
    return None, max_iter, f"no convergence in {max_iter} its"


def _predict(
    x: float, x_prev: float | None, t: float | None, t_prev: float | None, s: float, h: float
) -> float | None:
    """Cubic Hermite (or tangent line, or secant) increment from x over a load step s; h is
    the previous load step.  As ``small_path._predict`` with one unknown."""
    dpred = None
    if x_prev is not None:
        back = x_prev - x
        dpred = back * (-s / h)
    if t is not None:
        if dpred is None:
            return t * s
        u = s / h
        c2 = u * u
        c3 = c2 + c2 * u if t_prev is not None else 0.0
        poly = t * (s + h * (c2 + c3)) + back * (c2 + 2.0 * c3)
        if t_prev is not None:
            poly += t_prev * (h * c3)
        if poly * poly <= 9.0 * dpred * dpred:
            return poly
    return dpred


def minimize_path_scalar(
    grad_hess: Callable,
    x0: float,
    factors: Sequence[float],
    *,
    xtol: float = 1e-10,
    gtol: float | None = None,
    max_iter: int = 25,
    max_cuts: int = 10,
    load_gradient: Callable | None = None,
) -> PathResult:
    """``small_path.minimize_path_small`` for one unknown (see the module docstring)."""
    factors = [float(f) for f in factors]
    rec = Recorder(1)
    lam0 = factors[0] if factors else 0.0
    engine = _Engine(grad_hess, rec, load_gradient, float(x0), lam0, xtol, gtol, max_iter)
    return rec.result(*follow(engine, float(x0), factors, max_cuts))


class _Engine:
    """``minimize_path_scalar``'s arithmetic for ``stepper.follow`` (one float)."""

    def __init__(
        self,
        grad_hess: Callable,
        rec: Recorder,
        load_gradient: Callable | None,
        x0: float,
        lam0: float,
        xtol: float,
        gtol: float | None,
        max_iter: int,
    ) -> None:
        self.gh, self.rec, self.load_gradient, self.x0, self.lam0 = (
            grad_hess,
            rec,
            load_gradient,
            x0,
            lam0,
        )
        self.xtol, self.gtol, self.max_iter = xtol, gtol, max_iter

    def solve(self, x: float, lam: float) -> tuple[tuple | None, int, str]:
        return _newton(self.gh, x, lam, self.xtol, self.gtol, self.max_iter)

    def state(self, c: tuple) -> float:
        return c[0]

    def tangent(self, c: tuple, lam: float) -> float | None:
        if self.load_gradient is None:
            return None
        t = -self.load_gradient(c[0], lam) / c[3]
        return t if abs(t) < math.inf else None

    def predict(
        self,
        x_cur: float,
        x_prev: float | None,
        t_cur: float | None,
        t_prev: float | None,
        s: float,
        lam_cur: float,
        lam_prev: float | None,
    ) -> float | None:
        h = 0.0 if lam_prev is None else lam_cur - lam_prev  # the previous load step
        d = _predict(x_cur, x_prev, t_cur, t_prev, s, h)
        return None if d is None else x_cur + d

    def branch_jump(
        self,
        cur: tuple,
        conv: tuple,
        x_cur: float,
        x_prev: float | None,
        lam_cur: float,
        lam_prev: float | None,
    ) -> str:
        """As ``continuation``'s: the stable branch left, or the path turned back."""
        if cur[2] and not conv[2]:
            return "the step left the stable branch"
        if x_prev is not None and (conv[0] - x_cur) * (x_cur - x_prev) < 0:
            return "the path turned back (branch jump)"
        return ""

    def diagnose(self, c: tuple, lam: float) -> str:
        h0 = self.gh(self.x0, self.lam0)[1]
        ratio = abs(self.gh(c[0], lam)[1]) / max(abs(h0), 1e-300)
        return limit_note(ratio, lam)

    def record(self, c: tuple, lam: float, its: int, cuts: int) -> None:
        self.rec.add(lam, c[0], its, cuts, c[1], c[2])
