"""The replay's generalised-alpha step in LAPACK band storage (no locks or boom pushes).

Without locks or pushes every matrix of a step -- tangent K, damping C, mass M -- has the
FE system's band, so the iteration matrix ``K + cv C + cq M`` is assembled straight into
``dgbtrf`` storage (no csr assembly, no SuperLU: together 3x the cost of the banded
factorisation at 100 DOFs) and solved by modified Newton: factorised at the first iteration
of a step and again only when the updates stop contracting fast (an update above
``REFRESH`` times the previous one).  While ``GenAlpha.keep_lu`` is a dict (an impulse
probe: small motion about a settled state, steps of one size) the factorisation also
carries over to the next step of the same size.  Convergence is judged by the update test
of ``GenAlpha.step`` (an update within the Newton tolerance) or, once two updates are
known, by the updates still to come: at most theta / (1 - theta) of the last one while they
contract by theta < 1/2 -- the converged state is the same to that tolerance, and a step
spends one iteration fewer than waiting for the next update to be within it.

The tangent test of a settled state in band storage too (``lowest_mode``): banded Cholesky
and inverse iteration warm-started from the previous state's mode, where a dense
generalised eigensolver costs ~1 ms at 100 DOFs.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dpbtrf as _dpbtrf
from scipy.linalg.lapack import dpbtrs as _dpbtrs

from fem_reference.banded import BAND_MAX, BandedLU, csr_to_band, symmetric_upper_band

if TYPE_CHECKING:
    from fem_reference.replay.integrator import GenAlpha, State

REFRESH = 0.1  # modified Newton: refactorise when an update is above this ratio of the last
EIG_RTOL = 1e-12  # inverse iteration: estimated relative error of the lowest eigenvalue
EIG_MAX_IT = 60


def band_mass(integ: GenAlpha) -> np.ndarray | None:
    """M in ``dgbtrf`` band storage when the band step applies (no locks or pushes, a system
    with a band tangent, M within the band), else None."""
    M, bw = integ.M, integ.bw
    if integ.pairs or not hasattr(integ.sys, "tangent_band") or not bw or bw > BAND_MAX:
        return None
    rows = np.repeat(np.arange(M.shape[0]), np.diff(M.indptr))
    if not M.nnz or int(np.abs(rows - M.indices).max()) > bw:
        return None
    return csr_to_band(M, bw)


def step_band(integ: GenAlpha, s: State, h: float, lam: float) -> State | None:
    """``step`` without locks or pushes, every matrix in LAPACK band storage (no csr
    assembly, no SuperLU), by modified Newton: the iteration matrix K + cv C + cq M is
    factorised at the first iteration and again only when the updates stop contracting
    fast (ratio above ``REFRESH``); convergence is judged by the same update test."""
    b, g, am, af = integ.beta, integ.gamma, integ.am, integ.af
    astar = (af * s.acc - am * s.a) / (1 - am)
    qh = s.q + h * s.v + h * h * ((0.5 - b) * s.a + b * astar)
    vh = s.v + h * ((1 - g) * s.a + g * astar)
    cq = 1.0 / (integ.beta_p * h * h)
    cv = integ.gamma_p / (integ.beta_p * h)
    acc = s.acc.copy()
    q = qh + acc / cq
    a0, C = integ.a0, None
    if integ.a1 == 0.0:  # C = a0 M: its band is M's, and one band product M (acc + a0 v)
        Cb = (cv * a0 + cq) * integ._Mb
    else:
        C = integ.damping(s)
        Cb = cv * csr_to_band(C, integ.bw) + cq * integ._Mb
    tol = integ.newton_tol * integ.L
    keep = integ.keep_lu  # {h: solve} while a probe reuses its factorisation across steps
    prev, solve, fresh = math.inf, None if keep is None else keep.get(h), False
    for it in range(1, 2 * integ.max_iter + 1):
        v = vh + acc * (cv / cq)
        ev_ = integ.sys.evaluate(q, lam)
        if solve is None:
            try:
                solve = BandedLU(integ.sys.tangent_band(ev_) + Cb, integ.bw).solve
            except RuntimeError:
                return None
            integ.factorizations += 1
            fresh = True
            if keep is not None:
                keep.clear()
                keep[h] = solve
        if C is None:
            x = acc + a0 * v
            inertia = integ.mass_times(x)
        else:
            inertia = integ.M @ acc + C @ v
        dq = -solve(inertia + ev_.r)
        if not np.all(np.isfinite(dq)):
            return None
        q = q + dq
        acc = acc + cq * dq
        err = float(np.max(np.abs(integ.w * dq)))
        integ.newton_iterations += 1
        theta = err / prev if it > 1 else 1.0  # contraction of the updates
        # converged: this update, or the ones still to come (at most theta / (1 - theta) of
        # it while they contract by theta), within tol
        if err <= tol or theta < 0.5 and theta * err <= (1.0 - theta) * tol:
            break
        if err > REFRESH * prev:
            if fresh and it > 3 and err > 0.5 * prev:  # not contracting with a new matrix
                return None
            solve = None  # a stale matrix: refactorise at the current state
        fresh = False
        prev = err
    else:
        return None
    v = vh + acc * (cv / cq)
    a = (1 - af) / (1 - am) * acc + astar
    if integ.alg is not None:  # algebraic unknowns (a servo's load factor): no inertia
        v[integ.alg] = acc[integ.alg] = a[integ.alg] = 0.0
    fe_new = lam * np.asarray(integ.sys.external(q), dtype=float)
    # the tangent for current-stiffness damping of the next step, only when it is used
    K = integ.sys.tangent_csr(ev_) if integ.a1 != 0.0 and integ.K0 is None else None
    return replace(s, t=s.t + h, lam=lam, q=q, v=v, acc=acc, a=a, mu=s.mu.copy(), f_ext=fe_new, K=K)


def lowest_mode(
    K: sp.csr_matrix, M: sp.csr_matrix, bw: int, warm: dict
) -> tuple[float, np.ndarray] | None:
    """Lowest eigenpair of the symmetric part of (K, M) when it is positive definite
    (``lowest_mode_band``); None also when K does not fit the band."""
    n = K.shape[0]
    rows = np.repeat(np.arange(n), np.diff(K.indptr))
    if not K.nnz or int(np.abs(rows - K.indices).max()) > bw:
        return None
    return lowest_mode_band(csr_to_band(K, bw), M, bw, warm)


def lowest_mode_band(
    Kb: np.ndarray, M: sp.csr_matrix, bw: int, warm: dict
) -> tuple[float, np.ndarray] | None:
    """Lowest eigenpair of the symmetric part of (K, M), K in ``dgbtrf`` band storage
    ``Kb``, when it is positive definite: the banded Cholesky (``dpbtrf``) succeeds, then
    inverse iteration x <- K^-1 M x with Rayleigh quotients, warm-started from ``warm["x"]``
    (the previous settled state's mode; replaced by the new one).  Stops when the error
    estimated from the convergence rate is below ``EIG_RTOL``; the mode is M-normalised, its
    largest component positive.  None when K is not positive definite or the iteration is
    too slow (close eigenvalues): the dense test decides."""
    n = Kb.shape[1]
    chol, info = _dpbtrf(symmetric_upper_band(Kb, bw, np.ones(n)), lower=0)
    if info != 0:
        return None
    x = warm.get("x")
    x = np.cos(np.arange(n) * 0.7071) + 0.5 if x is None or x.shape != (n,) else x
    lam, diff = math.nan, math.nan  # the last eigenvalue and its last change
    for _ in range(EIG_MAX_IT):
        y = _dpbtrs(chol, M @ x, lower=0)[0]  # K y = M x
        My = M @ y
        new = float(y @ (M @ x)) / float(y @ My)  # Rayleigh quotient y K y / y M y
        x = y / math.sqrt(float(y @ My))
        d = abs(new - lam)
        # linear convergence: the error left is ~ d rate / (1 - rate) (a rate once two changes
        # are known; an exact repeat has converged)
        rate = d / diff if diff > 0.0 else 0.0 if diff == 0.0 else math.inf
        lam, diff = new, d
        if rate < 1.0 and d * rate <= EIG_RTOL * abs(lam) * (1.0 - rate):
            warm["x"] = x if x[np.argmax(np.abs(x))] > 0 else -x
            return lam, warm["x"]
    return None
