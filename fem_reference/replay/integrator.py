"""Time integration for the damped replay: generalised-alpha with Newton, adaptive steps, events.

The equations of motion of a ``DiscreteSystem`` with viscous damping ``C`` and optional
holonomic distance constraints (locked booms) are::

    M qdd + C qd + r(q, lam(t)) + f_act(q) + G(q)^T mu = 0,      g(q) = 0

integrated with the generalised-alpha method in the form of Arnold & Bruls (2007): the
equation of motion holds exactly at t_{n+1} (so a state at rest is an exact static
equilibrium, whatever the step) and an algorithmic acceleration ``a`` carries the
Chung-Hulbert (1993) alpha weights::

    (1 - alpha_m) a_{n+1} + alpha_m a_n = (1 - alpha_f) qdd_{n+1} + alpha_f qdd_n
    q_{n+1} = q_n + h qd_n + h^2 ((1/2 - beta) a_n + beta a_{n+1})
    qd_{n+1} = qd_n + h ((1 - gamma) a_n + gamma a_{n+1})

Newton iterates on q_{n+1} with the iteration matrix ``K + gamma'/(beta' h) C + M/(beta' h^2)``
(``beta', gamma' = beta, gamma * (1-alpha_f)/(1-alpha_m)``), bordered by constraint rows.
Second order for rho_inf in [0, 1] with constant C (the default mass damping); damping with
the start-of-step tangent ("current") lags C by one step and is first order in it.

Events (``events.py``): a ``LengthLock`` is the thesis's tape-spring boom -- a constant push
``force`` between two points until their distance reaches ``length``, then a bar of exactly
that length. The crossing is located by root finding on the step size (Brent on the step
fraction, 1e-14), the bar is switched on as an exact constraint with a perfectly plastic latch
(relative normal velocity removed by a mass-consistent projection, the lost kinetic energy
booked as dissipated) and the integration restarts with consistent accelerations. No penalty
stop, hence no BISTOP-style chatter around the locked length.

References: J. Chung & G. M. Hulbert, J. Appl. Mech. 60:371 (1993), doi 10.1115/1.2900803;
M. Arnold & O. Bruls, Multibody Syst. Dyn. 18:185 (2007), doi 10.1007/s11044-007-9084-0;
O. C. Zienkiewicz & Y. M. Xie, Earthq. Eng. Struct. Dyn. 20:871 (1991),
doi 10.1002/eqe.4290200907 (local error estimate of Newmark-type schemes).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.optimize as so
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg.blas import dgbmv as _dgbmv

from fem_reference.banded import BAND_MAX, BandedLU, csr_to_band
from fem_reference.replay.band import band_mass, step_band

if TYPE_CHECKING:
    from fem_reference.replay.events import LockPair


def ramp(tau: float) -> float:
    """C2 quintic ramp 0 -> 1 on [0, 1] (clipped outside)."""
    t = min(max(tau, 0.0), 1.0)
    return t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)


def ramp_path(a: float, b: float, t0: float, T: float) -> Callable[[float], float]:
    """Load factor a -> b over [t0, t0 + T] along ``ramp``."""
    return lambda t: a + (b - a) * ramp((t - t0) / T)


def combine(terms: list[tuple[float, sp.spmatrix]]) -> sp.csr_matrix:
    """sum(c_i A_i) of csr matrices; a data-array sum when they share one sparsity pattern
    (the FE system scatters mass and tangent into the same pattern), else a sparse sum."""
    A0 = terms[0][1]
    same = all(
        sp.isspmatrix_csr(A)
        and A.nnz == A0.nnz
        and np.array_equal(A.indptr, A0.indptr)
        and np.array_equal(A.indices, A0.indices)
        for _, A in terms
    )
    if same:
        data = sum(c * A.data for c, A in terms)
        return sp.csr_matrix((data, A0.indices, A0.indptr), shape=A0.shape)
    out = terms[0][0] * sp.csr_matrix(A0)
    for c, A in terms[1:]:
        out = out + c * sp.csr_matrix(A)
    return out.tocsr()


def bordered(
    solve: Callable[[np.ndarray], np.ndarray], Gc: np.ndarray, dq: np.ndarray, gc: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A Newton correction ``dq`` = -A^-1 R of the unconstrained system (``solve`` = A^-1)
    bordered by the locked booms' rows, so that G dq = -g: (dq - X dmu, dmu) with
    X = A^-1 G^T, (m,) multiplier update dmu (G (m, n), g (m,))."""
    X = solve(Gc.T)
    dmu = np.linalg.solve(Gc @ X, Gc @ dq + gc)
    return dq - X @ dmu, dmu


