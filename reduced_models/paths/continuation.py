"""Shared load continuation: Newton on an equilibrium residual, load stepping, step cutting.

Used by every energy-based reduced model (linear chains, BCM, chained BCM, the PRB family).

API
---
``minimize_path(grad_hess, x0, factors, *, scale=None, xtol=1e-10, gtol=None, max_iter=25,
max_cuts=10, max_step=None, fixed=None, stability=positive_definite, update=None,
keep_branch=True, load_gradient=None, symmetric=None) -> PathResult``

* ``grad_hess(x, lam) -> (g, H)``: for a conservative model ``g`` is the gradient of the total
  potential ``Pi(x; lam) = U(x) - lam * W(x)`` and ``H`` its Hessian; any residual/Jacobian
  pair works (follower loads give an unsymmetric ``H``; a mixed Lagrangian gives an
  indefinite one).  ``x`` has shape (n,), ``g`` shape (n,).  ``H`` may be

  - a dense ``numpy.ndarray`` of shape (n, n) (LAPACK ``dgesv``, or ``dposv`` -- Cholesky --
    when ``symmetric`` is True and the stability test is ``positive_definite``),
  - a ``Banded`` (LAPACK band storage, ``dgbsv``, or ``dpbsv`` under the same condition; pays
    for chained segments whose Hessian is block-tridiagonal),
  - a ``scipy.sparse`` matrix (sparse LU, ``scipy.sparse.linalg.splu``).

  The LAPACK drivers are called directly: for the small systems of reduced models the
  argument checking of ``numpy.linalg.solve`` / ``scipy.linalg.solve_banded`` costs more
  than the factorisation.

* ``factors``: the load factors to report, shape (m,), usually starting at 0
  (``base.load_factors(scene)``).  Between two reported factors the increment is halved on a
  Newton failure and grown again after easy successes; the path stops (``ok = False``) after
  ``max_cuts`` halvings in a row or once the increment falls below the reported interval /
  2^max_cuts.  Only the requested factors are returned.
* ``fixed``: indices of unknowns held at their ``x0`` value (supports).  Their rows and
  columns are replaced by identity rows so band structure is kept; callers may also do this
  themselves.
* Convergence is judged on the state returned: a Newton iteration evaluates ``g, H`` at
  ``x_k`` and solves for the update ``dx_k = -H^{-1} g(x_k)``; ``x_k`` is accepted when
  that correction, computed from its own residual, is small, ``max |dx_k,i / scale_i| <=
  xtol`` (and, with ``gtol``, ``max |g(x_k)| <= gtol``).  The accepted state is ``x_k``
  itself (not the unevaluated ``x_k + dx_k``): its residual, factorisation, tangent and
  stability are all measured on it, at no extra evaluation.
  ``scale`` (shape (n,)) gives each unknown's typical size (default 1).  A residual that
  stops falling while the update is already below ``xtol`` (a round-off floor above
  ``gtol``) fails the attempt.
* ``max_step``: optional cap (scalar or per unknown) on ``|dx_i / scale_i|`` per Newton
  update; a longer update is shortened as a whole (damping).
* ``update(x, dx) -> x_new``: optional retraction replacing ``x + dx`` (first-order equal);
  chained-segment models use it to rebuild node positions from segment deformations.
* Predictor: with ``load_gradient(x, lam) -> dg/dlam`` (shape (n,); for dead loads
  ``-grad W``; called with the last point handed to ``grad_hess``), the path tangent
  ``dx/dlam = -H^{-1} dg/dlam`` at each converged state is obtained from the factorisation
  of its last Newton solve (one extra triangular solve), and the next start is the cubic
  Hermite polynomial through the previous and the current state and their tangents (the
  tangent line on the first increment), taken in x itself (no retraction).  Without it,
  or where that polynomial runs more than 3 times further than the secant (a tangent
  blowing up next to a bifurcation or limit point), the secant through the last two
  converged states.  A predictor that fails is retried from the last converged state
  before the increment is cut.  The increment grown after an easy step (<= 4 iterations)
  is carried on to the next reported factor, so it recovers after a cut.
* ``stability(x, lam, H) -> bool | None``: evaluated at every converged (sub)state, at the
  last evaluated iterate (within ``xtol`` of the accepted state).  With ``keep_branch``
  (default) a substep from a stable to an unstable state, or one whose increment (scaled)
  points against the previous increment, is cut and retried (Newton tends to jump branches
  next to a bifurcation of an imperfect system); it is accepted only at the shortest step.
  The default, ``positive_definite``, is right for pure energy minimisation; pass ``None``
  to skip, or a model-specific test (e.g. an inertia count for a mixed Lagrangian).  With
  ``symmetric=True`` (the caller guarantees a symmetric ``H``) and ``positive_definite``,
  the Newton systems are solved by Cholesky where it succeeds, so the last solve already
  decides positive definiteness and no separate factorisation is spent on the test.

Returns a ``PathResult``: the converged reported factors, states, Newton iterations per
reported step (one iteration = one evaluation of ``grad_hess`` and one linear solve;
substeps and failed attempts included), cuts, final residual norms, stability flags, ``ok``
and a one-line ``reason`` when the path stopped early.  Nothing is ever returned as
converged that did not meet ``xtol`` (and ``gtol``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

# The linear-algebra layer lives in ``linalg``; its names stay importable from here.
from reduced_models.paths.linalg import (
    Banded,
    _absmax,
    _factor_solve,
    _fix_dense,
    _fix_sparse,
    _resolve,
    positive_definite,
    solve_linear,
)
from reduced_models.paths.path_result import PathResult, limit_note

__all__ = [
    "Banded",
    "PathResult",
    "minimize_path",
    "positive_definite",
    "solve_linear",
]


@dataclass
class _Converged:
    """One converged Newton solve: accepted state and what was measured on the way."""

    x: np.ndarray  # accepted state x_k (its residual was evaluated)
    its: int
    res: float  # max |g(x_k)| of the accepted state
    stable: bool | None
    x_eval: np.ndarray  # x_k
    factor: tuple  # factorisation of H(x_k)


class _Solver:
    """Newton iterations at fixed load factor with the options of one ``minimize_path``."""

    def __init__(
        self,
        grad_hess: Callable,
        n: int,
        fixed: np.ndarray,
        scale: np.ndarray,
        xtol: float,
        gtol: float | None,
        max_iter: int,
        max_step: float | np.ndarray | None,
        update: Callable | None,
        stability: Callable | None,
        symmetric: bool | None,
    ) -> None:
        self.grad_hess, self.n, self.fixed = grad_hess, n, fixed
        self.fixed_key = tuple(fixed.tolist())
        # None: unit scale (the common case skips a multiplication per iteration)
        self.inv_scale = None if np.all(scale == 1.0) else 1.0 / scale
        self.xtol, self.gtol, self.max_iter = xtol, gtol, max_iter
        self.inv_cap = None if max_step is None else 1.0 / (scale * max_step)
        self.update, self.stability = update, stability
        # Cholesky in the Newton solves decides positive definiteness on the way
        self.chol = stability is positive_definite and symmetric is True

    def evaluate(self, x: np.ndarray, lam: float) -> tuple[np.ndarray, object]:
        """Residual and tangent with the fixed unknowns replaced by identity equations."""
        g, H = self.grad_hess(x, lam)
        fixed = self.fixed
        if fixed.size:
            g = np.array(g, dtype=float)
            g[fixed] = 0.0
            if isinstance(H, Banded):
                H.fix(self.fixed_key)
            elif sp.issparse(H):
                H = _fix_sparse(H, fixed, self.n)
            else:
                H = _fix_dense(H, fixed)
        return g, H

    def newton(self, x: np.ndarray, lam: float) -> tuple[_Converged | None, int, str]:
        """Newton from ``x`` at factor ``lam``: (result or None, iterations, reason)."""
        if self.n == 0:
            return _Converged(x.copy(), 0, 0.0, None, x, ("ge", None, None)), 0, ""
        gtol, xtol, prev_res = self.gtol, self.xtol, math.inf
        evaluate = self.evaluate if self.fixed.size else self.grad_hess
        inv_scale, update, chol = self.inv_scale, self.update, self.chol
        for it in range(1, self.max_iter + 1):
            g, H = evaluate(x, lam)
            res = _absmax(g)
            if not math.isfinite(res):
                return None, it, "non-finite residual"
            try:
                sol, pd, factor = _factor_solve(H, g, chol)
            except (np.linalg.LinAlgError, ValueError) as exc:
                return None, it, f"singular tangent ({exc})"
            size = _absmax(sol if inv_scale is None else sol * inv_scale)
            if not math.isfinite(size):
                return None, it, "singular tangent"
            dx = -sol
            if size <= xtol:
                if gtol is None or res <= gtol:
                    # the accepted state is the evaluated one (its residual was just checked)
                    if self.stability is None:
                        st = None
                    elif chol and pd is not None:
                        st = pd
                    else:
                        st = self.stability(x, lam, H)
                    return _Converged(x, it, res, st, x, factor), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            elif self.inv_cap is not None:
                over = float((abs(dx) * self.inv_cap).max())
                if over > 1.0:
                    dx /= over
            prev_res = res
            x = update(x, dx) if update is not None else x + dx
        return None, self.max_iter, f"no convergence in {self.max_iter} its"


def _min_abs_eig(solver: _Solver, x: np.ndarray, lam: float) -> float:
    """Smallest |eigenvalue| of the symmetric part of the tangent at ``(x, lam)`` (dense; a
    diagnosis after failure, never in the Newton loop)."""
    _, H = solver.evaluate(x, lam)
    A = H.to_dense() if isinstance(H, Banded) else (H.toarray() if sp.issparse(H) else H)
    A = np.asarray(A, dtype=float)
    return float(np.min(np.abs(np.linalg.eigvalsh(0.5 * (A + A.T)))))


def _diagnose(solver: _Solver, x: np.ndarray, lam: float, lam0: float, x0: np.ndarray) -> str:
    """Why load control stopped: the model's own limit point (its tangent turned singular:
    smallest |eigenvalue| below 1 % of the unloaded state's) or an unexplained failure."""
    try:
        ratio = _min_abs_eig(solver, x, lam) / max(_min_abs_eig(solver, x0, lam0), 1e-300)
    except (np.linalg.LinAlgError, ValueError):
        ratio = float("nan")
    return limit_note(ratio, lam)


