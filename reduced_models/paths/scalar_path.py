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

import numpy as np

from reduced_models.paths.path_result import PathResult, limit_note


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
    out_f, out_x, out_it, out_cut, out_res, out_stab = [], [], [], [], [], []

    def result(ok: bool, reason: str) -> PathResult:
        return PathResult(
            factors=np.array(out_f),
            states=np.array(out_x, dtype=float).reshape(len(out_x), 1),
            iterations=np.array(out_it, dtype=int),
            cuts=np.array(out_cut, dtype=int),
            residuals=np.array(out_res),
            stable=out_stab,
            ok=ok,
            reason=reason,
        )

    def tangent(c: tuple, lam: float) -> float | None:
        if load_gradient is None:
            return None
        t = -load_gradient(c[0], lam) / c[3]
        return t if abs(t) < math.inf else None

    factors = [float(f) for f in factors]
    if not factors:
        return result(True, "")
    lam0 = factors[0]
    cur, its, why = _newton(grad_hess, float(x0), lam0, xtol, gtol, max_iter)
    if cur is None:
        return result(False, f"no equilibrium at factor {lam0:.6g}: {why}")
    out_f.append(lam0), out_x.append(cur[0]), out_it.append(its), out_cut.append(0)
    out_res.append(cur[1]), out_stab.append(cur[2])
    lam_cur, x_prev, h_prev = lam0, None, 0.0
    t_cur, t_prev = tangent(cur, lam_cur), None
    dlam = None
    for target in factors[1:]:
        its_total, cuts_total, consecutive = 0, 0, 0
        span = target - lam_cur
        direction = 1.0 if span >= 0 else -1.0
        step = abs(span) if dlam is None else min(dlam, abs(span))
        min_step = abs(span) * 0.5**max_cuts
        while abs(target - lam_cur) > 1e-14 * max(1.0, abs(target)):
            lam_try = lam_cur + direction * step
            if direction * (target - lam_try) < 1e-9 * step:
                lam_try = target
            x_cur = cur[0]
            s = lam_try - lam_cur
            d = _predict(x_cur, x_prev, t_cur, t_prev, s, h_prev)
            conv, its, why = _newton(
                grad_hess, x_cur if d is None else x_cur + d, lam_try, xtol, gtol, max_iter
            )
            its_total += its
            if conv is None and d is not None:
                conv, its, why = _newton(grad_hess, x_cur, lam_try, xtol, gtol, max_iter)
                its_total += its
            if conv is not None and 0.5 * abs(s) >= min_step:  # branch keeping
                if cur[2] and not conv[2]:
                    conv, why = None, "the step left the stable branch"
                elif x_prev is not None and (conv[0] - x_cur) * (x_cur - x_prev) < 0:
                    conv, why = None, "the path turned back (branch jump)"
            if conv is None:
                cuts_total += 1
                consecutive += 1
                step = 0.5 * abs(s)
                if consecutive > max_cuts or step < min_step:
                    h0 = grad_hess(float(x0), lam0)[1]
                    ratio = abs(grad_hess(x_cur, lam_cur)[1]) / max(abs(h0), 1e-300)
                    return result(
                        False,
                        f"Newton failed between factors {lam_cur:.6g} and {lam_try:.6g} "
                        f"after {cuts_total} step cuts ({why}); " + limit_note(ratio, lam_cur),
                    )
                continue
            consecutive = 0
            x_prev, h_prev = x_cur, s
            cur, lam_cur = conv, lam_try
            t_prev, t_cur = t_cur, tangent(cur, lam_cur)
            step = 2.0 * abs(s) if its <= 4 else abs(s)
            dlam = step
        out_f.append(lam_cur), out_x.append(cur[0]), out_it.append(its_total)
        out_cut.append(cuts_total), out_res.append(cur[1]), out_stab.append(cur[2])
    return result(True, "")
