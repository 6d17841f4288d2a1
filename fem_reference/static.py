"""Static solvers on a ``DiscreteSystem``: Newton, load control with step cutting, displacement
control, arc-length continuation (Crisfield's cylindrical constraint), limit-point refinement
and the stability test.

All solvers work on converged ``State`` objects and raise ``SolveError`` (with a reason) when
they cannot reach the requested point; they never return an unconverged state.

Convergence (``Options``): a state is converged when the scaled force residual
``||r_s|| <= rtol * fscale * max(|lam|, 1)`` (moments divided by the length scale) *and* the
energy norm of the last correction ``|du . r| <= etol * |du_0 . r_0|``; a correction at
round-off level (``||du||_W < 1e-13``) with ``||r_s||`` within 1e4 of the tolerance also counts
(1000-element meshes with EA L^2/EI ~ 1e5 have a residual floor near 1e-10 of the load).
References: Crisfield, Non-linear FE analysis of solids and structures, Vol. 1 (1991), Ch. 9;
Feng, Peric & Owen (1996) for the predictor sign; Ritto-Correa & Camotim (2008) for root
choice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import minimize_scalar

from fem_reference.system import DiscreteSystem


class SolveError(RuntimeError):
    """The solver could not reach the requested equilibrium (message says why).

    ``state`` is the last converged state reached before the failure (or None)."""

    def __init__(self, message: str, state: State | None = None, iterations: int = 0):
        super().__init__(message)
        self.state = state
        self.iterations = iterations


@dataclass(frozen=True)
class Options:
    """Solver settings (all dimensionless)."""

    rtol: float = 1e-9
    etol: float = 1e-16
    max_iter: int = 25
    max_cuts: int = 8
    grow: float = 2.0
    arc_iter_goal: int = 5
    arc_max_steps: int = 2000
    max_rot_step: float = 0.6  # rad per Newton correction before damping
    max_trans_step: float = 0.3  # x length scale per Newton correction before damping


@dataclass
class State:
    """A converged equilibrium: displacements, load factor and bookkeeping."""

    u: np.ndarray
    lam: float
    iterations: int = 0
    cuts: int = 0
    residual: float = 0.0
    lu: object | None = field(default=None, repr=False)
    info: dict = field(default_factory=dict)


class _BandedLU:
    """LAPACK banded LU (dgbtrf/dgbtrs) of a csr matrix with half-bandwidth ``bw``."""

    def __init__(self, K: sp.csr_matrix, bw: int):
        n = K.shape[0]
        rows = np.repeat(np.arange(n), np.diff(K.indptr))
        ab = np.zeros((3 * bw + 1, n))
        ab[2 * bw + rows - K.indices, K.indices] = K.data
        self.lu, self.piv, info = sla.lapack.dgbtrf(ab, bw, bw, overwrite_ab=True)
        if info > 0:
            raise SolveError("singular tangent (zero pivot in banded LU)")
        self.bw = bw

    def solve(self, b: np.ndarray) -> np.ndarray:
        x, info = sla.lapack.dgbtrs(self.lu, self.bw, self.bw, b, self.piv)
        return x


def _factor(K: sp.csr_matrix, bw: int | None = None) -> object:
    """LU of the tangent: banded LAPACK when the (RCM-ordered) band is narrow, else SuperLU."""
    if bw is not None and K.shape[0] > 30 and bw <= 48:
        return _BandedLU(K, bw)
    try:
        lu = spla.splu(K.tocsc())
    except RuntimeError as e:  # exactly singular
        raise SolveError(f"singular tangent ({e})") from None
    return lu


def _lu(system: DiscreteSystem, K: sp.csr_matrix) -> object:
    return _factor(K, getattr(system, "bandwidth", None))


class _Scaler:
    def __init__(self, system: DiscreteSystem):
        self.sys = system
        self.rs = np.where(system.is_rotation, 1.0 / system.length_scale(), 1.0)
        self.w = system.weights
        rf = getattr(system, "residual_floor", None)
        self.floor = float(rf()) if callable(rf) else 0.0

    def rnorm(self, r: np.ndarray) -> float:
        return float(np.linalg.norm(r * self.rs))

    def unorm(self, du: np.ndarray) -> float:
        return float(math.sqrt(np.dot(du * du, self.w)))

    def ftol(self, lam: float, opts: Options) -> float:
        floor = self.floor
        return max(opts.rtol * self.sys.force_scale() * max(abs(lam), 1.0), floor)

    def damp(self, du: np.ndarray, opts: Options) -> np.ndarray:
        rot = self.sys.is_rotation
        mr = float(np.max(np.abs(du[rot]), initial=0.0))
        mt = float(np.max(np.abs(du[~rot]), initial=0.0)) / self.sys.length_scale()
        a = min(1.0, opts.max_rot_step / max(mr, 1e-300), opts.max_trans_step / max(mt, 1e-300))
        return du * a


def _converged(rn: float, tol: float, e: float, e0: float, dun: float, etol: float) -> bool:
    if rn <= tol and e <= e0 * etol + 1e-300:
        return True
    if rn <= tol and e0 == 0.0:
        return True
    return dun < 1e-13 and rn <= 1e4 * tol


def newton(
    system: DiscreteSystem,
    u0: np.ndarray,
    lam: float,
    opts: Options,
    constraint: tuple[int, float, float] | None = None,
) -> State:
    """Newton-Raphson at fixed ``lam`` (or with a linear constraint, see below).

    ``constraint = (index, coef, value)`` switches to displacement control: ``lam`` becomes an
    unknown and ``coef * u[index] = value`` is enforced by bordering.
    Raises ``SolveError`` on divergence, a singular tangent or ``max_iter``.
    """
    sc = _Scaler(system)
    u = u0.copy()
    e0, e, dun, rref, lu = 0.0, 0.0, np.inf, 0.0, None
    rot = system.is_rotation
    for it in range(opts.max_iter + 1):
        r, K = system.residual_and_tangent(u, lam)
        rn = sc.rnorm(r)
        rref = max(rref, rn) if it <= 1 else rref
        if it >= 3 and rn > 1e3 * rref:  # early exit: the step will be cut anyway
            raise SolveError(f"Newton diverging (|r| grew {rn / rref:.1e}x)", iterations=it)
        g = 0.0
        if constraint is not None:
            i, c, v = constraint
            g = c * u[i] - v
        tol = sc.ftol(lam, opts)
        if not np.isfinite(rn):
            raise SolveError("non-finite residual", iterations=it)
        gok = constraint is None or abs(g) <= 1e-12 * (abs(v) + system.length_scale())
        if it > 0 and gok and _converged(rn, tol, e, e0, dun, opts.etol):
            return State(u, lam, it, 0, rn, lu)
        if it == 0 and rn <= tol * 1e-3 and gok:
            return State(u, lam, 0, 0, rn, None)
        if it == opts.max_iter:
            break
        lu = _lu(system, K)
        du = lu.solve(-r)
        if constraint is not None:
            dt = lu.solve(system.external(u))
            if abs(c * dt[i]) < 1e-300:
                raise SolveError("displacement control: controlled DOF does not respond to load")
            dl = -(g + c * du[i]) / (c * dt[i])
            du = du + dl * dt
            lam = lam + dl
        if not np.all(np.isfinite(du)):
            raise SolveError("non-finite Newton correction", iterations=it)
        if it >= 1 and np.max(np.abs(du[rot]), initial=0.0) > math.pi:
            raise SolveError("Newton diverging (rotation correction > pi)", iterations=it)
        e = abs(float(np.dot(du, r)))
        if it == 0:
            e0 = e
        if constraint is None:
            du = sc.damp(du, opts)
        dun = sc.unorm(du)
        u = u + du
    raise SolveError(
        f"Newton did not converge in {opts.max_iter} iterations (|r|={rn:.3e})",
        iterations=opts.max_iter,
    )


def load_control(
    system: DiscreteSystem, st: State, target: float, h0: float, opts: Options
) -> State:
    """March the load factor from ``st.lam`` to exactly ``target`` with adaptive steps.

    Steps start at ``h0``, double after easy steps and are cut by 4 after a failure (at most
    ``opts.max_cuts`` consecutive cuts).  Predictor: tangent (``K du = f_ext dlam``).
    """
    u, lam, lu = st.u, st.lam, st.lu
    total = abs(target - lam)
    if total == 0.0:
        return replace(st, iterations=0, cuts=0)
    sgn = 1.0 if target > lam else -1.0
    h, iters, cuts, streak = min(h0, total), 0, 0, 0
    while abs(target - lam) > 1e-14 * max(abs(target), 1.0):
        dl = sgn * min(h, abs(target - lam))
        lt = target if abs(target - (lam + dl)) < 1e-12 * max(1.0, abs(target)) else lam + dl
        try:
            if lu is None:
                lu = _lu(system, system.residual_and_tangent(u, lam)[1])
            up = u + (lt - lam) * lu.solve(system.external(u))
            up = _Scaler(system).damp(up - u, opts) + u
            new = newton(system, up, lt, opts)
        except SolveError as err:
            iters += err.iterations
            cuts += 1
            streak += 1
            h /= 4.0
            lu = None
            # (a step that keeps failing close to a limit point would creep towards it forever)
            if streak > opts.max_cuts or h < 1e-5 * total:
                last = State(u, lam, iters, cuts)
                raise SolveError(f"load control stalled at factor {lam:.6g}: {err}", last) from None
            continue
        iters += new.iterations
        streak = 0
        u, lam, lu = new.u, lt, new.lu
        if new.iterations <= 6:
            h = min(h * opts.grow, total)
    return State(u, lam, iters, cuts, new.residual, lu)


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
    res = st.residual
    while abs(target - v) > 1e-13 * (abs(target) + system.length_scale()):
        dv = sgn * min(h, abs(target - v))
        vt = target if abs(target - (v + dv)) < 1e-12 * (abs(target) + 1.0) else v + dv
        try:
            lu = _lu(system, system.residual_and_tangent(u, lam)[1])
            t = lu.solve(system.external(u))
            if abs(c * t[i]) > 1e-300:  # tangent predictor scaled to the requested increment
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
        u, lam, v, res = new.u, new.lam, vt, new.residual
        if new.iterations <= 6:
            h = min(h * opts.grow, total)
    return State(u, lam, iters, cuts, res)


class ArcLength:
    """Crisfield's cylindrical arc-length continuation in the metric ``system.weights``.

    ``step()`` returns the next converged ``State`` on the path (cutting ``ds`` on failure).
    The predictor sign follows the previous increment (Feng et al.), so limit points and
    snap-backs are passed; of the two corrector roots the one closest in direction to the
    current increment is taken, a complex pair falls back to the linearised (normal-plane)
    correction.
    """

    def __init__(
        self,
        system: DiscreteSystem,
        st: State,
        ds: float,
        opts: Options,
        direction: float = 1.0,
        ds_max: float | None = None,
    ):
        self.sys, self.opts, self.sc = system, opts, _Scaler(system)
        self.u, self.lam, self.ds = st.u.copy(), st.lam, ds
        self.ds_max = ds_max if ds_max is not None else 1e3 * ds
        self.ds_min = ds * 1e-7
        self.du_prev: np.ndarray | None = None
        self.direction = direction

    def _dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(np.dot(a * self.sc.w, b))

    def _try(self, ds: float) -> State:
        sys, opts = self.sys, self.opts
        r, K = sys.residual_and_tangent(self.u, self.lam)
        lu = _lu(sys, K)
        t = lu.solve(sys.external(self.u))
        tn = math.sqrt(max(self._dot(t, t), 1e-300))
        sgn = (
            self.direction
            if self.du_prev is None
            else math.copysign(1.0, self._dot(t, self.du_prev) or self.direction)
        )
        dl = sgn * ds / tn
        Du, Dl = dl * t - lu.solve(r), dl
        e0 = 1e-300
        for it in range(1, opts.max_iter + 1):
            u, lam = self.u + Du, self.lam + Dl
            r, K = sys.residual_and_tangent(u, lam)
            rn = self.sc.rnorm(r)
            if not np.isfinite(rn):
                raise SolveError("non-finite residual")
            lu = _lu(sys, K)
            dr = -lu.solve(r)
            if (
                it > 1
                and rn <= self.sc.ftol(lam, opts)
                and (abs(np.dot(dr, r)) <= opts.etol * e0 or self.sc.unorm(dr) < 1e-12)
            ):
                return State(u, lam, it, 0, rn, lu)
            dt = lu.solve(sys.external(u))
            a = self._dot(dt, dt)
            b = 2.0 * self._dot(Du + dr, dt)
            c = self._dot(Du + dr, Du + dr) - ds * ds
            disc = b * b - 4.0 * a * c
            if disc >= 0.0 and a > 0.0:
                q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
                roots = [q / a, c / q] if q != 0.0 else [0.0]
                best = max(roots, key=lambda x: self._dot(Du + dr + x * dt, Du))
            else:  # normal-plane (Ramm) correction
                den = self._dot(Du, dt)
                if den == 0.0:
                    raise SolveError("arc-length: degenerate corrector")
                best = -self._dot(Du, dr) / den
            step = dr + best * dt
            if it == 1:
                e0 = max(abs(float(np.dot(step, r))), 1e-300)
            Du, Dl = Du + step, Dl + best
            if self.sc.unorm(Du) > 10.0 * ds + 1e-300:
                raise SolveError("arc-length corrector diverged")
        raise SolveError("arc-length corrector did not converge")

    def step(self) -> State:
        """Next converged point (raises ``SolveError`` when ``ds`` falls below ds_min)."""
        cuts = 0
        while True:
            try:
                st = self._try(self.ds)
                break
            except SolveError as err:
                cuts += 1
                self.ds *= 0.25
                if self.ds < self.ds_min:
                    raise SolveError(
                        f"arc-length stalled at factor {self.lam:.6g}: {err}"
                    ) from None
        self.du_prev = st.u - self.u
        self.u, self.lam = st.u, st.lam
        ratio = math.sqrt(self.opts.arc_iter_goal / max(st.iterations, 1))
        self.ds = min(self.ds * min(max(ratio, 0.5), 2.0), self.ds_max)
        st.cuts = cuts
        return st


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
    sc = _Scaler(system)
    lu = _lu(system, system.residual_and_tangent(base.u, base.lam)[1])
    t = lu.solve(system.external(base.u))
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
    x = np.cos(np.arange(n) * 0.7071) + 0.5  # deterministic start, not orthogonal to modes
    x /= np.linalg.norm(x)
    mu = math.nan
    for _ in range(max_it):
        y = lu.solve(x)
        ny = float(np.linalg.norm(y))
        if not np.isfinite(ny) or ny == 0.0:
            return math.nan
        new = float(np.dot(x, y)) / float(np.dot(y, y))
        x = y / ny
        if abs(new - mu) <= tol * abs(new):
            return new
        mu = new
    return math.nan


def stability(
    system: DiscreteSystem,
    u: np.ndarray,
    lam: float,
    dense_max: int = 60,
    exclude: int | None = None,
) -> dict:
    """Stability of the state from the symmetric part of the tangent on the free DOFs.

    The tangent is scaled by ``D = diag(Lref for translations, 1 for rotations)`` so every
    eigenvalue has units force*length.  ``stable`` = positive definite: a banded Cholesky
    (LAPACK dpbtrf) on the RCM band, else the inertia of an LDL^T-type SuperLU factorisation
    (symmetric mode, diagonal pivots).  ``min_eig`` (the lowest eigenvalue): dense
    ``eigvalsh`` up to ``dense_max`` DOFs; for a positive definite tangent inverse iteration
    (the smallest-magnitude eigenvalue is the lowest); otherwise shift-invert ``eigsh``.

    Returns ``{'stable': bool, 'min_eig': float, 'n_neg': int}``.
    """
    _, K = system.residual_and_tangent(u, lam)
    D = sp.diags(np.where(system.is_rotation, 1.0, system.length_scale()))
    Ks = (D @ (0.5 * (K + K.T)) @ D).tocsr()
    if exclude is not None:  # a prescribed (driver) coordinate: stability with it held
        keep = np.ones(Ks.shape[0], dtype=bool)
        keep[exclude] = False
        Ks = Ks[keep][:, keep].tocsr()
    n = Ks.shape[0]
    if n == 0:
        return {"stable": True, "min_eig": math.nan, "n_neg": 0}
    if n <= dense_max:
        w = sla.eigvalsh(Ks.toarray())
        tol = 1e-11 * max(abs(w[-1]), 1e-300)
        n_neg = int(np.sum(w < -tol))
        return {"stable": n_neg == 0, "min_eig": float(w[0]), "n_neg": n_neg}
    Ks.sort_indices()
    rows = np.repeat(np.arange(n), np.diff(Ks.indptr))
    bw = int(np.max(np.abs(rows - Ks.indices), initial=0))
    if bw <= 48:
        up = rows <= Ks.indices
        ab = np.zeros((bw + 1, n))
        ab[bw + rows[up] - Ks.indices[up], Ks.indices[up]] = Ks.data[up]
        _, info = sla.lapack.dpbtrf(ab, lower=0)
        if info == 0:
            try:
                lu = _BandedLU(Ks, bw)
            except SolveError:
                return {"stable": False, "min_eig": 0.0, "n_neg": 0}
            return {"stable": True, "min_eig": _inverse_iteration(lu, n), "n_neg": 0}
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
            return_eigenvectors=False,
        )
        mn = float(np.min(w))
    except Exception:  # noqa: BLE001 - ARPACK failures must not kill a solve
        mn = math.nan
    return {"stable": False, "min_eig": mn, "n_neg": n_neg}


def refine_extremum(system: DiscreteSystem, a: State, b: State, c: State, opts: Options) -> State:
    """Locate a limit point (local extremum of lam) bracketed by path states a, b, c (b the
    extreme one).  The controlling DOF is the one moving most (metric W) across the bracket;
    lam(v) along it is maximised/minimised with Brent's method, each evaluation a
    displacement-control Newton solve from the nearest path state."""
    sc = _Scaler(system)
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

    res = minimize_scalar(
        lam_of, bounds=(lo, hi), method="bounded", options={"xatol": 1e-10 * (hi - lo + 1e-300)}
    )
    v = float(res.x)
    if v not in cache:
        lam_of(v)
    if v not in cache:
        raise SolveError("limit point refinement failed")
    st = cache[v]
    st.info = {"limit_point": sgn, "control_dof": float(i)}
    return st
