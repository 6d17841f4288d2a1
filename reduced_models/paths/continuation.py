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

from reduced_models.paths.linalg import (
    Banded,
    _absmax,
    _factor_solve,
    _fix_dense,
    _fix_sparse,
    _resolve,
    positive_definite,
)
from reduced_models.paths.path_result import PathResult, limit_note
from reduced_models.paths.stepper import Recorder, follow

__all__ = ["minimize_path"]


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

    rec = Recorder(n)
    if factors.size == 0:
        return rec.result(True, "")
    engine = _Engine(
        solver, rec, fixed, inv_scale if inv_scale_used else None, update, keep_branch,
        load_gradient, x, float(factors[0]),
    )  # fmt: skip
    return rec.result(*follow(engine, x, factors, max_cuts))


class _Engine:
    """``minimize_path``'s arithmetic for ``stepper.follow`` (numpy arrays, LAPACK)."""

    def __init__(
        self,
        solver: _Solver,
        rec: Recorder,
        fixed: np.ndarray,
        inv_scale: np.ndarray | None,
        update: Callable | None,
        keep_branch: bool,
        load_gradient: Callable | None,
        x0: np.ndarray,
        lam0: float,
    ) -> None:
        self.solver, self.fixed, self.inv_scale, self.update = solver, fixed, inv_scale, update
        self.keep_branch, self.load_gradient, self.x0, self.lam0 = (
            keep_branch,
            load_gradient,
            x0,
            lam0,
        )
        self.rec = rec
        self.n = x0.size

    def solve(self, start: np.ndarray, lam: float) -> tuple[_Converged | None, int, str]:
        return self.solver.newton(start, lam)

    def state(self, c: _Converged) -> np.ndarray:
        return c.x

    def tangent(self, c: _Converged, lam: float) -> np.ndarray | None:
        """dx/dlam at a converged state from the factorisation of its last solve."""
        if self.load_gradient is None or self.n == 0:
            return None
        dg = self.load_gradient(c.x_eval, lam)
        if self.fixed.size:
            dg = np.array(dg, dtype=float)
            dg[self.fixed] = 0.0
        t = _resolve(c.factor, dg)
        t *= -1.0
        return t if math.isfinite(t.dot(t)) else None

    def predict(
        self,
        x_cur: np.ndarray,
        x_prev: np.ndarray | None,
        t_cur: np.ndarray | None,
        t_prev: np.ndarray | None,
        s: float,
        lam_cur: float,
        lam_prev: float | None,
    ) -> np.ndarray | None:
        """Cubic Hermite, tangent line or secant start (module docstring); None: x_cur."""
        dpred, hermite = None, False
        if x_prev is not None and lam_cur != lam_prev:
            h = lam_cur - lam_prev
            back_step = x_prev - x_cur
            dpred = back_step * (-s / h)  # secant
        if t_cur is not None:
            if dpred is None:
                dpred, hermite = t_cur * s, True
            else:
                # cubic Hermite through the previous and current states and tangents (the
                # quadratic through the previous state if its tangent is unknown), written
                # as a1 t_cur + a2 (x_prev - x_cur) + a3 t_prev, u = s / h
                u = s / h
                c2 = u * u
                c3 = c2 + c2 * u if t_prev is not None else 0.0
                poly = t_cur * (s + h * (c2 + c3)) + back_step * (c2 + 2.0 * c3)
                if t_prev is not None:
                    poly += t_prev * (h * c3)
                # next to a bifurcation or limit point the tangent blows up: keep the secant
                # when the polynomial runs far beyond it (2-norms, scaled)
                w = self.inv_scale
                a, b = (poly * w, dpred * w) if w is not None else (poly, dpred)
                if a.dot(a) <= 9.0 * b.dot(b):
                    dpred, hermite = poly, True
        if dpred is None:
            return None
        if hermite or self.update is None:
            # the Hermite polynomial is accurate in x itself: a retraction would add its own
            # second-order terms to it
            return x_cur + dpred
        return self.update(x_cur, dpred)

    def branch_jump(
        self,
        cur: _Converged,
        conv: _Converged,
        x_cur: np.ndarray,
        x_prev: np.ndarray | None,
        lam_cur: float,
        lam_prev: float | None,
    ) -> str:
        """Near a bifurcation of an imperfect system Newton likes to jump to another branch:
        a stable state followed by an unstable one, or a path that turns back on itself."""
        if not self.keep_branch:
            return ""
        if cur.stable is True and conv.stable is False:
            return "the step left the stable branch"
        if x_prev is not None and lam_cur != lam_prev:
            w = self.inv_scale if self.inv_scale is not None else 1.0
            if np.dot((conv.x - x_cur) * w, (x_cur - x_prev) * w) < 0:
                return "the path turned back (branch jump)"
        return ""

    def diagnose(self, c: _Converged, lam: float) -> str:
        return _diagnose(self.solver, c.x, lam, self.lam0, self.x0)

    def record(self, c: _Converged, lam: float, its: int, cuts: int) -> None:
        self.rec.add(lam, c.x, its, cuts, c.res, c.stable)
