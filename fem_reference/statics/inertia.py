"""Stability verdict of a converged state from the inertia of one band Cholesky factorisation.

The verdict every reported FE state carries (``models.Runner.stab``) and the stability watch
of a load path (``bifurcation.Watch``) both need the same thing: is the symmetric part of the
tangent at the state positive definite?  By Sylvester's law of inertia that is decided by the
pivots of one symmetric factorisation, so per state:

1. the tangent is assembled once, from the element state of the solver's own last
   evaluation at exactly that state (``State.ev``; evaluated afresh only for a state that
   carries none);
2. its symmetric part is Jacobi scaled, ``S K_sym S`` with ``S = diag(1 / sqrt|K_ii|)`` (well
   conditioned even for EA L^2/EI ~ 1e8, where a length-scaled matrix lets round-off pass an
   indefinite one), and factorised by banded Cholesky (LAPACK ``dpbtrf``): success = every
   pivot positive = stable, ``n_neg = 0``; the smallest pivot ``d_min`` of that ``L D L^T``
   (``min_pivot``, dimensionless, an upper bound of the scaled matrix's lowest eigenvalue:
   ``d_k = 1 / (A_k^-1)_kk >= lambda_min``) is reported with it;
3. only a state that is not positive definite -- rare on a path, and there the count of
   negative eigenvalues matters -- goes on to ``static.stability`` (dense ``eigvalsh`` up to
   ``dense_max`` DOFs, band bisection or sparse LDL^T beyond), reusing the assembled band.

No inverse iteration and no second factorisation is spent on a stable state: the lowest
eigenvalue of a stable tangent is no part of the verdict (``static.stability`` still gives
it to a caller that asks).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from fem_reference.banded import BAND_MAX, hold_dof, symmetric_upper_band
from fem_reference.rigid import stability_view
from fem_reference.statics import static as S

_dpbtrf = sla.lapack.dpbtrf


def evaluation(system: object, st: S.State) -> object:
    """The fast-path evaluation of ``system`` at ``st``: the solver's own (``st.ev``) when it
    was made at exactly this state, else a new one."""
    ev = st.ev
    if ev is None or ev.u is not st.u or ev.lam != st.lam:
        ev = system.evaluate(st.u, st.lam)
    return ev


def stability_band(system: object, st: S.State) -> np.ndarray | None:
    """The stability tangent at ``st`` in ``dgbtrf`` band storage (3 bw + 1, ndof), or None
    without a narrow band fast path."""
    bw = getattr(system, "bandwidth", None)
    if bw is None or bw > BAND_MAX or not hasattr(system, "tangent_band"):
        return None
    ev = evaluation(system, st)
    with stability_view(system):  # exact rigid links: the augmented Lagrangian Hessian
        return system.tangent_band(ev)


def jacobi_inertia(ab: np.ndarray, bw: int, exclude: int | None = None) -> float | None:
    """Smallest ``L D L^T`` pivot of the Jacobi-scaled symmetric part of ``ab`` (a ``dgbtrf``
    band, half-bandwidth ``bw``) when it is positive definite, else None.  ``exclude``: a DOF
    held fixed (decoupled with a unit diagonal: the inertia of the rest)."""
    d = np.abs(ab[2 * bw])
    up = symmetric_upper_band(ab, bw, 1.0 / np.sqrt(np.where(d > 0.0, d, 1.0)))
    if exclude is not None:
        hold_dof(up, bw, exclude, 1.0)
    chol, info = _dpbtrf(up, lower=0, overwrite_ab=1)
    if info != 0:
        return None
    piv = float(np.min(chol[bw]))  # the Cholesky diagonal is sqrt of the LDL^T pivots
    return piv * piv


def jacobi_verdict(system: object, st: S.State) -> tuple[np.ndarray | None, float | None]:
    """``(band, smallest pivot or None)`` of ``st`` (``stability_band``, ``jacobi_inertia``);
    ``(None, None)`` without a band fast path."""
    ab = stability_band(system, st)
    return ab, None if ab is None else jacobi_inertia(ab, system.bandwidth)


def state_stability(
    system: object,
    st: S.State,
    dense_max: int = 60,
    exclude: int | None = None,
    pre: tuple | None = None,
) -> dict:
    """``{'stable', 'n_neg', 'min_pivot' | 'min_eig', 'jacobi_pd'}`` of a converged state (see
    the module docstring); ``jacobi_pd`` is the Cholesky verdict alone (the watch's test).
    ``pre``: ``jacobi_verdict(system, st)`` when the caller has it (``exclude`` None)."""
    if system.ndof - (exclude is not None) <= 0:
        return {"stable": True, "min_eig": math.nan, "n_neg": 0, "jacobi_pd": True}
    if pre is not None and exclude is None:
        ab, piv = pre
    else:
        ab = stability_band(system, st)
        piv = None if ab is None else jacobi_inertia(ab, system.bandwidth, exclude)
    if piv is not None:
        return {"stable": True, "n_neg": 0, "min_pivot": piv, "jacobi_pd": True}
    res = S.stability(system, st.u, st.lam, dense_max, exclude, ab=ab)
    return {**res, "jacobi_pd": ab is None and bool(res["stable"])}


__all__ = [
    "evaluation",
    "jacobi_inertia",
    "jacobi_verdict",
    "stability_band",
    "state_stability",
]
