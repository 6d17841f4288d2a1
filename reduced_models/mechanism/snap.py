"""Snap-through under load control: stability loss on a load step, the jump, its report.

Load control follows the branch it starts on.  When a load step of ``Run.load`` ends on an
unstable equilibrium (the KKT inertia changed: a bifurcation) or cannot be completed (the
fundamental path turned back: a limit point), ``snap_step``:

1. *Locates* the critical factor ``lam_c``: bisection on the largest factor that the
   fundamental path reaches with a stable equilibrium (load control from the last stable
   step, ``newton.follow``), to ``LOCATE_RTOL`` of the step.
2. *Mode*: the KKT matrix at the last stable state is nearly singular; inverse iteration on it
   gives the critical mode ``phi`` (position unknowns).  *Kind*: ``|phi . f| / (|phi| |f|) <
   KIND_TOL`` (scaled: translations / Lref, rotations in rad; f the load vector at factor 1)
   is a bifurcation (the load does no work on the mode), otherwise a limit point (the
   criterion of ``fem_reference.bifurcation``, Riks 1979).
3. *Jump*: from the critical state displaced by ``+-PERTURB`` (scaled) along ``phi``, the
   constrained gradient flow of the total potential at the step's factor, integrated by
   pseudo-transient continuation (Kelley & Keyes 1998: Newton on the KKT system with the
   position block shifted by ``alpha`` times a pseudo-mass, ``alpha`` decreasing with the
   residual (switched evolution relaxation) but kept where the shifted block is convex on
   the constraints' tangent, so each step descends the energy), descends to an equilibrium;
   an unstable landing is displaced along its own unstable mode and relaxed again.  Of the
   stable landings the one of lower total potential is kept (a tie keeps +phi).  The flow
   descends the energy, so it lands where a damped structure would settle.  A landing the
   tangent at the critical state predicts (``_continues``: load control stalled for a
   numerical reason, e.g. a residual floor at the tolerance) is no snap and is not reported.

Newton can also converge across a limit point onto a stable far branch in one load step (a
stiff spring truss): both ends stable, no inertia change.  ``jumped`` tells such a step from
a smooth one (its move against the tangents at both ends, ``JUMP``); ``Run.load`` then treats
it as a stability loss and the bisection of step 1 refuses jumped steps, so the snap is
located and reported like any other, never silent.

``extras["critical_points"]`` (DESIGN.md, "Critical points"): the critical point (``kind``
"limit" | "bifurcation", ``factor`` = lam_c, ``switched`` = True when a stable state was
reached beyond it) followed by the ``"snap"`` (``factor`` = lam_c, the load at which it
snaps; ``from`` = the state at lam_c, ``to`` = the state landed at the step's factor, each
``{"factor", "outputs"}``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from reduced_models.mechanism.newton import SolveError, State, _solve, follow

LOCATE_RTOL = 1e-6  # bisection stops at this fraction of the load step
REFINE_BACK = 1e-3  # ``_refine``'s states, this x the load step apart
REFINE_LINEAR = 1e-2  # second difference / first of the eigenvalue: it lies on a line
KIND_TOL = 1e-3  # |phi . f| / (|phi| |f|) below this: the load does no work on the mode
PERTURB = 1e-2  # displacement along the mode, largest scaled component (Lref or rad)
RELAX_ITER = 400  # pseudo-time steps of one relaxation
# an equilibrium whose residual stalls (10 steps without a new best) below STALL x tol is
# converged to round-off (long chained members: the scaled residual floor nears 1e-10)
STALL = 1e2
CONTINUES = 0.25  # a landing this close (relative) to the tangent's prediction is no snap
# a converged load step that moved more than JUMP x what the tangent at either end predicts
# left its branch: on a smooth path the move is at most the larger end tangent's (the tangent
# grows monotonically towards a limit point), a Newton jump to a far branch is many times it
JUMP = 3.0
ALPHA0 = 1.0  # pseudo-time shift at the start, in units of the pseudo-mass (``_relax``)


def snap_step(run: object, st: State, lam0: float, lam1: float) -> tuple[State, list[dict]]:
    """The state at factor ``lam1`` after the fundamental path from the stable state ``st``
    (factor ``lam0``) lost stability or turned back inside (lam0, lam1]; with the critical
    point and snap entries.  Raises SolveError when no stable state is reached."""
    sv = run.solver
    lam_c, st_c = _locate(run, st, lam0, lam1)
    phi = _mode(run, st_c)
    kind = "bifurcation" if _work(run, st_c, phi) < KIND_TOL else "limit"
    if kind == "bifurcation":
        lam_c = _refine(run, st_c, lam_c, lam1 - lam0)
    point = {"kind": kind, "factor": float(lam_c), "switched": False}
    landed, why = [], ""
    for sign in (1.0, -1.0):
        q = st_c.q.copy()
        q[run.s.free] += sign * phi
        try:
            new = _settle(run, State(q, st_c.mu.copy(), lam1))
        except SolveError as err:
            why = f" ({err})"  # e.g. a member law refusing the states it would reach
            continue
        landed.append((run.s.potential(new.q, lam1), -sign, new))
    if not landed:
        run.extras.setdefault("critical_points", []).append(point)
        raise SolveError(
            f"{kind} point at load factor {lam_c:.6g}: no stable equilibrium reached at "
            f"factor {lam1:.6g} by energy descent{why}"
        )
    new = min(landed, key=lambda x: (x[0], x[1]))[2]
    sv.memo = None  # the Hermite predictor must not bridge the jump
    if _continues(run, st_c, new, lam1 - lam_c):
        return new, []
    out = run.s.outputs
    point["switched"] = True
    snap = {
        "kind": "snap",
        "factor": float(lam_c),
        "switched": True,
        "from": {"factor": float(lam_c), "outputs": out(st_c.q)},
        "to": {"factor": float(lam1), "outputs": out(new.q)},
    }
    return new, [point, snap]


def jumped(run: object, st: State, new: State, dlam: float) -> bool:
    """Did the converged load step ``st -> new`` (factor change ``dlam``) leave its branch?
    Its largest scaled move exceeds ``JUMP`` x the move predicted by the tangent at either
    end (module doc)."""
    w, f = _weights(run), run.s.free
    move = float(np.abs((new.q[f] - st.q[f]) * w).max()) if len(f) else 0.0
    if not move > 1e-9:
        return False
    pred = 0.0
    for x in (st, new):
        try:
            t = run.solver.tangent(x, "lam")[: len(f)]
        except (SolveError, np.linalg.LinAlgError):
            return False
        pred = max(pred, float(np.abs(dlam * t * w).max()))
    return bool(np.isfinite(pred)) and move > JUMP * pred


def _continues(run: object, st: State, new: State, dlam: float) -> bool:
    """Is ``new`` the regular continuation of the path through ``st`` (its tangent predicts
    it to within a quarter of the move)?  Load control that stalls for numerical reasons
    (a residual floor near the tolerance) then resumes without reporting a snap."""
    w, f = _weights(run), run.s.free
    try:
        t = run.solver.tangent(st, "lam")[: len(f)]
    except (SolveError, np.linalg.LinAlgError):
        return False
    move = float(np.abs((new.q[f] - st.q[f]) * w).max())
    dev = float(np.abs((new.q[f] - st.q[f] - dlam * t) * w).max())
    return bool(np.isfinite(dev)) and dev <= CONTINUES * move


def _reach(run: object, st: State, lam0: float, lam: float) -> State | None:
    """The stable equilibrium at ``lam`` by load control from ``st``, else None."""

    def set_lam(x: State, t: float) -> State:
        x.lam = t
        return x

    try:
        new = follow(run.solver, st, lam0, lam, set_lam, "lam", max_cuts=6)
    except SolveError:
        return None
    new.lam = lam
    if not run.solver.stable(new, False)[0] or jumped(run, st, new, lam - lam0):
        return None
    return new


def _locate(run: object, st: State, lo: float, hi: float) -> tuple[float, State]:
    """Bisection for the largest factor the fundamental path reaches stably (module doc).

    A start ``st`` settled at round-off above Newton's tolerance (``_relax``'s ``STALL``:
    long chained members on a far branch) is its own answer: Newton cannot follow the path
    from it to the tolerance whatever the stability, so every probe would fail only after
    all its step cuts (on DAS-2D Ex. 3 under load, 20 probes of ~0.15 s per load step)."""
    if st.residual > run.solver.tol:
        return lo, st
    tol = LOCATE_RTOL * abs(hi - lo)
    best = st
    while abs(hi - lo) > tol:
        mid = 0.5 * (lo + hi)
        new = _reach(run, best, lo, mid)
        if new is None:
            hi = mid
        else:
            lo, best = mid, new
    return lo, best


def _refine(run: object, st: State, lam: float, step: float) -> float:
    """A bifurcation's factor from the located state ``st`` (factor ``lam``, the
    bisection's last stable one): where the KKT eigenvalue nearest zero (``_eigenvalue``)
    vanishes on the fundamental path.  The bisection alone stops where Newton first fails,
    which next to the singular point depends on round-off (a flexible-shuttle switch: 1e-7
    of the factor apart in two encodings).  At a bifurcation the eigenvalue crosses zero
    with a slope: from its values at ``lam``, ``lam - d`` and ``lam - 2 d`` (d =
    ``REFINE_BACK`` x ``step``), when they lie on a line (second difference within
    ``REFINE_LINEAR`` of the first), its zero, if within d ahead of ``lam``.  Otherwise
    ``lam`` stands: a curved eigenvalue is a fold's square root (an imperfect bifurcation,
    where load control stops at the limit point itself: the bisection is already there)."""
    d = REFINE_BACK * abs(step)
    e = [_eigenvalue(run, st)]
    for k in (1, 2):
        back = _reach(run, st, lam, lam - k * d)
        if back is None:
            return lam
        e.append(_eigenvalue(run, back))
    e1, e0, e2 = e
    if not (e2 > e0 > e1 > 0.0) or abs(e2 - 2.0 * e0 + e1) > REFINE_LINEAR * (e0 - e1):
        return lam
    root = lam + d * e1 / (e0 - e1)
    return float(root) if root <= lam + d else lam


def _eigenvalue(run: object, st: State, iterations: int = 12) -> float:
    """The KKT matrix's eigenvalue nearest zero at ``st`` (signed; inverse iteration from a
    fixed start, then the Rayleigh quotient): zero exactly where the reduced Hessian is
    singular, whatever the matrix's scaling."""
    K = run.solver.kkt(st)[1]
    x = _nearest_zero(K, iterations)
    return float(x @ (K @ x))


