"""The continuation engine of the reduced models: Newton on an equilibrium residual along a
load ramp, with step cutting, a Hermite predictor and branch keeping.

Used by every energy-based single-beam reduced model (linear chains, BCM, chained BCM, the
PRB family).  One algorithm, two arithmetics: the state ``x0`` handed in decides which --
a numpy array (``linalg.Arrays``: dense LAPACK, ``Banded`` or sparse tangents) or, for a few
unknowns (at most ``floats.MAX_N``), a list of plain floats (``floats.Floats``: a tridiagonal
``L D L^T`` or a closed-form solve) or one bare float (``floats.Scalar``, its operations
written in place by ``_ScalarPath``), where a numpy call would cost more than the arithmetic
it does.  Every step of the algorithm below is the same
code for all of them.

API
---
``minimize_path(grad_hess, x0, factors, *, scale=None, xtol=1e-10, gtol=None, max_iter=25,
max_cuts=10, max_step=None, fixed=None, stability=positive_definite, update=None,
keep_branch=True, load_gradient=None, symmetric=None) -> PathResult``

* ``grad_hess(x, lam) -> (g, H)``: for a conservative model ``g`` is the gradient of the total
  potential ``Pi(x; lam) = U(x) - lam * W(x)`` and ``H`` its Hessian; any residual/Jacobian
  pair works (follower loads give an unsymmetric ``H``; a mixed Lagrangian an indefinite
  one).  On arrays ``H`` is a dense ``numpy.ndarray`` (LAPACK ``dgesv``, or ``dposv`` --
  Cholesky -- when ``symmetric`` and the stability test is ``positive_definite``), a
  ``Banded`` (``dgbsv`` / ``dpbsv``) or a ``scipy.sparse`` matrix (``splu``); on floats the
  forms of ``floats.Floats``.
* ``factors``: the load factors to report, shape (m,), usually starting at 0.  Newton at the
  first factor from ``x0``; between two reported factors an increment that starts at the
  last successful one (carried across reported factors), a predicted start (a failed one is
  retried from the last converged state), halving on a Newton failure or a branch jump,
  doubling after an easy step (<= 4 iterations), and a stop (``ok = False``) after
  ``max_cuts`` halvings in a row or once the increment falls below the reported interval /
  2^max_cuts.  Only the requested factors are returned.
* ``fixed``: indices of unknowns held at their ``x0`` value (supports): their equations are
  replaced by identity rows (band structure kept).
* Convergence is judged on the state returned: a Newton iteration evaluates ``g, H`` at
  ``x_k`` and solves for the update ``dx_k = -H^{-1} g(x_k)``; ``x_k`` is accepted when that
  correction is small, ``max |dx_k,i / scale_i| <= xtol`` (and, with ``gtol``,
  ``max |g(x_k)| <= gtol``).  The accepted state is ``x_k`` itself: its residual,
  factorisation, tangent and stability are all measured on it, at no extra evaluation.  A
  residual that stops falling while the update is already below ``xtol`` (a round-off floor
  above ``gtol``) fails the attempt.
* ``max_step``: optional cap (scalar or per unknown) on ``|dx_i / scale_i|`` per Newton
  update; a longer update is shortened as a whole (damping).
* ``update(x, dx) -> x_new``: optional retraction replacing ``x + dx`` (first-order equal).
* Predictor: with ``load_gradient(x, lam) -> dg/dlam`` (for dead loads ``-grad W``; called at
  the last point handed to ``grad_hess``), the path tangent ``dx/dlam = -H^{-1} dg/dlam`` at
  each converged state comes from the factorisation of its last Newton solve, and the next
  start is the cubic Hermite polynomial through the previous and current states and their
  tangents (the tangent line on the first increment), in x itself (no retraction).  Without
  it, or where that polynomial runs more than 3 times further than the secant (a tangent
  blowing up next to a bifurcation or limit point), the secant through the last two states.
* ``stability(x, lam, H) -> bool | None`` at every converged (sub)state.  The default,
  ``positive_definite``, is decided by the Newton solve's own factorisation where it is a
  Cholesky (``symmetric=True``) or an ``L D L^T``; pass ``None`` to skip, or a model's test.
  With ``keep_branch`` a substep from a stable to an unstable state, or one whose (scaled)
  increment points against the previous one, is cut and retried (Newton jumps branches next
  to a bifurcation of an imperfect system); it is accepted only at the shortest step.

Returns a ``PathResult`` (reported factors, states, Newton iterations per reported step --
substeps and failed attempts included --, cuts, residuals, stability flags, ``ok`` and the
reason the path stopped).  Nothing is returned as converged that did not meet ``xtol``
(and ``gtol``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from reduced_models.paths import floats_path
from reduced_models.paths.floats import Floats, Scalar
from reduced_models.paths.path_base import _Path, positive_definite
from reduced_models.paths.path_result import PathResult

__all__ = ["minimize_path", "positive_definite"]


class _ScalarPath(_Path):
    """``_Path`` on one bare float (``floats.Scalar``) with the arithmetic written in place:
    the same steps, the same floating-point operations in the same order, without the
    method call per operation that costs a one-unknown path (``prb-1r``) more than its
    equation."""

    def solve(self, x: float, lam: float) -> tuple[tuple | None, int, str]:
        """``_Path.solve``: Newton on g(x) = 0 with h = dg/dx."""
        gh, xtol, gtol, update = self.gh, self.xtol, self.gtol, self.update
        w, cap, isfinite = self.A.w, self.A.cap, math.isfinite
        prev_res = math.inf
        for it in range(1, self.max_iter + 1):
            g, h = gh(x, lam)
            res = abs(g)
            if not isfinite(res):
                return None, it, "non-finite residual"
            if h == 0.0:
                return None, it, "singular tangent (singular matrix)"
            sol = g / h
            size = abs(sol) if w is None else abs(sol * w)
            if not isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    return (x, res, self._stable(x, lam, h, h > 0.0), h), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            elif cap is not None:
                over = abs(sol) * cap
                sol = sol / over if over > 1.0 else sol
            prev_res = res
            x = x - sol if update is None else update(x, -sol)
        return None, self.max_iter, f"no convergence in {self.max_iter} its"

    def tangent(self, c: tuple, lam: float) -> float | None:
        """``_Path.tangent``: -(dg/dlam) / h."""
        if self.load_gradient is None:
            return None
        t = -(self.load_gradient(c[0], lam) / c[3])
        return t if math.isfinite(t) else None

    def _wdot(self, a: float, b: float) -> float:
        w = self.A.w
        return a * b if w is None else (a * w) * (b * w)

    def predict(self, x: float, x_prev: float | None, t: float | None, t_prev: float | None,
                s: float, lam: float, lam_prev: Any) -> float | None:  # fmt: skip
        """``_Path.predict``."""
        if x_prev is None or lam == lam_prev:
            return None if t is None else x + t * s
        h = lam - lam_prev
        back = x_prev - x
        secant = back * (-s / h)
        if t is not None:
            u = s / h
            c2 = u * u
            c3 = c2 + c2 * u if t_prev is not None else 0.0
            a1, a2 = s + h * (c2 + c3), c2 + 2.0 * c3
            poly = t * a1 + back * a2 if t_prev is None else t * a1 + back * a2 + t_prev * (h * c3)
            if self._wdot(poly, poly) <= 9.0 * self._wdot(secant, secant):
                return x + poly
        return x + secant if self.update is None else self.update(x, secant)

    def branch_jump(self, cur: tuple, conv: tuple, x: float, x_prev: float | None, lam: float,
                    lam_prev: Any) -> str:  # fmt: skip
        """``_Path.branch_jump``."""
        if not self.keep_branch:
            return ""
        if cur[2] is True and conv[2] is False:
            return "the step left the stable branch"
        if x_prev is not None and lam != lam_prev:
            if self._wdot(conv[0] - x, x - x_prev) < 0:
                return "the path turned back (branch jump)"
        return ""


def _arithmetic(x0: Any, n: int, fixed: Any, scale: Any, max_step: Any) -> Any:
    """``Scalar`` for a bare float, ``Floats`` for a list of floats, else ``linalg.Arrays``
    (the common options -- unit scales, no damping, nothing fixed -- without numpy calls:
    for one unknown they would cost a tenth of its path)."""
    inv = cap = None
    if scale is not None or max_step is not None:
        scale = np.ones(n) if scale is None else np.asarray(scale, dtype=float)
        inv = 1.0 / scale
        cap = None if max_step is None else 1.0 / (scale * np.asarray(max_step, dtype=float))
        if np.all(inv == 1.0):
            inv = None  # unit scales: no products per update
    held = [] if fixed is None else np.asarray(fixed, dtype=int).tolist()
    if isinstance(x0, float):
        if held:
            raise ValueError("a path of one unknown cannot hold it fixed")
        return Scalar(*(None if v is None else float(v[0]) for v in (inv, cap)))
    if isinstance(x0, (list, tuple)):
        return Floats(n, held, *(None if v is None else v.tolist() for v in (inv, cap)))
    from reduced_models.paths.linalg import Arrays  # scipy's LAPACK: arrays only

    return Arrays(n, np.asarray(held, dtype=int), inv, cap)


def minimize_path(
    grad_hess: Callable,
    x0: Sequence[float] | np.ndarray,
    factors: Sequence[float] | np.ndarray,
    *,
    scale: Sequence[float] | np.ndarray | None = None,
    xtol: float = 1e-10,
    gtol: float | None = None,
    max_iter: int = 25,
    max_cuts: int = 10,
    max_step: float | Sequence[float] | np.ndarray | None = None,
    fixed: Sequence[int] | np.ndarray | None = None,
    stability: Callable | None = positive_definite,
    update: Callable | None = None,
    keep_branch: bool = True,
    load_gradient: Callable | None = None,
    symmetric: bool | None = None,
) -> PathResult:
    """Follow the equilibrium path through the requested load factors (module docstring).

    Parameters
    ----------
    grad_hess : callable ``(x (n,), lam) -> (g (n,), H)``.
    x0 : (n,) start (and values of the ``fixed`` unknowns); a bare float or a list of floats
        (for at most ``floats.MAX_N`` unknowns: beyond, numpy is faster) selects the
        plain-float arithmetic, an array numpy's.
    factors : (m,) reported load factors, increasing from the first.
    scale : (n,) typical size of each unknown for the convergence test (default ones).
    xtol, gtol : tolerances on the scaled Newton update and on ``max |g|`` (optional).
    max_iter, max_cuts : Newton iterations per attempt; consecutive step halvings allowed.
    max_step : optional cap (scalar or (n,), may contain inf) on ``|dx_i / scale_i|``.
    fixed : indices of unknowns held at ``x0``.
    stability : ``(x, lam, H) -> bool | None`` at converged states, or None.
    update : optional retraction ``(x, dx) -> x_new`` (Newton updates, secant predictor).
    keep_branch : cut substeps that lose stability or turn back (branch jumps).
    load_gradient : optional ``(x, lam) -> dg/dlam`` (n,) for the tangent predictor.
    symmetric : True if every ``H`` is symmetric (Cholesky solves on arrays).

    Returns
    -------
    PathResult
    """
    n = 1 if isinstance(x0, float) else len(x0)
    A = _arithmetic(x0, n, fixed, scale, max_step)
    x = A.vector(x0)
    factors = [float(f) for f in factors]
    opts = dict(
        xtol=xtol, gtol=gtol, max_iter=max_iter, update=update, stability=stability,
        keep_branch=keep_branch, load_gradient=load_gradient, symmetric=symmetric,
    )  # fmt: skip
    kind = _ScalarPath if isinstance(A, Scalar) else _Path
    if kind is _Path and isinstance(A, Floats):
        kind = floats_path.FloatsPath if floats_path.plain(A, update) else _Path
    path = kind(A, grad_hess, opts, x, factors[0] if factors else 0.0)
    return path.result(*path.follow(x, factors, max_cuts))