def factor(A: sp.spmatrix, bw: int | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """LU of A; returns solve(b).  Within half-bandwidth ``bw`` (the FE system's, when narrow):
    LAPACK banded LU (``dgbtrf``; 2-3x cheaper than SuperLU at 100 DOFs).  Otherwise (or when
    lock Hessians widen the band) sparse LU: a csr matrix is handed to SuperLU as the csc
    matrix of A^T (no conversion) and solved with ``trans="T"``.  Raises RuntimeError for an
    exactly singular matrix."""
    A = sp.csr_matrix(A)
    if bw is not None and bw <= BAND_MAX and A.nnz:
        rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
        if int(np.abs(rows - A.indices).max()) <= bw:
            return BandedLU(csr_to_band(A, bw), bw).solve  # SingularTangent: a RuntimeError
    At = sp.csc_matrix((A.data, A.indices, A.indptr), shape=A.shape[::-1])
    lu = spla.splu(At, permc_spec="MMD_AT_PLUS_A")
    return lambda b: lu.solve(b, trans="T")


@dataclass
class State:
    """Integrator state at time t (all arrays (ndof,)); ``mu`` one multiplier per locked pair."""

    t: float
    lam: float
    q: np.ndarray
    v: np.ndarray
    acc: np.ndarray  # true acceleration qdd
    a: np.ndarray  # algorithmic acceleration of the alpha recursion
    mu: np.ndarray
    f_ext: np.ndarray  # lam * f_ext(q) + actuator forces (for the work integral)
    K: sp.csr_matrix | None = None  # tangent at (about) q, for current-stiffness damping

    def copy(self) -> State:
        return replace(
            self,
            q=self.q.copy(),
            v=self.v.copy(),
            acc=self.acc.copy(),
            a=self.a.copy(),
            mu=self.mu.copy(),
            f_ext=self.f_ext.copy(),
        )


class GenAlpha:
    """Generalised-alpha integrator of one DiscreteSystem with damping and boom events.

    Parameters
    ----------
    system : DiscreteSystem.
    damping : (a0, a1, K0): C = a0 M + a1 K with K the *current* tangent (objective; the
        tangent of the step's start state) or, when ``K0`` is given, the fixed initial one.
    pairs : resolved LengthLocks (mutated: ``locked`` flips at the event).
    w : (ndof,) weights turning DOFs into lengths (1 for translations, L for rotations).
    L : length scale; rho_inf : spectral radius at infinite step (numerical dissipation).
    newton_tol : Newton accepts the evaluated state whose correction max|w dq| computed from
        its own residual is <= newton_tol * L (the state returned is the one evaluated).
    mass : the mass matrix to use (default ``system.mass()``; see ``point_masses``).
    """

    def __init__(
        self,
        system: object,
        damping: tuple[float, float, sp.spmatrix | None],
        pairs: list[LockPair],
        w: np.ndarray,
        L: float,
        rho_inf: float = 0.6,
        newton_tol: float = 1e-11,
        max_iter: int = 12,
        mass: sp.spmatrix | None = None,
    ) -> None:
        self.sys = system
        self.M = sp.csr_matrix(system.mass() if mass is None else mass)
        self.a0, self.a1, K0 = damping
        self.K0 = None if K0 is None else sp.csr_matrix(K0)
        self.pairs = pairs
        self.w, self.L = w, L
        r = rho_inf
        self.am = (2 * r - 1) / (r + 1)
        self.af = r / (r + 1)
        self.gamma = 0.5 - self.am + self.af
        self.beta = 0.25 * (self.gamma + 0.5) ** 2
        k = (1 - self.af) / (1 - self.am)
        self.beta_p, self.gamma_p = self.beta * k, self.gamma * k
        self.newton_tol, self.max_iter = newton_tol, max_iter
        self.act_ramp = 0.0  # ramp-in time of the boom pushes (set by the replay)
        self.newton_iterations = 0
        self.factorizations = 0
        self.bw = getattr(system, "bandwidth", None)  # half-bandwidth of the FE matrices
        self.alg = getattr(system, "algebraic", None)  # DOF indices without inertia
        self._Mb = band_mass(self)  # not None: ``step`` works in band storage
        n, bw = self.M.shape[0], self.bw
        # M in ``dgbmv`` storage (the rows below the fill-in; scipy's wrapper needs n > 2 bw)
        self._Mg = None if self._Mb is None or n <= 2 * bw else np.asfortranarray(self._Mb[bw:])
        self._C0 = None  # mass damping a0 M, once asked for
        self.keep_lu: dict | None = None  # factorisation kept across steps (band.py)
        try:
            self._Msolve = factor(self.M)
        except RuntimeError:  # singular mass (massless DOFs): no consistent start accel.
            self._Msolve = None

    # -- forces --------------------------------------------------------------------------------
    def act(self, t: float) -> float:
        """Scale of the boom pushes at time t (ramped in over ``act_ramp`` from t = 0)."""
        return ramp(t / self.act_ramp) if self.act_ramp > 0.0 else 1.0

    def forces(self, q: np.ndarray, lam: float, t: float = math.inf, tangent: bool = True) -> tuple:
        """Static residual (incl. actuators at time t), tangent, external force, constraints.

        Returns r (ndof,), K (sparse or None), f_ext (ndof,) = lam f_ext + actuator pushes,
        Gc (nc, ndof) rows of the locked pairs, gc (nc,) gaps, Hs list of Hessians.
        """
        if tangent:
            r, K = self.sys.residual_and_tangent(q, lam)
        else:
            r, K = self.sys.residual(q, lam), None
        r = np.array(r, dtype=float)
        fe = lam * np.asarray(self.sys.external(q), dtype=float)
        Gc, gc, Hs = [], [], []
        for p in self.pairs:
            ell, G, H = p.geometry(q)
            if p.locked:
                Gc.append(G)
                gc.append(ell - p.lock.length)
                Hs.append(H)
            elif p.lock.stop_stiffness:  # collision damper: push on, elastic stop past length
                F = p.lock.force * self.act(t)
                k, over = p.lock.stop_stiffness, max(ell - p.lock.length, 0.0)
                r -= (F - k * over) * G
                fe += F * G
                if tangent:
                    terms = [(1.0, K), (-(F - k * over), H)]
                    if over > 0.0:
                        terms.append((k, sp.csr_matrix(np.outer(G, G))))
                    K = combine(terms)
            elif p.lock.force:
                F = p.lock.force * self.act(t)
                r -= F * G
                fe += F * G
                if tangent:
                    K = combine([(1.0, K), (-F, H)])
        Gc = np.array(Gc).reshape(len(Gc), q.size)
        return r, K, fe, Gc, np.array(gc), Hs

    def damping(self, s: State) -> sp.csr_matrix:
        """C = a0 M + a1 K for a step starting at ``s`` (K: current tangent or initial K0)."""
        K = self.K0 if self.K0 is not None else s.K
        if self.a1 == 0.0 or K is None:
            if self._C0 is None:  # constant: built once (the energy books ask every step)
                self._C0 = self.a0 * self.M
            return self._C0
        return combine([(self.a0, self.M), (self.a1, K)])

    def mass_times(self, x: np.ndarray) -> np.ndarray:
        """M x (a band product when M has the FE band: ~5x cheaper than csr at 100 DOFs)."""
        if self._Mg is None:
            return self.M @ x
        n = x.shape[0]
        return _dgbmv(n, n, self.bw, self.bw, 1.0, self._Mg, x)

    def damping_power(self, s: State, v: np.ndarray) -> float:
        """v^T C v for a step starting at ``s`` (``damping``), the rate of dissipation."""
        if self.a1 == 0.0 or (self.K0 is None and s.K is None):
            return self.a0 * float(v @ self.mass_times(v))
        return float(v @ (self.damping(s) @ v))

    def start(self, t: float, lam: float, q: np.ndarray, v: np.ndarray) -> State:
        """A state with consistent accelerations (constrained if pairs are locked)."""
        nc = sum(p.locked for p in self.pairs)
        st = State(
            t,
            lam,
            q.copy(),
            v.copy(),
            np.zeros_like(q),
            np.zeros_like(q),
            np.zeros(nc),
            np.zeros_like(q),
        )
        r, K, fe, Gc, _, Hs = self.forces(q, lam, t)
        st.f_ext, st.K = fe, K
        if self._Msolve is None:
            return st
        rhs = -(self.damping(st) @ v + r)
        acc = self._Msolve(rhs)
        if nc:
            # index-1 constraint G acc + v^T H v = 0 via the Schur complement of M
            X = self._Msolve(Gc.T)
            curv = np.array([v @ (H @ v) for H in Hs])
            mu = np.linalg.solve(Gc @ X, Gc @ acc + curv)
            acc = acc - X @ mu
            st.mu = mu
        st.acc, st.a = acc, acc.copy()
        return st

    # -- one step ------------------------------------------------------------------------------
    def step(self, s: State, h: float, lam: float) -> State | None:
        """Advance ``s`` by ``h`` to load factor ``lam``; None if Newton fails."""
        if self._Mb is not None:
            return step_band(self, s, h, lam)
        b, g, am, af = self.beta, self.gamma, self.am, self.af
        astar = (af * s.acc - am * s.a) / (1 - am)
        qh = s.q + h * s.v + h * h * ((0.5 - b) * s.a + b * astar)
        vh = s.v + h * ((1 - g) * s.a + g * astar)
        cq = 1.0 / (self.beta_p * h * h)  # d acc / d q
        cv = self.gamma_p / (self.beta_p * h)  # d v / d q
        acc = s.acc.copy()
        q = qh + acc / cq
        mu = s.mu.copy()
        C = self.damping(s)
        tol = self.newton_tol * self.L
        prev = math.inf
        for it in range(1, self.max_iter + 1):
            v = vh + acc * (cv / cq)
            r, K, fe, Gc, gc, Hs = self.forces(q, lam, s.t + h)
            R = self.M @ acc + C @ v + r
            terms = [(1.0, K), (cv, C), (cq, self.M)]
            if mu.size:
                R = R + Gc.T @ mu
                terms += [(m_, H) for m_, H in zip(mu, Hs)]
            try:
                solve = factor(combine(terms), self.bw)
            except RuntimeError:
                return None
            self.factorizations += 1
            dq = -solve(R)
            dmu = None
            if mu.size:
                dq, dmu = bordered(solve, Gc, dq, gc)
            if not np.all(np.isfinite(dq)):
                return None
            err = float(np.max(np.abs(self.w * dq)))
            self.newton_iterations += 1
            if err <= tol:  # accept the evaluated state: its own correction is within tol
                break
            q = q + dq
            acc = acc + cq * dq
            if dmu is not None:
                mu = mu + dmu
            if it > 3 and err > 0.5 * prev:  # not contracting: let the caller cut h
                return None
            prev = err
        else:
            return None
        v = vh + acc * (cv / cq)
        a = (1 - af) / (1 - am) * acc + astar
        if self.alg is not None:  # algebraic unknowns (a servo's load factor): no inertia
            v[self.alg] = acc[self.alg] = a[self.alg] = 0.0
        # external force at the converged state for the work integral (actuators included)
        fe_new = lam * np.asarray(self.sys.external(q), dtype=float)
        for p in self.pairs:
            if not p.locked and p.lock.force:
                fe_new += p.lock.force * self.act(s.t + h) * p.geometry(q)[1]
        return State(s.t + h, lam, q, v, acc, a, mu, fe_new, K)

    def error(self, s0: State, s1: State, h: float) -> float:
        """Local displacement error estimate / L (Zienkiewicz-Xie type)."""
        de = h * h * abs(self.beta - 1.0 / 6.0) * (s1.a - s0.a)
        return float(np.max(np.abs(self.w * de))) / self.L

    # -- events --------------------------------------------------------------------------------
    def crossing(self, s0: State, s1: State) -> LockPair | None:
        """The unlocked pair whose gap changes sign from s0 to s1 (extending) earliest in the
        step (linear estimate): two booms crossing in one step lock in turn, the step is
        located on the first, and the second still has its crossing ahead of it."""
        hits = []
        for p in self.pairs:
            latches = not p.locked and not p.lock.stop_stiffness  # a damper stop never latches
            g0, g1 = (p.gap(s0.q), p.gap(s1.q)) if latches else (0.0, 0.0)
            if g0 < 0.0 <= g1:
                hits.append((g0 / (g0 - g1), len(hits), p))
        return min(hits)[2] if hits else None

    def locate(
        self, s0: State, h: float, lam_of_t: Callable[[float], float], pair: LockPair
    ) -> State | None:
        """Re-integrate from ``s0`` with the step fraction that lands on gap = 0 (Brent)."""
        memo: dict[float, State] = {}

        def gap(x: float) -> float:
            if x == 0.0:
                return pair.gap(s0.q)
            st = self.step(s0, x * h, lam_of_t(s0.t + x * h))
            if st is None:
                raise ReplayError("Newton failed while locating the boom lock")
            memo[x] = st
            return pair.gap(st.q)

        x = so.brentq(gap, 0.0, 1.0, xtol=1e-14, rtol=1e-15)
        return memo[x] if x in memo else self.step(s0, x * h, lam_of_t(s0.t + x * h))

    def lock(self, s: State, pair: LockPair) -> tuple[State, float]:
        """Switch ``pair`` to a bar: plastic latch of its normal velocity, restart.

        Returns the restarted state and the kinetic energy lost in the latch.
        """
        pair.locked = True
        if self._Msolve is None:
            raise RuntimeError("a boom lock needs a non-singular mass matrix")
        Gc = self.forces(s.q, s.lam, s.t, tangent=False)[3]
        X = self._Msolve(Gc.T)
        v = s.v - X @ np.linalg.solve(Gc @ X, Gc @ s.v)
        lost = 0.5 * float(s.v @ (self.M @ s.v) - v @ (self.M @ v))
        return self.start(s.t, s.lam, s.q, v), lost


# -- modal tools and option parsing ---------------------------------------------------------


class ReplayError(RuntimeError):
    """The replay could not continue (message says why)."""