def _nearest_zero(K: object, iterations: int) -> np.ndarray:
    """Unit eigenvector of ``K`` (the KKT matrix, dense or sparse) of smallest |eigenvalue|:
    inverse iteration from a fixed start (the same answer on every call); (n,)."""
    x = np.random.default_rng(0).standard_normal(K.shape[0])
    for _ in range(iterations):
        x = _solve(K, x)
        x /= np.linalg.norm(x)
    return x


def _weights(run: object) -> np.ndarray:
    """Scale of each free unknown: 1 / Lref on translations, 1 on rotations, 0 on the axial
    multipliers of chained segments (no length)."""
    s = run.s
    kind = np.array(s.lay.kind)[s.free]
    return np.where(kind == "r", 1.0, np.where(kind == "p", 0.0, 1.0 / s.lay.Lref))


def _mode(run: object, st: State, iterations: int = 8) -> np.ndarray:
    """The KKT eigenvector of smallest |eigenvalue| (inverse iteration), position part,
    scaled to ``PERTURB`` in its largest scaled component; (nf,)."""
    sv = run.solver
    w = _weights(run)
    x = _nearest_zero(sv.kkt(st)[1], iterations)
    v = x[: sv.nf] * (w > 0)
    big = np.abs(v * w).max()
    if not np.isfinite(big) or big == 0.0:
        raise SolveError("no critical mode found at the stability loss")
    v *= PERTURB / big
    k = int(np.argmax(np.abs(v * w)))
    return v if v[k] > 0 else -v