def minimize_path(
    grad_hess: Callable,
    x0: np.ndarray,
    factors: Sequence[float] | np.ndarray,
    *,
    scale: np.ndarray | None = None,
    xtol: float = 1e-10,
    gtol: float | None = None,
    max_iter: int = 25,
    max_cuts: int = 10,
    max_step: float | np.ndarray | None = None,
    fixed: Sequence[int] | np.ndarray | None = None,
    stability: Callable | None = positive_definite,
    update: Callable | None = None,
    keep_branch: bool = True,
    load_gradient: Callable | None = None,
    symmetric: bool | None = None,
) -> PathResult:
    """Follow the equilibrium path through the requested load factors (see module doc).

    Parameters
    ----------
    grad_hess : callable ``(x (n,), lam) -> (g (n,), H)``.
    x0 : (n,) start (and values of the ``fixed`` unknowns).
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
    symmetric : True if every ``H`` is symmetric (Cholesky solves).

    Returns
    -------
    PathResult
    """
    x = np.array(x0, dtype=float)
    n = x.size
    fixed = np.asarray(fixed if fixed is not None else [], dtype=int)
    scale = np.ones(n) if scale is None else np.asarray(scale, dtype=float)
    inv_scale = 1.0 / scale
    inv_scale_used = not np.all(inv_scale == 1.0)
    factors = np.asarray(factors, dtype=float)
    solver = _Solver(
        grad_hess, n, fixed, scale, xtol, gtol, max_iter, max_step, update, stability, symmetric
    )

    out_f: list[float] = []
    out_x: list[np.ndarray] = []
    out_it: list[int] = []
    out_cut: list[int] = []
    out_res: list[float] = []
    out_stab: list = []

    def result(ok: bool, reason: str) -> PathResult:
        return PathResult(
            factors=np.array(out_f),
            states=np.array(out_x).reshape(len(out_x), n),
            iterations=np.array(out_it, dtype=int),
            cuts=np.array(out_cut, dtype=int),
            residuals=np.array(out_res),
            stable=out_stab,
            ok=ok,
            reason=reason,
        )

    if factors.size == 0:
        return result(True, "")

    def tangent(c: _Converged, lam: float) -> np.ndarray | None:
        """dx/dlam at a converged state from the factorisation of its last solve."""
        if load_gradient is None or n == 0:
            return None
        dg = load_gradient(c.x_eval, lam)
        if fixed.size:
            dg = np.array(dg, dtype=float)
            dg[fixed] = 0.0
        t = _resolve(c.factor, dg)
        t *= -1.0
        return t if math.isfinite(t.dot(t)) else None

    # the first factor (usually 0): plain Newton from x0
    conv, its, why = solver.newton(x, float(factors[0]))
    if conv is None:
        return result(False, f"no equilibrium at factor {factors[0]:.6g}: {why}")

    def record(c: _Converged, lam: float, its: int, cuts: int) -> None:
        out_f.append(float(lam))
        out_x.append(c.x)
        out_it.append(its)
        out_cut.append(cuts)
        out_res.append(c.res)
        out_stab.append(c.stable)

    record(conv, factors[0], its, 0)
    x_prev, lam_prev = None, None  # the converged state before the current one
    cur, lam_cur = conv, float(factors[0])
    t_cur, t_prev = tangent(cur, lam_cur), None
    dlam = None  # size of the last successful increment (carried to the next reported step)

    for target in factors[1:]:
        target = float(target)
        its_total, cuts_total, consecutive = 0, 0, 0
        span = target - lam_cur
        direction = 1.0 if span >= 0 else -1.0
        step = abs(span) if dlam is None else min(dlam, abs(span))
        why = ""
        while abs(target - lam_cur) > 1e-14 * max(1.0, abs(target)):
            lam_try = lam_cur + direction * step
            if direction * (target - lam_try) < 1e-9 * step:
                lam_try = target  # do not leave a sliver before the reported factor
            x_cur = cur.x
            s = lam_try - lam_cur
            dpred, hermite = None, False
            if x_prev is not None and lam_cur != lam_prev:
                h = lam_cur - lam_prev
                back_step = x_prev - x_cur
                dpred = back_step * (-s / h)  # secant
            if t_cur is not None:
                if dpred is None:
                    dpred, hermite = t_cur * s, True
                else:
                    # cubic Hermite through the previous and current states and tangents
                    # (the quadratic through the previous state if its tangent is unknown),
                    # written as a1 t_cur + a2 (x_prev - x_cur) + a3 t_prev, u = s / h
                    u = s / h
                    c2 = u * u
                    c3 = c2 + c2 * u if t_prev is not None else 0.0
                    poly = t_cur * (s + h * (c2 + c3)) + back_step * (c2 + 2.0 * c3)
                    if t_prev is not None:
                        poly += t_prev * (h * c3)
                    # next to a bifurcation or limit point the tangent blows up: keep the
                    # secant when the polynomial runs far beyond it (2-norms, scaled)
                    if inv_scale_used:
                        a, b = poly * inv_scale, dpred * inv_scale
                    else:
                        a, b = poly, dpred
                    if a.dot(a) <= 9.0 * b.dot(b):
                        dpred, hermite = poly, True
            if dpred is None:
                pred = x_cur
            elif hermite or update is None:
                # the Hermite polynomial is accurate in x itself: a retraction would add
                # its own second-order terms to it
                pred = x_cur + dpred
            else:
                pred = update(x_cur, dpred)
            conv, its, why = solver.newton(pred, lam_try)
            its_total += its
            if conv is None and dpred is not None:
                # the predictor can overshoot near a limit: retry from the last state
                conv, its, why = solver.newton(x_cur, lam_try)
                its_total += its
            can_cut = 0.5 * abs(s) >= abs(span) * 0.5**max_cuts
            if conv is not None and keep_branch and can_cut:
                # Near a bifurcation of an imperfect system Newton likes to jump to another
                # branch: a stable state followed by an unstable one, or a path that turns
                # back on itself, is retried with a shorter step; either is accepted once
                # the step is as short as allowed (a genuine loss of stability or fold).
                if cur.stable is True and conv.stable is False:
                    conv, why = None, "the step left the stable branch"
                elif x_prev is not None and lam_cur != lam_prev:
                    back = np.dot((conv.x - x_cur) * inv_scale, (x_cur - x_prev) * inv_scale)
                    if back < 0:
                        conv, why = None, "the path turned back (branch jump)"
            if conv is None:
                cuts_total += 1
                consecutive += 1
                step = 0.5 * abs(s)
                # give up after max_cuts halvings in a row, or when the increment has shrunk
                # below span / 2^max_cuts (a limit point approached through many successes)
                if consecutive > max_cuts or step < abs(span) * 0.5**max_cuts:
                    return result(
                        False,
                        f"Newton failed between factors {lam_cur:.6g} and {lam_try:.6g} "
                        f"after {cuts_total} step cuts ({why}); "
                        + _diagnose(solver, cur.x, lam_cur, float(factors[0]), x0),
                    )
                continue
            consecutive = 0
            x_prev, lam_prev = x_cur, lam_cur
            step = abs(s)
            cur, lam_cur = conv, lam_try
            t_prev, t_cur = t_cur, tangent(cur, lam_cur)
            if its <= 4:  # easy step: allow a larger increment next time (also carried on)
                step *= 2.0
            dlam = step
        record(cur, lam_cur, its_total, cuts_total)
    return result(True, "")
