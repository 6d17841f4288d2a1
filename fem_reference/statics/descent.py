"""Energy descent at a fixed load factor: where a damped structure settles after a snap.

At a subcritical bifurcation (DAS-2D Ex. 3's unguided shuttle tilting) no stable state lies
next to the critical one: the structure leaves dynamically and settles wherever the damped
motion takes it.  Following the bifurcated branch by arc-length does not answer that (the
branch falls in load, may close on itself, and where an arc-length step lands past it
depends on round-off).  ``descend`` answers it statically and deterministically: from the
critical state displaced along the critical mode, the gradient flow of the total potential
at the fixed factor,

    M du/dt = -r(u, lam),

integrated by pseudo-transient continuation (Kelley & Keyes 1998): Newton on ``K + alpha
M``, ``alpha`` kept where the shifted stability tangent is positive definite (twice the
smallest such shift: every step descends the energy, along the unstable mode at the pace of
its own curvature) and adapted as a Levenberg-Marquardt trust region on the potential (a
step that releases energy quarters it, one that does not is refused and quadruples it).
With ``alpha`` -> 0 in a stable basin this is Newton, and the landing is polished by
``static.newton`` (the solver's own convergence test).  An unstable landing (a saddle the
flow stopped at) is displaced along its own lowest mode, both signs, and relaxed again.

Exact rigid links (Lagrange multipliers, ``fem_reference.rigid``): the step solves the KKT
system, the pseudo-mass is zero on the multipliers, and convexity is judged on the
augmented-Lagrangian stability tangent (positive definite exactly when the energy Hessian is
on the constraints' tangent space).  The pseudo-mass is the residual scale over Newton's
step caps (force / length, moment / rad): one metric for every DOF; a Jacobi mass would make
the soft snap mode as heavy as the members' axial stiffness.  The same scheme lands the
reduced models' snaps (``reduced_models/mechanism/snap.py``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem_reference.banded import BAND_MAX, arpack_start, csr_to_band, symmetric_upper_band
from fem_reference.rigid import stability_view
from fem_reference.statics import static as S
from fem_reference.statics.inertia import jacobi_inertia

DENSE_MAX = 800  # lowest_mode: dense eigh up to this many DOFs, sparse shift-invert beyond
BAND_EIG_MIN = 200  # ... and the band eigensolver above this many where the band is narrow
RELAX_ITER = 400  # pseudo-time steps of one relaxation
POLISH = 1e3  # residual (x Newton's tolerance) below which a convex state is polished by Newton
ALPHA0 = 1.0  # pseudo-time shift at the start, in units of the pseudo-mass
ARMIJO = 1e-4  # fraction of the first-order energy release a kept step must release


def lowest_mode(
    system: object, u: np.ndarray, lam: float, scale: np.ndarray | None = None
) -> tuple[float, np.ndarray, np.ndarray]:
    """Lowest eigenvalue of the symmetrically scaled tangent ``S K_sym S`` and its mode in
    displacement coordinates ``S v`` (ndof,), normalised to unit largest entry, and ``S``.

    ``S = diag(1 / sqrt|K_ii|)`` (Jacobi scaling; computed here unless given): with axial
    stiffness EA L^2/EI up to 1e8 the unscaled tangent has a condition number near 1e11 and
    its lowest eigenvalue only an absolute accuracy of eps ||K||; scaled, the bending and
    axial entries are both O(1), the sign (Sylvester's inertia) is the same and the zero
    crossing -- the critical factor -- is found to round-off.  Pass one fixed ``S`` along a
    path so that the eigenvalue is a continuous function of the load factor.
    """
    with stability_view(system):  # exact rigid links: the augmented Lagrangian Hessian
        _, K = system.residual_and_tangent(u, lam)
    Ks = (0.5 * (K + K.T)).tocsc()
    if scale is None:
        d = np.abs(Ks.diagonal())
        scale = 1.0 / np.sqrt(np.where(d > 0.0, d, 1.0))
    bw = getattr(system, "bandwidth", None)
    if bw is not None and bw <= BAND_MAX and Ks.shape[0] > BAND_EIG_MIN:
        # LAPACK dsbevx on the band: O(n bw^2), not dense eigh's O(n^3) (58 ms at n = 768)
        up = symmetric_upper_band(csr_to_band(sp.csr_matrix(Ks), bw), bw, scale)
        w, v = sla.eig_banded(up, lower=False, select="i", select_range=(0, 0))
    else:
        D = sp.diags(scale)
        Ks = (D @ Ks @ D).tocsc()
        if Ks.shape[0] <= DENSE_MAX:
            w, v = sla.eigh(Ks.toarray(), subset_by_index=[0, 0])
        else:
            w, v = spla.eigsh(Ks, k=1, sigma=-1e-3, which="LM", v0=arpack_start(Ks.shape[0]))
    phi = scale * v[:, 0]
    phi /= phi[np.argmax(np.abs(phi))]
    return float(w[0]), phi, scale


def _pseudo_mass(system: object, opts: S.Options) -> np.ndarray:
    """(ndof,) the residual scale over Newton's step cap: ``fscale / (max_trans_step L)``
    on translations, ``fscale L / max_rot_step`` on rotations, 0 on multipliers."""
    L, f = float(system.length_scale()), float(system.force_scale())
    rot = np.asarray(system.is_rotation, dtype=bool)
    mass = np.where(rot, f * L / opts.max_rot_step, f / (opts.max_trans_step * L))
    mult = getattr(system, "is_multiplier", None)
    if mult is not None:
        mass[np.asarray(mult, dtype=bool)] = 0.0
    return mass


def positive_definite(system: object, K: sp.spmatrix) -> bool:
    """Is the symmetric part of the (stability) tangent ``K`` positive definite?  Cholesky of
    its Jacobi-scaled form: LAPACK band ``dpbtrf`` on a narrow band
    (``inertia.jacobi_inertia``), dense otherwise."""
    if K.shape[0] == 0:
        return True
    bw = getattr(system, "bandwidth", None)
    if bw is not None and bw <= BAND_MAX:
        return jacobi_inertia(csr_to_band(sp.csr_matrix(K), bw), bw) is not None
    d = np.abs(K.diagonal())
    scale = 1.0 / np.sqrt(np.where(d > 0.0, d, 1.0))
    A = K.toarray()
    A = 0.5 * (A + A.T) * np.outer(scale, scale)
    try:
        sla.cholesky(A, check_finite=False)
    except sla.LinAlgError:
        return False
    return True


def _shift(system: object, Ks: sp.spmatrix, mass: np.ndarray, alpha: float) -> float:
    """``alpha`` if ``Ks + alpha M`` is positive definite, else twice the smallest such shift
    (to 20 %; ``Ks`` the stability tangent)."""

    def convex(a: float) -> bool:
        return positive_definite(system, Ks + sp.diags(a * mass))

    if convex(alpha):
        return alpha
    lo, hi = alpha, max(4.0 * alpha, 1e-8)
    while not convex(hi):
        lo, hi = hi, 4.0 * hi
        if hi > 1e12:
            raise S.SolveError("energy descent: no convexifying shift")
    while hi > 1.2 * lo:
        mid = float(np.sqrt(lo * hi))
        lo, hi = (lo, mid) if convex(mid) else (mid, hi)
    return 2.0 * hi


def relax(system: object, u0: np.ndarray, lam: float, opts: S.Options) -> S.State:
    """The equilibrium at ``lam`` the gradient flow from ``u0`` descends to (module doc),
    converged by ``static.newton``.  Raises ``SolveError`` if it does not settle.

    A step is kept when the energy it releases, by the trapezoidal rule on the residual
    along it (displacement DOFs: the constraint forces do no work on a step that keeps the
    linearised constraints), is at least ``ARMIJO`` of the tangent's first-order prediction;
    the shift is then quartered, else quadrupled and the step retried (a Levenberg-Marquardt
    trust region on the potential)."""
    sc = S.Scaler.of(system)
    mass = _pseudo_mass(system, opts)
    disp = mass > 0.0
    polish = POLISH * sc.ftol(lam, opts)
    u, alpha, steps = u0.copy(), ALPHA0, 0
    r, K = system.residual_and_tangent(u, lam)
    for steps in range(RELAX_ITER):
        rn = sc.rnorm(r)
        if not np.isfinite(rn):
            break
        with stability_view(system):
            Ks = system.residual_and_tangent(u, lam)[1]
        if rn <= polish and positive_definite(system, Ks):
            st = _polish(system, u, lam, opts)  # a stable basin: Newton's convergence test
            if st is not None:
                st.iterations += steps
                return st
            polish = 0.1 * rn  # Newton left the basin (a saddle near by): descend further
        a = _shift(system, Ks, mass, alpha)
        try:
            du = spla.splu((K + sp.diags(a * mass)).tocsc()).solve(-r)
        except RuntimeError:
            break
        du = sc.damp(du, opts)
        r1, K1 = system.residual_and_tangent(u + du, lam)
        first = float(r[disp] @ du[disp])
        released = 0.5 * float((r + r1)[disp] @ du[disp])
        if np.isfinite(released) and released <= ARMIJO * first:
            u, r, K, alpha = u + du, r1, K1, a / 4.0
        else:
            alpha = 4.0 * a
    raise S.SolveError(f"energy descent did not settle at factor {lam:.6g}", iterations=steps)


def _polish(system: object, u: np.ndarray, lam: float, opts: S.Options) -> S.State | None:
    """Newton from ``u`` at ``lam`` if it converges to a stable state, else None."""
    try:
        st = S.newton(system, u, lam, opts)
    except S.SolveError:
        return None
    with stability_view(system):
        Ks = system.residual_and_tangent(st.u, lam)[1]
    return st if positive_definite(system, Ks) else None


def settle(
    system: object, u0: np.ndarray, lam: float, opts: S.Options, amplitude: float, depth: int = 2
) -> S.State:
    """``relax``; an unstable landing is displaced along its own lowest mode
    (``lowest_mode``) by ``amplitude`` x the length scale (rad on a rotation), both signs,
    and relaxed again, ``depth`` times."""
    st = relax(system, u0, lam, opts)
    eig, phi, _ = lowest_mode(system, st.u, lam)
    if eig > 0.0:
        return st
    if depth == 0:
        raise S.SolveError("energy descent ended on an unstable equilibrium")
    i = int(np.argmax(np.abs(phi)))
    a = amplitude * (1.0 if system.is_rotation[i] else float(system.length_scale()))
    for sign in (1.0, -1.0):
        try:
            return settle(system, st.u + sign * a * phi, lam, opts, amplitude, depth - 1)
        except S.SolveError:
            continue
    raise S.SolveError("energy descent ended on an unstable equilibrium")


__all__ = ["lowest_mode", "positive_definite", "relax", "settle"]