def _work(run: object, st: State, phi: np.ndarray) -> float:
    """|phi . f| / (|phi| |f|) in scaled unknowns (f: load vector at factor 1)."""
    w = _weights(run)
    f = run.s.reduced_load(st.q)
    a, b = phi * w, np.where(w > 0, f / np.where(w > 0, w, 1.0), 0.0)
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return float(abs(a @ b) / (na * nb)) if na * nb > 0 else 0.0


def _settle(run: object, st: State, depth: int = 2) -> State:
    """Relax to an equilibrium; an unstable one is displaced along its mode (both signs)
    and relaxed again (``depth`` times)."""
    new = _relax(run, st)
    if run.solver.stable(new, False)[0]:
        return new
    if depth == 0:
        raise SolveError("energy descent ended on an unstable equilibrium")
    phi = _mode(run, new)
    for sign in (1.0, -1.0):
        q = new.q.copy()
        q[run.s.free] += sign * phi
        try:
            return _settle(run, State(q, new.mu.copy(), new.lam), depth - 1)
        except SolveError:
            continue
    raise SolveError("energy descent ended on an unstable equilibrium")


def _relax(run: object, st: State) -> State:
    """Pseudo-transient continuation at fixed factor (module doc); Newton's step cap."""
    sv, s = run.solver, run.s
    nf, f = sv.nf, s.free
    kind = np.array(s.lay.kind)[f]
    shift = kind != "p"  # the axial multipliers carry no pseudo-mass
    q, mu, lam = st.q.copy(), st.mu.copy(), st.lam
    icap = 1.0 / np.where(kind == "r", 0.5, np.where(shift, 0.25 * s.lay.Lref, np.inf))
    # pseudo-mass: the residual scale over the step cap (force / length, moment / rad), one
    # metric for every unknown: a Jacobi mass would make the soft snap mode as heavy as the
    # members' axial stiffness
    mass = np.where(shift, s.rscale[f] * icap, 0.0)
    res0, best = None, (np.inf, 0)
    for it in range(RELAX_ITER):
        R, K, res = sv.kkt(State(q, mu, lam))
        if not np.isfinite(R).all():
            break
        if res <= sv.tol or (res <= STALL * sv.tol and it - best[1] > 10):
            # converged (a Newton update takes it to round-off), or stalled at round-off
            return sv.polish(State(q, mu, lam, it, res, K), R, False)
        res0 = res if res0 is None else res0
        best = (res, it) if res < best[0] else best
        d = np.zeros(K.shape[0])
        d[:nf] = mass
        alpha = _shift(sv, State(q, mu, lam, K=K), d, ALPHA0 * min(res / res0, 1.0))
        Ks = K + sp.diags(alpha * d, format="csc") if sp.issparse(K) else K + np.diag(alpha * d)
        dx = _solve(Ks, -R)
        if not np.isfinite(dx).all():
            break
        big = float((np.abs(dx[:nf]) * icap).max()) if nf else 0.0
        if big > 1.0:
            dx /= big
        q = q.copy()
        q[f] += dx[:nf]
        mu = mu + dx[nf:]
    raise SolveError("energy descent did not settle")


def _shift(sv: object, st: State, d: np.ndarray, alpha: float) -> float:
    """``alpha`` if ``K + alpha diag(d)`` is positive definite on the constraints' tangent,
    else twice the smallest such shift (to 20 %): the step then moves along the unstable
    mode at the pace of its own curvature."""

    def convex(a: float) -> bool:
        K = st.K + sp.diags(a * d, format="csc") if sp.issparse(st.K) else st.K + np.diag(a * d)
        return bool(sv.stable(State(st.q, st.mu, st.lam, K=K), False)[0])

    if convex(alpha):
        return alpha
    lo, hi = alpha, max(4.0 * alpha, 1e-8)
    while not convex(hi):
        lo, hi = hi, 4.0 * hi
        if hi > 1e12:
            raise SolveError("no convexifying shift (singular constraints)")
    while hi > 1.2 * lo:
        mid = np.sqrt(lo * hi)
        lo, hi = (lo, mid) if convex(mid) else (mid, hi)
    return 2.0 * hi
