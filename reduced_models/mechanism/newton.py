"""Constrained Newton (KKT), continuation with step cutting, and stability on the manifold.

Equilibrium of a ``MechanismSystem`` at load factor ``lam``:

    r(q, mu) = grad Pi(q; lam) + J(q)^T mu = 0   (free unknowns),   c(q) = 0,

solved by Newton on the KKT system ``[[W, J^T], [J, 0]]`` with ``W = Hess Pi + sum mu_k
Hess c_k``.  In a *distance* solve the load factor is unknown and takes the place of the
driver row's multiplier (the driver is then a target, not a force).  Convergence is judged
on the state handed back: max |r_i| / rscale_i and max |c_j| / cscale_j both <= tol.

Stability (``Step.stable``): the reduced Hessian ``Z^T W Z`` on the tangent space of the
constraints (driver held in energy analyses) is positive definite iff the KKT matrix has
exactly ``m + n_p`` negative eigenvalues and none near zero (inertia additivity; n_p = number
of axial multipliers of chained segments, each of which brings one negative eigenvalue).
"Near zero" is judged unit-free: the factorisation kept for the tangent is scaled by the
residual and constraint scales; where its pivot ratio is close enough to ``SINGULAR_REL``
that the units could move it across, the verdict comes from a dimensionless copy.

The KKT system comes from ``kkt.Assembly`` (one scatter per evaluation), dense below
``kkt.SPARSE_FROM`` unknowns (LAPACK dgesv, Bunch-Kaufman dsytrf for the inertia), sparse
above (SuperLU; the inertia from ``kkt_sparse``'s certified symmetric LDL^T).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack

from reduced_models.mechanism import kkt_sparse
from reduced_models.mechanism.kkt import Assembly

if TYPE_CHECKING:
    from reduced_models.mechanism.system import MechanismSystem

#: KKT matrix: dense below ``kkt.SPARSE_FROM`` unknowns, CSC above
Matrix = np.ndarray | sp.csc_matrix

TOL = 1e-10
POLISH_BELOW = 1e-4  # a converged residual above tol * this gets one more update
POLISH_STEP = 1e-6  # ... if it is that small (relative to the unknowns' scales)
MAX_ITER = 30
# a Newton whose residual has not halved in FLOOR_ITERATIONS iterations while below
# FLOOR_RES x tol is at the residual's round-off floor (64-segment chains: ~1e-10, the
# tolerance itself): where it never meets the tolerance it has converged there, the
# iterates only wander (the shallow arch's unloaded drawn state, turned 37 deg, stalled at
# 4e-10 for 30 iterations as cbcm-64).  The path corrector stops at the floor at once.
FLOOR_RES = 1e2
FLOOR_ITERATIONS = 3


class SolveError(RuntimeError):
    """Newton did not converge (message = reason)."""


@dataclass
class State:
    """A converged equilibrium: unknowns, multipliers (driver row: -driver force), factor."""

    q: np.ndarray
    mu: np.ndarray
    lam: float
    iterations: int = 0
    residual: float = 0.0
    K: Matrix | None = None  # KKT matrix at this state (reused by tangent/stability)
    lam_free: bool = False
    ldl: tuple | None = None  # (solve K x = b, size): factors from ``Solver.stable``


class Solver:
    """Newton solves on one system; ``lam_free`` makes the load factor the driver's unknown.
    ``sparse``: force the sparse (True) or dense (False) KKT path (None: by size, ``kkt``)."""

    def __init__(
        self,
        sysm: MechanismSystem,
        tol: float = TOL,
        max_iter: int = MAX_ITER,
        sparse: bool | None = None,
    ) -> None:
        self.s = sysm
        self.tol, self.max_iter = tol, max_iter
        self.f = sysm.free
        self.nf = len(self.f)
        self.asm = Assembly(sysm, sparse)
        self.sparse = sparse
        self._stab_key: tuple | None = None
        self._cap: np.ndarray | None = None
        self.memo: tuple | None = None  # last (path kind, t, x, dx) for the Hermite predictor

    def driver_index(self) -> int | None:
        """Row of the driver in the stacked constraint vector (None without a driver)."""
        s = self.s
        if s.driver_row is None:
            return None
        return s.m - s.linear.m + s.driver_row

    def kkt(self, st: State, lam_free: bool = False) -> tuple[np.ndarray, Matrix, float]:
        """Residual (nf + m,) and KKT matrix (dense array or CSC) at a state; the scaled
        residual norm."""
        mu, col = st.mu, None
        if lam_free:
            d = self.driver_index()
            mu = mu.copy()
            mu[d] = 0.0
            col = self.nf + d
        R, K = self.asm.evaluate(st.q, st.lam, mu, col)
        return R, K, float(np.abs(R * self.asm.isc).max()) if len(R) else 0.0

    def polish(self, st: State, R: np.ndarray, lam_free: bool) -> State:
        """One more Newton update from a converged state, kept when it lowers the residual.

        Converged at ``tol`` the state still depends on the iterates that led there (on how
        the scene is drawn: rotated, translated, in other units); quadratic convergence takes
        one more update to round-off, so the same scene gives the same answer to ~1e-14.
        """
        if st.residual <= POLISH_BELOW * self.tol:
            return st
        dx = _solve(st.K, -R)
        if not np.isfinite(dx).all() or not self._small(dx, st.mu):
            return st  # near a singular configuration the update is no polish
        q, mu, lam = st.q.copy(), st.mu + dx[self.nf :], st.lam
        q[self.f] += dx[: self.nf]
        if lam_free:
            d = self.driver_index()
            lam, mu[d] = lam + mu[d], 0.0
        R2, K2, res2 = self.kkt(State(q, mu, lam), lam_free)
        if not (np.isfinite(R2).all() and res2 < st.residual):
            return st
        return State(q, mu, lam, st.iterations + 1, res2, K2, lam_free)

    def _small(self, dx: np.ndarray, mu: np.ndarray) -> bool:
        """True when the update moves no unknown by more than POLISH_STEP of its scale
        (0.5 rad, L) and no multiplier by more than POLISH_STEP of the force scale."""
        nf, lay = self.nf, self.s.lay
        kind = np.array(lay.kind)[self.f]
        scale = np.where(kind == "r", 0.5, np.where(kind == "p", np.inf, lay.Lref))
        dq = float(np.max(np.abs(dx[:nf]) / scale, initial=0.0))
        big_mu = max(float(np.max(np.abs(mu), initial=0.0)), self.s.fscale * lay.Lref)
        dmu = float(np.max(np.abs(dx[nf:]), initial=0.0)) / big_mu
        return dq <= POLISH_STEP and dmu <= POLISH_STEP

    def newton(self, st: State, lam_free: bool = False) -> State:
        """Newton from ``st`` (not modified); raises SolveError when it does not converge."""
        q, mu, lam = st.q.copy(), st.mu.copy(), st.lam
        s, f, nf = self.s, self.f, self.nf
        d = self.driver_index()
        if self._cap is None:  # damping: at most 0.5 rad / 0.25 L per update, none in p
            kind = np.array(s.lay.kind)[f]
            self._cap = 1.0 / np.where(
                kind == "r", 0.5, np.where(kind == "p", np.inf, 0.25 * s.lay.Lref)
            )
        icap = self._cap
        prev, best, since, least = np.inf, np.inf, 0, None
        for it in range(self.max_iter + 1):
            cur = State(q, mu, lam)
            R, K, res = self.kkt(cur, lam_free)
            if not np.isfinite(R).all():
                raise SolveError("non-finite residual")
            if res <= self.tol:
                return self.polish(State(q, mu, lam, it, res, K, lam_free), R, lam_free)
            best, since = (res, 0) if res < 0.5 * best else (best, since + 1)
            if least is None or res < least[0].residual:
                least = (State(q, mu, lam, it, res, K, lam_free), R)
            if it == self.max_iter or (it > 8 and res > 1e3 * prev):
                break
            prev = res
            dx = _solve(K, -R)
            if not np.isfinite(dx).all():
                raise SolveError("singular KKT matrix (mechanism at a singular configuration)")
            big = float((np.abs(dx[:nf]) * icap).max()) if nf else 0.0
            if big > 1.0:
                dx /= big
            q = q.copy()
            q[f] += dx[:nf]
            mu = mu + dx[nf:]
            if lam_free:
                lam = lam + mu[d]
                mu[d] = 0.0
        if since >= FLOOR_ITERATIONS and least[0].residual <= FLOOR_RES * self.tol:
            # stalled at the floor for good: its least residual iterate is the answer (only
            # where the tolerance was never met, so every solve that met it is unchanged)
            return self.polish(*least, lam_free)
        raise SolveError(
            f"Newton did not converge in {self.max_iter} iterations (residual {res:.2e})"
        )

    def tangent(self, st: State, wrt: str, lam_free: bool = False) -> np.ndarray:
        """d(q_free, mu)/dt along the equilibrium path, t = load factor (``wrt="lam"``) or
        the driver value (``"driver"``; in its units: length or rad); (nf + m,)."""
        K = st.K if st.K is not None and st.lam_free == lam_free else self.kkt(st, lam_free)[1]
        rhs = np.zeros(K.shape[0])
        if wrt == "lam":
            rhs[: self.nf] = -self.s.reduced_load(st.q)
        else:
            rhs[self.nf + self.driver_index()] = 1.0
        if st.ldl is not None and not lam_free and st.ldl[1] == len(rhs):
            x = st.ldl[0](rhs)  # the stability check factorised K at this state already
            if np.isfinite(x).all():
                return x
        return _solve(K, rhs)

    def stable(self, st: State, hold_driver: bool) -> tuple[bool | None, float]:
        """Reduced-Hessian verdict and the lowest scaled pivot (module doc)."""
        s, f, nf = self.s, self.f, self.nf
        K = st.K if st.K is not None and not st.lam_free else self.kkt(st)[1]
        d = self.driver_index()
        key = (K.shape[0], hold_driver, sp.issparse(K))
        if self._stab_key != key:  # congruence scaling (keeps the inertia) and kept rows
            keep = np.ones(K.shape[0], bool)
            if d is not None and not hold_driver:
                keep[nf + d] = False
            cs = s.cscale()
            cs = cs if d is None or hold_driver else np.delete(cs, d)
            sc = np.concatenate([1.0 / np.sqrt(s.rscale[f]), 1.0 / np.sqrt(cs)])
            n_p = sum(len(ch.w) for ch in s.chains)
            e = self._unit_free(cs)
            S = None if sp.issparse(K) else np.outer(sc, sc)  # dense: elementwise scaling
            self._stab = (np.flatnonzero(keep), S, bool(np.all(keep)), sc, n_p, e)
            self._stab_key = key
        keep, S, full, sc, n_p, e = self._stab
        m = len(keep) - nf
        if len(keep) == 0:
            return True, 1.0
        reuse = full and not st.lam_free
        n_neg, pivot = self._inertia(st, K, keep, full, sc, S, reuse)
        # the pivot ratio of this scaling moves with the length and force units (its
        # translation block is in 1/length): near the singular threshold, by as much as the
        # unit-free rescaling e can move it, the verdict comes from a dimensionless copy
        # (its factors are not kept: the Newton tangent stays as it is)
        if pivot <= SINGULAR_REL * (e.max() / e.min()) ** 4:
            se = sc * e
            n_neg, pivot = self._inertia(st, K, keep, full, se, np.outer(se, se), False)
        if n_neg is None:
            return None, pivot
        return n_neg == m + n_p, pivot

    def _unit_free(self, cs: np.ndarray) -> np.ndarray:
        """Factors that make ``stable``'s congruence scaling dimensionless, (nf + m,): a
        translation's scale 1/sqrt(fscale) times sqrt(Lref) (its stiffness is force/length),
        a length constraint's multiplier 1/sqrt(Lref) times sqrt(fscale) (an angle row's
        1 times sqrt(fscale Lref)); rotations and chain axial unknowns as they are."""
        s, f = self.s, self.f
        Lref = s.lay.Lref
        trans = np.array(s.lay.kind)[f] == "t"
        for ch in s.chains:  # the p unknowns have their own residual scale (not a force)
            trans &= ~np.isin(f, ch.dofs[:, 6])
        ef = np.where(trans, math.sqrt(Lref), 1.0)
        return np.concatenate([ef, np.sqrt(s.fscale * Lref / cs)])

    def _inertia(
        self,
        st: State,
        K: Matrix,
        keep: np.ndarray,
        full: bool,
        sc: np.ndarray,
        S: np.ndarray | None,
        reuse: bool,
    ) -> tuple[int | None, float]:
        """Inertia of the kept rows and columns of ``K`` congruence-scaled by ``sc`` (dense
        ``K``: ``S = outer(sc, sc)``, elementwise) and the lowest relative pivot."""
        if sp.issparse(K):
            return self._sparse_inertia(st, K, keep, full, sc, reuse)
        return _dense_inertia(st, K if full else K[np.ix_(keep, keep)], S, sc, reuse)

    def _sparse_inertia(
        self,
        st: State,
        K: sp.csc_matrix,
        keep: np.ndarray,
        full: bool,
        sc: np.ndarray,
        reuse: bool,
    ) -> tuple[int | None, float]:
        """Inertia by the sparse symmetric LDL^T (``kkt_sparse``); dense Bunch-Kaufman when
        it cannot be certified and the system is small enough (``DENSE_MAX``)."""
        A = K if full else K[keep][:, keep]
        D = sp.diags(sc)
        A = (D @ A @ D).tocsc()
        fac = kkt_sparse.ldl(A, self.nf)
        if fac is not None:
            solve_a, piv, rel = fac
            if reuse:
                st.ldl = (lambda rhs: sc * solve_a(sc * rhs), len(sc))
            return kkt_sparse.inertia(piv, rel)
        if A.shape[0] > DENSE_MAX:
            return None, 0.0
        return _dense_inertia(st, A.toarray(), 1.0, sc, False)


DENSE_MAX = 2000  # largest KKT size for the dense inertia fallback of the sparse path


def _dense_inertia(
    st: State, K: np.ndarray, S: np.ndarray | float, sc: np.ndarray, reuse: bool
) -> tuple[int | None, float]:
    """Bunch-Kaufman LDL^T (LAPACK dsytrf) of ``K * S`` (S: congruence scaling outer(sc, sc))
    and its inertia; ``reuse``: keep the factors for ``Solver.tangent`` at this state."""
    lu, piv, info = lapack.dsytrf(K * S, lower=1)[:3]
    if info < 0:
        return None, 0.0
    if reuse:

        def solve(rhs: np.ndarray) -> np.ndarray:
            x, info = lapack.dsytrs(lu, piv, sc * rhs, lower=1)
            return sc * x if info == 0 else np.full(len(rhs), np.nan)

        st.ldl = (solve, len(sc))
    return _inertia(lu, piv)


def _solve(K: Matrix, rhs: np.ndarray) -> np.ndarray:
    """LAPACK dgesv (least squares if singular); the argument checks of numpy.linalg.solve
    cost more than the factorisation at these sizes.  Sparse K: SuperLU.  No unknowns (a
    member clamped at both ends): the empty solution, which LAPACK refuses to compute."""
    if K.shape[0] == 0:
        return np.zeros(0)
    if sp.issparse(K):
        return kkt_sparse.solve(K, rhs)
    _, _, x, info = lapack.dgesv(K, rhs)
    if info != 0 or not np.isfinite(x).all():
        return np.linalg.lstsq(K, rhs, rcond=None)[0]
    return x


def _inertia(lu: np.ndarray, piv: np.ndarray) -> tuple[int | None, float]:
    """Number of negative eigenvalues of a symmetric matrix from its Bunch-Kaufman LDL^T
    factors (LAPACK dsytrf, lower; Sylvester's law of inertia), and the smallest |eigenvalue
    of D| relative to the largest; (None, pivot) when the matrix is numerically singular.
    2x2 blocks: rows k, k+1 share a negative pivot index; eigenvalues mean +- disc."""
    if len(piv) <= SMALL:
        neg, lo, hi = _inertia_small(np.diag(lu).tolist(), np.diag(lu, -1).tolist(), piv)
    else:
        d = np.diag(lu)
        starts = np.flatnonzero(piv < 0)[::2]
        a, c, b = d[starts], d[starts + 1], lu[starts + 1, starts]
        det, half = a * c - b * b, 0.5 * (a + c)
        big = np.abs(half) + np.sqrt(0.25 * (a - c) ** 2 + b * b)
        mags = np.abs(d)
        mags[starts], mags[starts + 1] = big, np.abs(det) / np.maximum(big, 1e-300)
        neg = int(np.count_nonzero(d < 0)) - int(np.count_nonzero(a < 0))
        neg += int(np.count_nonzero(det < 0)) - int(np.count_nonzero(c < 0))
        neg += 2 * int(np.count_nonzero((det >= 0) & (half < 0)))
        lo, hi = float(mags.min()), float(mags.max())
    rel = lo / max(hi, 1e-300)
    if rel <= SINGULAR_REL:
        return None, rel
    return neg, rel


SINGULAR_REL = 1e-13  # smallest |pivot| / largest below which the KKT matrix counts as singular
SMALL = 128  # pivots counted with plain floats up to this size (fewer calls than numpy)


def _inertia_small(d: list, sub: list, piv: np.ndarray) -> tuple[int, float, float]:
    """(negative eigenvalues, min |eigenvalue|, max |eigenvalue|) of the block-diagonal D."""
    p = piv.tolist()
    neg, lo, hi, k = 0, math.inf, 0.0, 0
    while k < len(d):
        if p[k] < 0:
            a, c, b = d[k], d[k + 1], sub[k]
            det, half = a * c - b * b, 0.5 * (a + c)
            big = abs(half) + math.sqrt(0.25 * (a - c) ** 2 + b * b)
            neg += 1 if det < 0 else (2 if half < 0 else 0)
            lo, hi = min(lo, abs(det) / big if big else 0.0), max(hi, big)
            k += 2
        else:
            v = d[k]
            neg += v < 0
            lo, hi = min(lo, abs(v)), max(hi, abs(v))
            k += 1
    return neg, lo, hi


def follow(
    solver: Solver,
    st: State,
    t0: float,
    t1: float,
    set_t: Callable[[State, float], State],
    wrt: str,
    lam_free: bool = False,
    max_cuts: int = 12,
    rate: float = 1.0,
    accept: Callable[[State, State, float], bool] | None = None,
) -> State:
    """Move the path parameter from t0 to t1 (``set_t(state, t) -> state`` applies it),
    with tangent predictor, step halving on a failure and doubling after an easy step;
    raises SolveError once a step would be shorter than ``|t1 - t0| / 2^max_cuts``.
    ``rate``: d(solver parameter)/dt (driver in degrees: pi/180).  ``accept(state, new,
    step) -> bool``: a converged substep it refuses (one that left the branch) is cut too.

    The give-up rule is a step length, not a count of the cuts so far: a count grows with
    the path's curvature over the whole interval, and where a steep but smooth stretch
    spends about ``max_cuts`` of them the round-off of the drawing (its orientation, its
    units) decided whether the step succeeded or was taken for a limit point."""
    t, h, its = t0, t1 - t0, 0
    shortest = abs(t1 - t0) * 0.5**max_cuts
    nf = solver.nf
    d = solver.driver_index() if lam_free else None
    while (t1 - t) * (t1 - t0) > 1e-14 * max(abs(t1 - t0), 1e-300):
        step = h if abs(h) < abs(t1 - t) else t1 - t
        try:
            dx = solver.tangent(st, wrt, lam_free) * rate
            x = np.concatenate([st.q[solver.f], st.mu])
            if lam_free:
                x[nf + d] = st.lam  # the load factor sits in the driver multiplier's slot
            xp = _predict(solver, (wrt, lam_free), t, x, dx, t + step)
            pred = State(st.q.copy(), xp[nf:].copy(), st.lam)
            pred.q[solver.f] = xp[:nf]
            if lam_free:
                pred.lam = float(xp[nf + d])
                pred.mu[d] = 0.0
            pred = set_t(pred, t + step)
            try:
                new = solver.newton(pred, lam_free)
            except SolveError:
                solver.memo = None
                new = solver.newton(set_t(State(st.q, st.mu, st.lam), t + step), lam_free)
            if accept is not None and not accept(st, new, step):
                raise SolveError("the substep left the branch")
        except SolveError as err:
            h = step / 2.0
            if abs(h) < shortest:
                raise SolveError(
                    f"step cut below 1/2^{max_cuts} of the interval near t = {t:.6g}: {err}"
                ) from None
            continue
        solver.memo = ((wrt, lam_free), t, x, dx)
        its += new.iterations
        st, t = new, t + step
        if new.iterations <= 4:
            h = 2.0 * step
    st.iterations = its
    return st


def _predict(
    solver: Solver, kind: tuple, t: float, x: np.ndarray, dx: np.ndarray, t_new: float
) -> np.ndarray:
    """Predictor: cubic Hermite through the previous and the current converged state and
    their tangents (extrapolated to ``t_new``), else the tangent line.  The Hermite cubic is
    dropped when it runs more than 3x further than the tangent line (a tangent blowing up
    near a limit or bifurcation point)."""
    line = x + (t_new - t) * dx
    memo = getattr(solver, "memo", None)
    if memo is None or memo[0] != kind or memo[1] == t or len(memo[2]) != len(x):
        return line
    _, t0, x0, dx0 = memo
    H = t - t0
    tau = (t_new - t0) / H
    h00, h10 = 2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau
    h01, h11 = -2 * tau**3 + 3 * tau**2, tau**3 - tau**2
    cubic = h00 * x0 + h10 * H * dx0 + h01 * x + h11 * H * dx
    a, b = cubic - x, line - x  # norms as numpy's 2-norm computes them: sqrt(v . v)
    if math.sqrt(float(a @ a)) > 3.0 * math.sqrt(float(b @ b)):
        return line
    return cubic
