"""``engine._Path`` on a list of floats (``floats.Floats``) with the arithmetic written in place.

A path of a few unknowns (``prb-2r``, ``prb-3r``: two or three PRB angles) spends more on the
method call per vector operation of the generic ``_Path`` than on the operation itself.  For
the common options -- unit scales, no damping, nothing held fixed, no retraction, a
tridiagonal Hessian ``(d, e)`` -- ``FloatsPath`` does the same steps with the same
floating-point operations in the same order (the answers are bit-identical), the list
arithmetic inlined; any other case falls back to ``_Path``'s own methods.
"""

from __future__ import annotations

import math
from typing import Any

from reduced_models.paths.floats import Floats, _ldl_factor_solve, _ldl_solve
from reduced_models.paths.path_base import _Path


def plain(A: object, update: object) -> bool:
    """Whether ``FloatsPath`` applies: ``Floats`` of at least one unknown with unit scales,
    no cap, nothing fixed, no retraction."""
    if not isinstance(A, Floats) or update is not None:
        return False
    return A.n > 0 and A.w is None and A.cap is None and not A.has_fixed


class FloatsPath(_Path):
    """``_Path`` for ``plain`` list-of-float arithmetic (module docstring)."""

    def solve(self, x: list, lam: float) -> tuple[tuple | None, int, str]:
        """``_Path.solve``: Newton on g(x) = 0, tridiagonal H by L D L^T (pivoted LU when
        indefinite, ``Floats.factor_solve``)."""
        gh, xtol, gtol, n = self.gh, self.xtol, self.gtol, self.A.n
        isfinite, factor_solve = math.isfinite, self.A.factor_solve
        prev_res = math.inf
        for it in range(1, self.max_iter + 1):
            g, H = gh(x, lam)
            res = max(map(abs, g))
            if not isfinite(sum(g)):
                return None, it, "non-finite residual"
            fs = None if callable(H) else _ldl_factor_solve(H[0], H[1], g, n)
            try:
                sol, pd, factor = (fs[1], True, ("ldl", fs[0])) if fs else factor_solve(H, g, 1)
            except (ArithmeticError, ValueError) as exc:
                return None, it, f"singular tangent ({exc})"
            size = max(map(abs, sol))
            if not isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    return (x, res, self._stable(x, lam, H, pd), factor), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            prev_res = res
            x = [a - b for a, b in zip(x, sol)]
        return None, self.max_iter, f"no convergence in {self.max_iter} its"

    def tangent(self, c: tuple, lam: float) -> list | None:
        """``_Path.tangent``: -H^-1 dg/dlam from the last solve's factor."""
        if self.load_gradient is None:
            return None
        factor, b = c[3], self.load_gradient(c[0], lam)
        r = _ldl_solve(factor[1], b, self.A.n) if factor[0] == "ldl" else self.A.resolve(factor, b)
        t = [-v for v in r]
        return t if math.isfinite(sum(t)) else None

    def predict(self, x: list, x_prev: list | None, t: list | None, t_prev: list | None,
                s: float, lam: float, lam_prev: Any) -> list | None:  # fmt: skip
        """``_Path.predict``."""
        if x_prev is None or lam == lam_prev:
            return None if t is None else [a + b * s for a, b in zip(x, t)]
        h = lam - lam_prev
        back = [a - b for a, b in zip(x_prev, x)]
        f = -s / h
        secant = [a * f for a in back]
        if t is not None:
            u = s / h
            c2 = u * u
            c3 = c2 + c2 * u if t_prev is not None else 0.0
            a1, a2 = s + h * (c2 + c3), c2 + 2.0 * c3
            if t_prev is None:
                poly = [p * a1 + q * a2 for p, q in zip(t, back)]
            else:
                a3 = h * c3
                poly = [p * a1 + q * a2 + r * a3 for p, q, r in zip(t, back, t_prev)]
            if sum([a * a for a in poly]) <= 9.0 * sum([a * a for a in secant]):
                return [a + b for a, b in zip(x, poly)]
        return [a + b for a, b in zip(x, secant)]

    def branch_jump(self, cur: tuple, conv: tuple, x: list, x_prev: list | None, lam: float,
                    lam_prev: Any) -> str:  # fmt: skip
        """``_Path.branch_jump``."""
        if not self.keep_branch:
            return ""
        if cur[2] is True and conv[2] is False:
            return "the step left the stable branch"
        if x_prev is not None and lam != lam_prev:
            if sum([(a - b) * (b - c) for a, b, c in zip(conv[0], x, x_prev)]) < 0:
                return "the path turned back (branch jump)"
        return ""
