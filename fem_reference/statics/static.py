"""Static solvers on a ``DiscreteSystem``: Newton, load control with step cutting, displacement
control, arc-length continuation (Crisfield's cylindrical constraint), limit-point refinement
and the stability test.

All solvers work on converged ``State`` objects and raise ``SolveError`` (with a reason) when
they cannot reach the requested point; they never return an unconverged state.

The Newton core (``Options``, ``State``, ``SolveError``, ``newton``, convergence test) lives
in ``newton.py``, arc-length in ``arclength.py``, the banded linear algebra in ``banded.py``;
all their public names are re-exported here.  Convergence: see ``newton``.
References: Crisfield, Non-linear FE analysis of solids and structures, Vol. 1 (1991), Ch. 9;
Feng, Peric & Owen (1996) for the predictor sign; Ritto-Correa & Camotim (2008) for root
choice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import brentq, minimize_scalar

from fem_reference.banded import (
    BAND_MAX,
    _dpbtrf,
    arpack_start,
    band_stability,
    csr_to_band,
    hold_dof,
    inf_norm,
    inverse_iteration,
    symmetric_upper_band,
)
from fem_reference.rigid import stability_view
from fem_reference.statics.arclength import ArcLength
from fem_reference.statics.newton import (
    Options,
    Scaler,
    SolveError,
    State,
    bordered_solve,
    newton,
    ops,
    tangent_lu,
)
from fem_reference.system import DiscreteSystem

__all__ = [
    "ArcLength",
    "Options",
    "SolveError",
    "State",
    "displacement_control",
    "load_control",
    "newton",
    "reach_factor",
    "refine_extremum",
    "stability",
    "tangent_lu",
    "Scaler",
    "unwrap",
]


def predictor(
    u: np.ndarray,
    lam: float,
    t: np.ndarray,
    h: float,
    prev: tuple[float, np.ndarray] | None,
    prev2: tuple[float, np.ndarray] | None,
) -> np.ndarray:
    """Predicted increment ``u(lam + h) - u`` of a load-controlled branch, (ndof,).

    ``t = du/dlam`` at ``(lam, u)`` (from the factorised tangent); ``prev`` and ``prev2``: the
    previous two converged points ``(lam_i, u_i)`` of the branch (newest first), used only
    when they lie behind ``lam`` in the marching direction.  With none: the tangent ``h t``.
    With one: the quadratic through it,
    ``u + h t + (u_p - u + t h_p) (h / h_p)^2`` with ``h_p = lam - lam_p`` (error O(h^3)
    instead of O(h^2): on slender meshes with a large EA L^2/EI the O(h^2) stretch of the
    tangent predictor makes Newton diverge).  With two: the cubic Hermite extrapolation
    ``u + t s + a s^2 + b s^3`` through both (error O(h^4); it saves a Newton iteration on
    most steps of a smooth path).
    """
    du = h * t
    if prev is None or (lam - prev[0]) * h <= 0.0:
        return du
    s1 = prev[0] - lam
    d1 = prev[1] - u - t * s1
    if prev2 is None or (prev[0] - prev2[0]) * h <= 0.0:
        return du + d1 * ((h / s1) ** 2)
    # a s_i^2 + b s_i^3 = d_i (i = 1, 2): Cramer's rule on the 2 x 2 in (a, b)
    s2 = prev2[0] - lam
    d2 = prev2[1] - u - t * s2
    det = s1 * s1 * s2 * s2 * (s2 - s1)
    a = (d1 * s2**3 - d2 * s1**3) / det
    b = (d2 * s1**2 - d1 * s2**2) / det
    return du + a * h**2 + b * h**3


def load_control(
    system: DiscreteSystem, st: State, target: float, h0: float, opts: Options
) -> State:
    """March the load factor from ``st.lam`` to exactly ``target`` with adaptive steps.

    Steps start at ``st.h_next`` (the step size reached by the previous call on this branch)
    or ``h0``, double after easy steps (at most 6 iterations) and are cut by 4 after a failure
    (at most ``opts.max_cuts`` consecutive cuts).  Predictor: ``predictor`` (the tangent
    ``t = K^-1 f_ext`` bent through the last one or two converged points of the branch).
    """
    u, lam, lu, prev, prev2 = st.u, st.lam, st.lu, st.prev, st.prev2
    total = abs(target - lam)
    if total == 0.0:
        return replace(st, iterations=0, cuts=0)
    sc = Scaler.of(system)
    sgn = 1.0 if target > lam else -1.0
    h = min(st.h_next if st.h_next else h0, total)
    iters, cuts, streak, res, ev = 0, 0, 0, st.residual, st.ev
    while abs(target - lam) > 1e-14 * max(abs(target), 1.0):
        dl = sgn * min(h, abs(target - lam))
        lt = target if abs(target - (lam + dl)) < 1e-12 * max(1.0, abs(target)) else lam + dl
        try:
            if lu is None:
                lu = tangent_lu(system, u, lam)
            hh = lt - lam
            t = lu.solve(system.external(u))
            du = predictor(u, lam, t, hh, prev, prev2)
            new = newton(system, u + sc.damp(du, opts), lt, opts)
        except SolveError as err:
            iters += err.iterations
            cuts += 1
            streak += 1
            h /= 4.0
            lu = None
            # (a step that keeps failing close to a limit point would creep towards it forever)
            if streak > opts.max_cuts or h < 1e-5 * total:
                last = State(u, lam, iters, cuts, prev=prev, prev2=prev2)
                raise SolveError(f"load control stalled at factor {lam:.6g}: {err}", last) from None
            continue
        iters += new.iterations
        streak = 0
        prev2, prev = prev, (lam, u)
        u, lam, lu, res, ev = new.u, lt, new.lu, new.residual, new.ev
        if new.iterations <= 6:
            h = min(h * opts.grow, total)
    return State(u, lam, iters, cuts, res, lu, prev=prev, prev2=prev2, h_next=h, ev=ev)


def displacement_control(
    system: DiscreteSystem,
    st: State,
    func: tuple[int, float, float],
    target: float,
    h0: float,
    opts: Options,
) -> State:
    """March an output ``off + coef * u[i]`` (func = (i, coef, off)) to ``target``; the load
    factor is the unknown.  Adaptive steps as in ``load_control``."""
    i, c, off = func
    if i < 0:
        raise SolveError("displacement control on a coordinate fixed by a support")
    v = off + c * st.u[i]
    total = abs(target - v)
    if total == 0.0:
        return replace(st, iterations=0, cuts=0)
    sgn = 1.0 if target > v else -1.0
    u, lam, h, iters, cuts, streak = st.u, st.lam, min(h0, total), 0, 0, 0
    res, ev = st.residual, st.ev
    while abs(target - v) > 1e-13 * (abs(target) + system.length_scale()):
        dv = sgn * min(h, abs(target - v))
        vt = target if abs(target - (v + dv)) < 1e-12 * (abs(target) + 1.0) else v + dv
        try:
            try:
                lu = tangent_lu(system, u, lam)
            except SolveError:  # held only by the driver: predictor from the bordered system
                du, dl = bordered_solve(system, ops(system).evaluate(u, lam), i, c, 0 * u, vt - v)
                up, lp = u + du, lam + dl
            else:
                t = lu.solve(system.external(u))
                if abs(c * t[i]) > 1e-300:  # tangent predictor scaled to the increment
                    dl = (vt - v) / (c * t[i])
                    up, lp = u + dl * t, lam + dl
                else:
                    up, lp = u.copy(), lam
                    up[i] += (vt - v) / c
            new = newton(system, up, lp, opts, constraint=(i, c, vt - off))
        except SolveError as err:
            iters += err.iterations
            cuts += 1
            streak += 1
            h /= 4.0
            if streak > opts.max_cuts or h < 1e-5 * total:
                raise SolveError(f"displacement control stalled at {v:.6g}: {err}") from None
            continue
        iters += new.iterations
        streak = 0
        u, lam, v, res, ev = new.u, new.lam, vt, new.residual, new.ev
        if new.iterations <= 6:
            h = min(h * opts.grow, total)
    return State(u, lam, iters, cuts, res, ev=ev)


def unwrap(system: DiscreteSystem, st: State, ref: np.ndarray, opts: Options) -> State:
    """``st`` with every rotation DOF moved by the whole turns that bring it within pi of
    ``ref`` (the state before a jump), if the moved state is still converged.

    An arc-length past a bifurcation or limit point may go round a circle of equilibria
    (a pinned beam at factor ~0) several times before it crosses the target factor: its
    landing is the right configuration with 2 pi k added to the rotations (24 turns,
    -pi/2 - 24 pi).  The load path from ``ref`` does not turn through them.  Element rotations
    are wrapped, so only a torsion spring (which counts whole turns) can tell the two apart:
    then the residual changes and ``st`` is kept.
    """
    rot = np.asarray(system.is_rotation, dtype=bool)
    k = np.where(rot, np.round((st.u - ref) / (2.0 * math.pi)), 0.0)
    if not k.any():
        return st
    u = st.u - 2.0 * math.pi * k
    sc = Scaler.of(system)
    rn = sc.rnorm(ops(system).evaluate(u, st.lam).r)
    if not rn <= max(sc.ftol(st.lam, opts), 2.0 * st.residual):
        return st
    return replace(st, u=u, residual=rn, lu=None, prev=None, prev2=None)


def reach_factor(
    system: DiscreteSystem,
    st: State,
    target: float,
    h0: float,
    opts: Options,
    ds: float | None = None,
) -> State:
    """Load control to ``target``; when it stalls (limit point), continue by arc-length until
    the path crosses ``target`` again and land on it exactly (Newton at lam = target).

    The returned state carries ``info['arc_steps']`` and ``info['snap']`` (1.0 when the state
    lies beyond a limit point of the load-controlled path)."""
    try:
        return load_control(system, st, target, h0, opts)
    except SolveError as err:
        first = err
        base = err.state or st
    sgn = 1.0 if target > base.lam else -1.0
    sc = Scaler.of(system)
    t = tangent_lu(system, base.u, base.lam).solve(system.external(base.u))
    ds0 = ds or min(sc.unorm(t) * max(abs(h0), 1e-12) * 0.5, 0.05)
    arc = ArcLength(system, base, ds0, opts, direction=sgn, ds_max=max(8 * ds0, 0.1))
    prev, iters, cuts = base, 0, 0
    for n in range(opts.arc_max_steps):
        cur = arc.step()
        iters += cur.iterations
        cuts += cur.cuts
        if n >= 20 and abs(cur.lam - base.lam) <= 1e-12 * (1.0 + abs(target)):
            raise SolveError(
                f"{first}; the path does not carry load (a mechanism: equilibria "
                f"at constant factor {base.lam:.6g})"
            )
        if (prev.lam - target) * (cur.lam - target) <= 0.0 and sgn * (cur.lam - prev.lam) > 0:
            w = (target - prev.lam) / (cur.lam - prev.lam)
            for guess in (prev.u + w * (cur.u - prev.u), cur.u, prev.u):
                try:
                    land = newton(system, guess, target, opts)
                except SolveError:
                    continue
                land = unwrap(system, land, base.u, opts)
                land.iterations += iters
                land.cuts = cuts
                land.info = {"arc_steps": float(n + 1), "snap": 1.0}
                return land
            raise SolveError(f"could not land on factor {target:.6g} after arc-length")
        prev = cur
    raise SolveError(f"{first}; arc-length did not reach factor {target:.6g}")


def _inverse_iteration(lu: object, n: int, tol: float = 1e-10, max_it: int = 80) -> float:
    """Eigenvalue of smallest magnitude of a symmetric matrix from its factorisation
    (inverse iteration with Rayleigh quotients; nan if it does not settle)."""
    return inverse_iteration(lu.solve, n, None, tol, max_it)[0]


def stability(
    system: DiscreteSystem,
    u: np.ndarray,
    lam: float,
    dense_max: int = 60,
    exclude: int | None = None,
    ab: np.ndarray | None = None,
) -> dict:
    """``_stability`` on the system's stability tangent (for exact rigid links the augmented
    Lagrangian Hessian, ``rigid.stability_view``; otherwise the tangent itself); ``ab``: that
    tangent at ``(u, lam)`` in ``dgbtrf`` band storage when the caller has assembled it."""
    with stability_view(system):
        return _stability(system, u, lam, dense_max, exclude, ab)


def _stability(
    system: DiscreteSystem,
    u: np.ndarray,
    lam: float,
    dense_max: int = 60,
    exclude: int | None = None,
    ab: np.ndarray | None = None,
) -> dict:
    """Stability of the state from the symmetric part of the tangent on the free DOFs.

    The tangent is scaled by ``D = diag(Lref for translations, 1 for rotations)`` so every
    eigenvalue has units force*length.  ``stable`` = positive definite.  Up to ``dense_max``
    DOFs: a positive definite band is decided by its Cholesky factor as below, any other
    tangent by dense ``eigvalsh``.  Narrow bands (``banded.band_stability``): banded Cholesky
    ``dpbtrf`` decides, inverse iteration on the Cholesky factor (warm-started from the
    previous state's mode) gives ``min_eig``, bisection counts the negative eigenvalues of an
    indefinite matrix.  Otherwise the inertia of an LDL^T-type SuperLU factorisation
    (symmetric mode, diagonal pivots) and shift-invert ``eigsh``.  ``exclude``: a prescribed
    (driver) coordinate, held fixed.

    Returns ``{'stable': bool, 'min_eig': float, 'n_neg': int}``.
    """
    n = system.ndof - (exclude is not None)
    if n <= 0:
        return {"stable": True, "min_eig": math.nan, "n_neg": 0}
    scale = np.where(system.is_rotation, 1.0, system.length_scale())
    bw = getattr(system, "bandwidth", None)
    fast = hasattr(system, "tangent_band") and hasattr(system, "evaluate")
    if bw is not None and bw <= BAND_MAX:
        if ab is None and fast:
            ab = system.tangent_band(system.evaluate(u, lam))
        elif ab is None:
            ab = csr_to_band(system.residual_and_tangent(u, lam)[1].tocsr(), bw)
        up = symmetric_upper_band(ab, bw, scale)
        if exclude is not None:  # decoupled, above every eigenvalue: inertia of the rest
            hold_dof(up, bw, exclude, 2.0 * inf_norm(up, bw) + 1.0)
        # up to dense_max DOFs the band Cholesky decides only a positive definite tangent (a
        # dense eigvalsh cost half of a 16-element solve); any other keeps the dense test
        chol = _dpbtrf(up, lower=0)
        if n > dense_max or chol[1] == 0:
            warm = getattr(system, "_flex_eig_warm", None)
            if warm is None:
                warm = {}
                try:
                    system._flex_eig_warm = warm
                except AttributeError:  # pragma: no cover
                    pass
            res = band_stability(up, bw, warm, chol)
            if res is not None:
                return res
    _, K = system.residual_and_tangent(u, lam)
    D = sp.diags(scale)
    Ks = (D @ (0.5 * (K + K.T)) @ D).tocsr()
    if exclude is not None:
        keep = np.ones(Ks.shape[0], dtype=bool)
        keep[exclude] = False
        Ks = Ks[keep][:, keep].tocsr()
    if n <= dense_max:
        w = sla.eigvalsh(Ks.toarray())
        tol = 100.0 * np.finfo(float).eps * max(abs(w[-1]), 1e-300)  # eigvalsh accuracy
        n_neg = int(np.sum(w < -tol))
        return {"stable": n_neg == 0, "min_eig": float(w[0]), "n_neg": n_neg}
    try:
        ldl = spla.splu(
            Ks.tocsc(),
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:  # exactly singular: neutral stability
        return {"stable": False, "min_eig": 0.0, "n_neg": 0}
    dg = ldl.U.diagonal()
    n_neg = int(np.sum(dg < 0))
    if n_neg == 0:
        return {"stable": True, "min_eig": _inverse_iteration(ldl, n), "n_neg": 0}
    try:
        w = spla.eigsh(
            Ks.tocsc(),
            k=min(n_neg + 1, n - 1),
            sigma=-1e-9 * abs(dg).max(),
            which="LM",
            v0=arpack_start(n),
            return_eigenvectors=False,
        )
        mn = float(np.min(w))
    except Exception:  # noqa: BLE001 - ARPACK failures must not kill a solve
        mn = math.nan
    return {"stable": False, "min_eig": mn, "n_neg": n_neg}


# stencil of the limit point's polish, of the bracket's width: wide enough that lam's
# differences (a 1e-8 of lam) stand far above its round-off (1e-14), narrow enough that the
# fifth-order truncation (1e-11 of the width) is far below the 1e-8 the location is asked to
POLISH_STEP = 3e-3


def _polish_extremum(lam_of: Callable[[float], float], v0: float, step: float) -> float:
    """One Newton step on ``d lam / dv = 0`` from ``v0``, both derivatives by five-point
    differences of ``lam_of`` (-/+ lam at the displacement ``v``) with spacing ``step``.

    Why not the bordered tangent's slope: the slope depends on the tangent, which depends on
    the state's axial forces, known only to EA times the round-off of the element lengths
    (on DaDeppo's arch, EA/EI = 1e7, the slope scattered by 1e-7 from one v to the next and
    its root by 3e-8 of the crown's rotation between units).  The load at a controlled
    displacement is an equilibrium quantity, well conditioned (1e-14), so its differences
    locate the root to 1e-10.  The step is taken only within the stencil; otherwise ``v0``
    stays."""
    g = [lam_of(v0 + k * step) for k in (-2, -1, 0, 1, 2)]
    if any(abs(x) >= 1e300 for x in g):  # a displacement-control solve failed
        return v0
    d1 = (g[0] - 8.0 * g[1] + 8.0 * g[3] - g[4]) / (12.0 * step)
    d2 = (-g[0] + 16.0 * g[1] - 30.0 * g[2] + 16.0 * g[3] - g[4]) / (12.0 * step**2)
    if not d2 > 0.0 or abs(d1) >= d2 * step:  # (lam_of is minimised)
        return v0
    return v0 - d1 / d2


def refine_extremum(system: DiscreteSystem, a: State, b: State, c: State, opts: Options) -> State:
    """Locate a limit point (local extremum of lam) bracketed by path states a, b, c (b the
    extreme one).  The controlling DOF is the one moving most (metric W) across the bracket;
    along it the root of ``d lam / d v`` (the bordered tangent ``K du - f dlam = 0``,
    ``du_v = 1``: regular at the fold, where ``K`` is not) is found by Brent's method, each
    evaluation a displacement-control Newton solve from the path states.  A root, not a
    maximum: a flat maximum of lam(v) locates v only to the square root of lam's round-off
    (the limit state's outputs then differed by 1e-8 between encodings of one arch); where
    the slope does not change sign across the bracket lam(v) is maximised instead.  The
    root is then polished on lam itself (``_polish_extremum``)."""
    sc = Scaler.of(system)
    span = np.abs(c.u - a.u) * np.sqrt(sc.w)
    i = int(np.argmax(span))
    va, vc = a.u[i], c.u[i]
    lo, hi = min(va, vc), max(va, vc)
    sgn = 1.0 if b.lam >= max(a.lam, c.lam) else -1.0
    cache: dict[float, State] = {}
    pts = (a, b, c)

    vs = np.array([s.u[i] for s in pts])

    def lam_of(v: float) -> float:
        # quadratic (Lagrange) interpolation of the path states in v as the initial guess
        wts = [
            np.prod([(v - vs[m]) / (vs[k] - vs[m]) for m in range(3) if m != k]) for k in range(3)
        ]
        u0 = sum(w * s.u for w, s in zip(wts, pts))
        l0 = sum(w * s.lam for w, s in zip(wts, pts))
        try:
            st = newton(system, u0, l0, opts, constraint=(i, 1.0, v))
        except SolveError:
            return -sgn * 1e300
        cache[v] = st
        return -sgn * st.lam

    def slope(v: float) -> float:
        if lam_of(v) == -sgn * 1e300:
            raise SolveError("limit point refinement: displacement control failed")
        st = cache[v]
        return bordered_solve(system, st.ev, i, 1.0, np.zeros(st.u.size), 1.0)[1]

    try:
        v = float(brentq(slope, lo, hi, xtol=1e-14 * (hi - lo + 1e-300)))
    except (ValueError, SolveError):  # no sign change of the slope: maximise lam itself
        res = minimize_scalar(
            lam_of, bounds=(lo, hi), method="bounded", options={"xatol": 1e-10 * (hi - lo + 1e-300)}
        )
        v = float(res.x)
    v = _polish_extremum(lam_of, v, POLISH_STEP * (hi - lo))
    if v not in cache:
        lam_of(v)
    if v not in cache:
        raise SolveError("limit point refinement failed")
    st = cache[v]
    st.info = {"limit_point": sgn, "control_dof": float(i)}
    return st
