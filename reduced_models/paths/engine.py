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

from reduced_models.paths.floats import Floats, Scalar
from reduced_models.paths.path_result import PathResult, limit_note

__all__ = ["minimize_path", "positive_definite"]


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
        from reduced_models.paths import floats_path  # it subclasses _Path: imported here

        kind = floats_path.FloatsPath if floats_path.plain(A, update) else _Path
    path = kind(A, grad_hess, opts, x, factors[0] if factors else 0.0)
    return path.result(*path.follow(x, factors, max_cuts))
