"""Shared load continuation: Newton on an equilibrium residual, load stepping, step cutting.

Used by every energy-based reduced model (linear chains, BCM, chained BCM, the PRB family).

API
---
``minimize_path(grad_hess, x0, factors, *, scale=None, xtol=1e-10, gtol=None, max_iter=25,
max_cuts=10, max_step=None, fixed=None, stability=positive_definite, update=None,
keep_branch=True) -> PathResult``

* ``grad_hess(x, lam) -> (g, H)``: for a conservative model ``g`` is the gradient of the total
  potential ``Pi(x; lam) = U(x) - lam * W(x)`` and ``H`` its Hessian; any residual/Jacobian
  pair works (follower loads give an unsymmetric ``H``; a mixed Lagrangian gives an
  indefinite one).  ``x`` has shape (n,), ``g`` shape (n,).  ``H`` may be

  - a dense ``numpy.ndarray`` of shape (n, n),
  - a ``Banded`` (LAPACK band storage, solved by ``scipy.linalg.solve_banded``; pays for
    chained segments whose Hessian is block-tridiagonal),
  - a ``scipy.sparse`` matrix (solved by ``scipy.sparse.linalg.spsolve``).

* ``factors``: the load factors to report, shape (m,), usually starting at 0
  (``base.load_factors(scene)``).  Between two reported factors the increment is halved on a
  Newton failure and grown again after easy successes; the path stops (``ok = False``) after
  ``max_cuts`` halvings in a row or once the increment falls below the reported interval /
  2^max_cuts.  Only the requested factors are returned.
* ``fixed``: indices of unknowns held at their ``x0`` value (supports).  Their rows and
  columns are replaced by identity rows so band structure is kept; callers may also do this
  themselves.
* Convergence: after a Newton update, ``max |dx_i / scale_i| <= xtol``; the residual is then
  quadratically small.  ``scale`` (shape (n,)) gives each unknown's typical size (default 1).
  With ``gtol`` the residual at the accepted point must also satisfy ``max |g| <= gtol``.
* ``max_step``: optional cap (scalar or per unknown) on ``|dx_i / scale_i|`` per Newton
  update; a longer update is shortened as a whole (damping).
* ``update(x, dx) -> x_new``: optional retraction replacing ``x + dx`` (first-order equal);
  chained-segment models use it to rebuild node positions from segment deformations.
* ``stability(x, lam, H) -> bool | None``: evaluated at every converged (sub)state.  With
  ``keep_branch`` (default) a substep from a stable to an unstable state, or one whose
  increment (scaled) points against the previous increment, is cut and retried (Newton
  tends to jump branches next to a bifurcation of an imperfect system); it is accepted only
  at the shortest step.  The default,
  ``positive_definite``, is right for pure energy minimisation; pass ``None`` to skip, or a
  model-specific test (e.g. an inertia count for a mixed Lagrangian).

Returns a ``PathResult``: the converged reported factors, states, Newton iterations per
reported step (substeps and failed attempts included), cuts, final residual norms, stability
flags, ``ok`` and a one-line ``reason`` when the path stopped early.  Nothing is ever returned
as converged that did not meet ``xtol``.  The predictor is the secant through the last two
converged (sub)states.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = [
    "Banded",
    "PathResult",
    "minimize_path",
    "positive_definite",
    "solve_linear",
]


@dataclass
class Banded:
    """A square matrix in LAPACK general band storage.

    Attributes
    ----------
    ab : (l + u + 1, n) array, ``ab[u + i - j, j] = A[i, j]``.
    l, u : numbers of sub- and super-diagonals.
    symmetric : True if A is symmetric (enables the Cholesky test in ``positive_definite``).
    """

    ab: np.ndarray
    l: int
    u: int
    symmetric: bool = True

    @property
    def n(self) -> int:
        """Matrix size."""
        return self.ab.shape[1]

    def to_dense(self) -> np.ndarray:
        """Dense (n, n) copy (tests and debugging only)."""
        n = self.n
        A = np.zeros((n, n))
        for k in range(-self.l, self.u + 1):  # loop over diagonals, not over elements
            if abs(k) < n:
                A += np.diag(self.ab[self.u - k, max(k, 0) : n + min(k, 0)], k)
        return A

    def upper(self) -> np.ndarray:
        """Upper symmetric band storage (u + 1, n) for ``solveh_banded``/``eigvals_banded``."""
        return self.ab[: self.u + 1]

    def fix(self, idx: np.ndarray) -> None:
        """Replace rows and columns ``idx`` by identity rows/columns (in place)."""
        zero, diag = _band_fix_index(self.n, self.l, self.u, tuple(np.atleast_1d(idx).tolist()))
        if not self.ab.flags.c_contiguous:
            self.ab = np.ascontiguousarray(self.ab)
        flat = self.ab.reshape(-1)  # a view of the C-contiguous storage
        flat[zero] = 0.0
        flat[diag] = 1.0


@functools.lru_cache(maxsize=64)
def _band_fix_index(n: int, l: int, u: int, idx: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """Flat band-storage positions of the rows/columns ``idx`` and of their diagonal."""
    k = np.asarray(idx, dtype=int)[:, None]
    d = np.arange(-l, u + 1)[None, :]
    rows = np.broadcast_to(u - d, (k.size, d.size))
    col_k = np.broadcast_to(k, rows.shape)  # column k holds (k - d, k)
    ok1 = (k - d >= 0) & (k - d < n)
    col_kd = np.broadcast_to(k + d, rows.shape)  # row k holds (k, k + d) at column k + d
    ok2 = (col_kd >= 0) & (col_kd < n)
    zero = np.concatenate([rows[ok1] * n + col_k[ok1], rows[ok2] * n + col_kd[ok2]])
    return zero, u * n + k[:, 0]


def _fix_dense(H: np.ndarray, idx: np.ndarray) -> np.ndarray:
    H = np.array(H, dtype=float)
    H[idx, :] = 0.0
    H[:, idx] = 0.0
    H[idx, idx] = 1.0
    return H


def _fix_sparse(H: sp.spmatrix, idx: np.ndarray, n: int) -> sp.csc_matrix:
    keep = np.ones(n)
    keep[idx] = 0.0
    D = sp.diags(keep)
    E = sp.diags(1.0 - keep)
    return (D @ H @ D + E).tocsc()


def solve_linear(H: object, rhs: np.ndarray) -> np.ndarray:
    """Solve ``H x = rhs`` for a dense, ``Banded`` or sparse ``H`` (raises LinAlgError)."""
    if isinstance(H, Banded):
        return sla.solve_banded((H.l, H.u), H.ab, rhs, check_finite=False)
    if sp.issparse(H):
        x = spla.spsolve(sp.csc_matrix(H), rhs)
        if not np.all(np.isfinite(x)):
            raise np.linalg.LinAlgError("singular sparse matrix")
        return x
    return np.linalg.solve(H, rhs)


def positive_definite(x: np.ndarray, lam: float, H: object) -> bool | None:
    """Stability test for pure energy minimisation: is the Hessian positive definite?

    Dense and symmetric ``Banded`` matrices use a Cholesky factorisation; sparse or
    unsymmetric matrices give None (not assessed).
    """
    try:
        if isinstance(H, Banded):
            if not H.symmetric:
                return None
            sla.cholesky_banded(H.upper(), lower=False, check_finite=False)
            return True
        if sp.issparse(H):
            return None
        H = np.asarray(H)
        if not np.allclose(H, H.T, rtol=1e-9, atol=1e-12 * np.max(np.abs(H))):
            return None
        np.linalg.cholesky(H)
        return True
    except np.linalg.LinAlgError:
        return False


@dataclass(frozen=True)
class PathResult:
    """What ``minimize_path`` found.

    Attributes
    ----------
    factors : (m,) reported load factors reached (a prefix of the requested ones).
    states : (m, n) converged unknowns at those factors.
    iterations : (m,) Newton iterations spent reaching each reported factor (all substeps and
        failed attempts included).
    cuts : (m,) step halvings needed to reach each reported factor.
    residuals : (m,) final ``max |g|`` at each reported state (free unknowns only).
    stable : list of m stability flags (True/False/None).
    ok : True if every requested factor was reached.
    reason : '' if ok, else why the path stopped.
    """

    factors: np.ndarray
    states: np.ndarray
    iterations: np.ndarray
    cuts: np.ndarray
    residuals: np.ndarray
    stable: list
    ok: bool
    reason: str


def _evaluate(
    grad_hess: Callable, x: np.ndarray, lam: float, fixed: np.ndarray
) -> tuple[np.ndarray, object]:
    """Residual and tangent with the fixed unknowns replaced by identity equations."""
    g, H = grad_hess(x, lam)
    g = np.array(g, dtype=float)
    if fixed.size:
        g[fixed] = 0.0
        if isinstance(H, Banded):
            H.fix(fixed)
        elif sp.issparse(H):
            H = _fix_sparse(H, fixed, x.size)
        else:
            H = _fix_dense(H, fixed)
    return g, H


def _newton(
    grad_hess: Callable,
    x: np.ndarray,
    lam: float,
    fixed: np.ndarray,
    scale: np.ndarray,
    xtol: float,
    max_iter: int,
    max_step: float | np.ndarray | None,
    update: Callable | None = None,
    gtol: float | None = None,
) -> tuple[np.ndarray | None, int, float, object, str]:
    """Newton iterations at fixed ``lam``; returns (x or None, iterations, |g|, H, reason)."""
    x = x.copy()
    n = x.size
    for it in range(1, max_iter + 1):
        g, H = _evaluate(grad_hess, x, lam, fixed)
        if not np.all(np.isfinite(g)):
            return None, it, np.inf, None, "non-finite residual"
        try:
            dx = -solve_linear(H, g)
        except (np.linalg.LinAlgError, ValueError) as exc:
            return None, it, float(np.max(np.abs(g))), None, f"singular tangent ({exc})"
        if not np.all(np.isfinite(dx)):
            return None, it, float(np.max(np.abs(g))), None, "singular tangent"
        size = float(np.max(np.abs(dx) / scale)) if n else 0.0
        if max_step is not None:
            over = float(np.max(np.abs(dx) / (scale * max_step))) if n else 0.0
            if over > 1.0:
                dx /= over
        x = update(x, dx) if update is not None else x + dx
        if size <= xtol:
            # residual at the accepted point (one extra evaluation keeps the report honest)
            g2, H2 = _evaluate(grad_hess, x, lam, fixed)
            res = float(np.max(np.abs(g2))) if n else 0.0
            if not np.isfinite(res):
                return None, it, np.inf, None, "non-finite residual"
            if gtol is not None and res > gtol:
                return None, it, res, None, f"update converged but residual {res:.3g} > gtol"
            return x, it, res, H2, ""
        if size > 1e6:
            return None, it, float(np.max(np.abs(g))), None, "Newton diverged"
    return None, max_iter, float(np.max(np.abs(g))), None, f"no convergence in {max_iter} its"


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
) -> PathResult:
    """Follow the equilibrium path through the requested load factors (see module doc).

    Parameters
    ----------
    grad_hess : callable ``(x (n,), lam) -> (g (n,), H)``.
    x0 : (n,) start (and values of the ``fixed`` unknowns).
    factors : (m,) reported load factors, increasing from the first.
    scale : (n,) typical size of each unknown for the convergence test (default ones).
    xtol : convergence tolerance on the scaled Newton update.
    gtol : optional extra tolerance on ``max |g|`` at the accepted point.
    max_iter : Newton iterations per attempt.
    max_cuts : consecutive step halvings allowed before giving up.
    max_step : optional cap (scalar or (n,), may contain inf) on ``|dx_i / scale_i|``; a
        longer Newton update is shortened as a whole (damping).
    fixed : indices of unknowns held at ``x0``.
    stability : ``(x, lam, H) -> bool | None`` at reported states, or None.
    update : optional ``(x, dx) -> x_new`` used instead of ``x + dx`` for Newton updates and
        the predictor (a retraction that keeps kinematic relations exact; it must equal
        ``x + dx`` to first order so Newton stays quadratic).
    keep_branch : cut a substep that turns a stable state into an unstable one or whose
        increment points against the previous one (branch jumping near a bifurcation);
        accepted once the step reaches the shortest allowed length.

    Returns
    -------
    PathResult
    """
    x = np.array(x0, dtype=float)
    n = x.size
    fixed = np.asarray(fixed if fixed is not None else [], dtype=int)
    scale = np.ones(n) if scale is None else np.asarray(scale, dtype=float)
    factors = np.asarray(factors, dtype=float)

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

    # the first factor (usually 0): plain Newton from x0
    xs, its, res, H, why = _newton(
        grad_hess, x, factors[0], fixed, scale, xtol, max_iter, max_step, update, gtol
    )
    if xs is None:
        return result(False, f"no equilibrium at factor {factors[0]:.6g}: {why}")

    def record(xk: np.ndarray, lam: float, its: int, cuts: int, res: float, st: object) -> None:
        out_f.append(float(lam))
        out_x.append(xk.copy())
        out_it.append(its)
        out_cut.append(cuts)
        out_res.append(res)
        out_stab.append(st)

    def assess(xk: np.ndarray, lam: float, H: object) -> bool | None:
        return stability(xk, lam, H) if stability is not None else None

    st_cur = assess(xs, factors[0], H)
    record(xs, factors[0], its, 0, res, st_cur)
    x_prev, lam_prev = None, None  # the converged state before the current one (secant)
    x_cur, lam_cur, res_cur = xs, float(factors[0]), res
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
            if x_prev is not None and lam_cur != lam_prev:
                dpred = (lam_try - lam_cur) / (lam_cur - lam_prev) * (x_cur - x_prev)
                pred = update(x_cur, dpred) if update is not None else x_cur + dpred
            else:
                pred = x_cur
            xs, its, res, H, why = _newton(
                grad_hess, pred, lam_try, fixed, scale, xtol, max_iter, max_step, update, gtol
            )
            its_total += its
            if xs is None and x_prev is not None:
                # the secant predictor can overshoot near a limit: retry from the last state
                xs, its, res, H, why = _newton(
                    grad_hess, x_cur, lam_try, fixed, scale, xtol, max_iter, max_step, update, gtol
                )
                its_total += its
            st = assess(xs, lam_try, H) if xs is not None else None
            can_cut = 0.5 * abs(lam_try - lam_cur) >= abs(span) * 0.5**max_cuts
            if xs is not None and keep_branch and can_cut:
                # Near a bifurcation of an imperfect system Newton likes to jump to another
                # branch: a stable state followed by an unstable one, or a path that turns
                # back on itself, is retried with a shorter step; either is accepted once
                # the step is as short as allowed (a genuine loss of stability or fold).
                if st_cur is True and st is False:
                    xs, why = None, "the step left the stable branch"
                elif x_prev is not None and lam_cur != lam_prev:
                    back = np.dot((xs - x_cur) / scale, (x_cur - x_prev) / scale)
                    if back < 0:
                        xs, why = None, "the path turned back (branch jump)"
            if xs is None:
                cuts_total += 1
                consecutive += 1
                step = 0.5 * abs(lam_try - lam_cur)
                # give up after max_cuts halvings in a row, or when the increment has shrunk
                # below span / 2^max_cuts (a limit point approached through many successes)
                if consecutive > max_cuts or step < abs(span) * 0.5**max_cuts:
                    return result(
                        False,
                        f"Newton failed between factors {lam_cur:.6g} and {lam_try:.6g} "
                        f"after {cuts_total} step cuts ({why}); limit point or loss of "
                        "equilibrium?",
                    )
                continue
            consecutive = 0
            x_prev, lam_prev = x_cur, lam_cur
            step = abs(lam_try - lam_cur)
            x_cur, lam_cur, res_cur, st_cur = xs, lam_try, res, st
            dlam = step
            if its <= 4:  # easy step: allow a larger increment next time
                step *= 2.0
        record(x_cur, lam_cur, its_total, cuts_total, res_cur, st_cur)
    return result(True, "")
