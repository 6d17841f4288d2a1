"""One continuous load ramp through all report factors, sampled and settled at each.

The replay's default way to reach its report factors (``run.replay_system``).  The load
factor follows the factors piecewise linearly, one increment per ``ramp_periods`` lowest
periods T1, never stopping: no restart transient per increment, so the time steps are set by
the ramp (up to ``dt_max``), not by a fresh transient to resolve at every factor.  The first
increment after a start from rest eases in (C2: load rate and its derivative start at zero).

At a report factor the moving state lags the ramp (by ~ 2 zeta / omega_1 times its rate).
When that sample is quasi-static -- velocity / omega_1 and the distance K^-1 r to
equilibrium below ``CLOSE`` L and below ``QUASI_STATIC`` of the increment's own motion (not
a sudden load's transient), within the tangent's linear range (Newton's second correction
at most ``LINEAR`` of its first) -- what is left if the load is held is a small damped
vibration about the nearby equilibrium, which it comes to rest at.  That equilibrium is
found directly, by Newton from the sample (``settle``), and kept only if it is stable (or
no static verdict exists: follower loads) and passes the same settling test as a held state
(``_Run.static_check``).  Otherwise (a snap under way, an unstable or no nearby
equilibrium) the load is held at the factor and the motion integrated until settled
(``_Run.hold``) as a ramp-and-hold replay does, and the ramp starts again from rest there;
so is the last factor (the time history ends at rest on it).  After a settled sample the
ramp goes on from the moving state.

Steps on the ramp are sized by the integrator's error estimate up to ``RAMP_DT`` T1, with a
local error of ``RAMP_RTOL`` of the motion the tangent at the last settled sample predicts
for the increment (``K^-1 f_ext`` times its load step; never below ``lte_tol``, and
``lte_tol`` after a hold): a quasi-static ramp takes two steps per increment, while a snap
starting on it (accelerations far above the ramp's) is resolved to that tolerance and held
at ``lte_tol``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from fem_reference.banded import BandedLU
from fem_reference.replay import integrator as ev
from fem_reference.replay import modes
from fem_reference.replay.band import lowest_mode_band
from fem_reference.statics.bifurcation import is_conservative
from fem_reference.statics.switch import SWITCH_AMPLITUDE

CLOSE = 5e-2  # velocity / omega_1 and distance to equilibrium (/ L) that a sample may have
QUASI_STATIC = 0.25  # and at most this fraction of the increment's own motion (a ramp's lag)
LINEAR = 0.1  # and Newton's second correction / its first: the tangent barely changes on the way
NEWTON_MAX = 12
RAMP_NEWTON = 1e-3  # Newton tolerance on a ramp / lte_tol
RAMP_DT = 2.0  # largest ramp step / T1 (two per increment at ramp_periods = 4)
RAMP_RTOL = 0.03  # local error per ramp step / the motion the tangent predicts for it
SADDLE_KICKS = 3  # displacements off a held saddle (``off_saddle``) at most
TIE_PARITY = 1e-6  # odd / even part of the potential along a kick: the saddle's sides mirror


def _ease(x: float) -> float:
    """Increments covered after ``x`` ramp periods from rest: x^3 - x^4 / 2 on [0, 1]
    (C2 start, unit rate at x = 1), then x - 1/2."""
    return x**3 - 0.5 * x**4 if x < 1.0 else x - 0.5


class ContinuousRamp:
    """``reach`` of ``replay_system``: called with the factors in order (see module doc).

    Parameters
    ----------
    factors : (nsteps,) the report factors, in the order they will be asked for.
    """

    def __init__(self, factors: np.ndarray) -> None:
        self.factors = np.asarray(factors, dtype=float)
        self.sched: np.ndarray | None = None  # [start factor, factors...]
        self.k = 0  # schedule index of the next report factor
        self.j0, self.t0 = 0, 0.0  # the ramp runs from rest at schedule index j0, time t0
        self.q_last: np.ndarray | None = None  # the last settled state's DOFs
        self.move = 0.0  # motion the tangent predicts for the next increment / L (0: unknown)

    def lam_of_t(self, Tr: float) -> Callable[[float], float]:
        """Load factor along the ramp that started from rest at (j0, t0)."""
        sched, j0, t0 = self.sched, self.j0, self.t0
        idx = np.arange(sched.size, dtype=float)
        return lambda t: float(np.interp(j0 + _ease((t - t0) / Tr), idx, sched))

    def __call__(self, run: object, lam: float) -> tuple[ev.State, dict]:
        if self.sched is None:
            self.sched = np.r_[run.s.lam, self.factors]
            self.k, self.j0, self.t0 = 1, 0, run.s.t
            self.q_last = run.s.q
            if self.factors.size and self.factors[0] == run.s.lam:  # starts where it is
                self.k, self.j0 = 2, 1
                out = off_saddle(run, run.hold(lam))
                if banded(run) and self.sched.size > 2:
                    chk = at_rest(run, out[0].t, lam, out[0].q)[1]
                    self.move = 0.0 if chk is None else self._ahead(run, out[0], chk, 2)
                return out
        j, self.k = self.k, self.k + 1
        if self.sched[j] != lam:
            raise ev.ReplayError(f"continuous ramp: factor {lam:g} asked out of order")
        if run.tied and banded(run):
            return on_fundamental(run, lam)
        Tr = run.o.ramp_periods * run.T1
        t_j = self.t0 + Tr * (j - self.j0 + 0.5)  # _ease(x) = j - j0 (j > j0)
        # the local error per step: a fraction of the motion the tangent at the last settled
        # sample predicts for this increment (its end is settled by Newton anyway), never
        # below lte_tol; lte_tol after a hold (a snap, the start from rest: no prediction)
        lte = max(run.o.lte_tol, RAMP_RTOL * self.move)
        integ, tight = run.integ, run.integ.newton_tol
        # a transient: Newton to a fraction of the step's own error (the reported state is
        # checked on itself, by ``static_check``)
        integ.newton_tol = max(tight, RAMP_NEWTON * lte)
        try:
            run.advance(t_j, self.lam_of_t(Tr), hmax=RAMP_DT * run.T1, lte=lte, through=True)
        finally:
            integ.newton_tol = tight
        # the last factor is held: the run's history ends at rest on its last answer
        last = j == self.sched.size - 1
        out = None if last else settle(run, run.s, lam, self.q_last)
        if out is None:  # held on the ramp itself: it starts again from rest
            out = off_saddle(run, run.hold(lam))
            self.j0, self.t0 = j, out[0].t
            self.move = 0.0
        elif not last:
            self.move = self._ahead(run, out[0], out[1], j + 1)
        self.q_last = out[0].q
        return out

    def _ahead(self, run: object, s: ev.State, chk: dict, j: int) -> float:
        """max|w K^-1 f_ext| (lam_j - s.lam) / L: the motion the tangent at the settled
        state ``s`` (``chk["solve"]``, from ``at_rest``) predicts for the increment to
        schedule index ``j``."""
        f = np.asarray(run.sys.external(s.q), dtype=float) * (self.sched[j] - s.lam)
        return float(np.max(np.abs(run.w * chk["solve"](f)))) / run.L


def settle(
    run: object, s: ev.State, lam: float, q_from: np.ndarray
) -> tuple[ev.State, dict] | None:
    """The equilibrium at ``lam`` the nearly settled state ``s`` comes to rest at (Newton
    from s.q), at rest, with its ``static_check``; None if ``s`` is not close to rest and to
    equilibrium (``CLOSE``, ``QUASI_STATIC`` of the motion since the settled ``q_from``),
    Newton does not converge, or the equilibrium is unstable."""
    L, w = run.L, run.w
    if not banded(run):
        return None
    speed = float(np.max(np.abs(w * s.v))) / run.w1
    if speed > CLOSE * L:
        return None
    steps = _newton(run, s.q, lam)
    if steps is None:
        return None
    q, dist = steps
    if max(speed, dist) > QUASI_STATIC * float(np.max(np.abs(w * (q - q_from)))):
        return None
    rest, chk = at_rest(run, s.t, lam, q)
    if chk is None:
        return None
    if is_conservative(run.sys) and not chk["tangent"][0] > 0.0:
        return None  # a damped motion does not come to rest at an unstable equilibrium
    return rest, chk


def off_saddle(run: object, held: tuple[ev.State, dict]) -> tuple[ev.State, dict]:
    """The held state, or -- where it is a saddle of the potential (conservative loads, the
    tangent test's lowest eigenvalue negative) -- the state the motion settles at once
    displaced off it along the unstable mode.

    A damped motion comes to rest at a saddle only when it has no component along the
    unstable mode: a perfectly symmetric structure loaded on its symmetry axis, ramped past
    its bifurcation, stays on the symmetric path while that path is unstable (a real one,
    or the same scene in another encoding, leaves it by its imperfections or round-off, at
    an undetermined time and onto an undetermined side).  It is displaced as the FE's branch
    switch does (``switch.SWITCH_AMPLITUDE`` of the length scale, or rad, along the
    mode's largest weighted component, positive) and held again, at most ``SADDLE_KICKS``
    times.  The tangent test is kept in ``chk["tangent"]`` (the stability verdict uses it).

    Where the two sides of the saddle are mirror images (``mirror_sides``) and the kick
    landed off the symmetric path, the other kick would land on the mirror-image state: a
    perfect structure's two buckled branches, which no rule drawn from the scene can tell
    apart (the mirrored scene is the same scene).  The saddle is kept, unstable (as the
    FE's ``bifurcation.Watch`` stays on the fundamental branch), the factor is recorded in
    ``run.tied``; the later report factors are held on the fundamental branch statically
    (``on_fundamental``)."""
    s, chk = held
    if not is_conservative(run.sys):
        return held
    for _ in range(SADDLE_KICKS):
        eig, mode = chk.get("tangent") or run.tangent_test(chk)
        chk["tangent"] = (eig, mode)
        if not eig < 0.0 or s.mu.size:  # locked booms: held where the lock holds them
            break
        wm = run.w * mode
        kick = SWITCH_AMPLITUDE * run.L * mode / wm[int(np.argmax(np.abs(wm)))]
        mirrored = mirror_sides(run.sys, s.q, s.lam, kick)
        saddle, books = (s, chk), _books(run)
        q = s.q + kick
        run.s = run.integ.start(s.t, s.lam, q, np.zeros_like(q))
        s, chk = run.hold(s.lam)
        if mirrored and _off_symmetric(run, saddle[0].q, s.q, mode):
            _rewind(run, books, saddle[0])  # the kick was a question, not the motion
            run.tied.append(float(s.lam))
            return saddle
    return s, chk


def _books(run: object) -> tuple:
    """What ``_rewind`` restores: history length, energy books, events, step size."""
    return len(run.hist.t), run.W, run.D, run.D_impact, len(run.events), run.h


def _rewind(run: object, books: tuple, s: ev.State) -> None:
    """Undo the motion since ``_books``: the history, energy books and events as they were,
    the run at rest at ``s``."""
    n, run.W, run.D, run.D_impact, n_events, run.h = books
    for seq in vars(run.hist).values():
        del seq[n:]
    del run.events[n_events:]
    run.s = s


def on_fundamental(run: object, lam: float) -> tuple[ev.State, dict]:
    """The fundamental branch at ``lam`` after the replay was held between a perfect
    structure's mirror branches (``off_saddle``, ``run.tied``): by Newton from the last
    state, at rest, with its settling check and tangent test.  A motion along an unstable
    branch leaves it by the round-off of the encoding (the unstable mode grows ~e^20 over
    one ramp increment), onto a branch the scene cannot pick, so the replay holds it
    statically there, as the FE follows it."""
    s0 = run.s
    found = _newton(run, s0.q, lam)
    if found is None:
        raise ev.ReplayError(f"the fundamental branch was lost at factor {lam:.6g}")
    # in the history as a quasi-static increment of one ramp's duration (dead loads: the
    # work of the mean load on the step)
    t = s0.t + run.o.ramp_periods * run.T1
    rest, chk = at_rest(run, t, lam, found[0])
    if chk is None:
        raise ev.ReplayError(f"the fundamental branch at factor {lam:.6g} does not settle")
    run.W += 0.5 * float((s0.f_ext + rest.f_ext) @ (rest.q - s0.q))
    run.s = rest
    run._record(rest)
    run.tied.append(float(lam))
    return rest, chk


def mirror_sides(system: object, q: np.ndarray, lam: float, kick: np.ndarray) -> bool:
    """Whether the total potential U(q) - lam f . q (dead loads) is even along ``kick`` from
    the equilibrium ``q``: its odd part (P+ - P-) / 2 below ``TIE_PARITY`` of its even part
    (P+ + P- - 2 P0) / 2 plus the round-off of the sums.  A mirror symmetry that fixes
    ``q`` and reverses the mode makes it exactly even; an asymmetric bifurcation's odd
    part is of the kick's relative size (the cubic term)."""
    f = np.asarray(system.external(q), dtype=float)

    def potential(x: np.ndarray) -> float:
        return float(system.strain_energy(x)) - lam * float(f @ x)

    u0, w0 = float(system.strain_energy(q)), lam * float(f @ q)
    p0, pp, pm = u0 - w0, potential(q + kick), potential(q - kick)
    even, odd = 0.5 * (pp + pm - 2.0 * p0), 0.5 * (pp - pm)
    noise = 8.0 * np.finfo(float).eps * (abs(u0) + abs(w0))
    return abs(odd) <= TIE_PARITY * abs(even) + noise


def _off_symmetric(run: object, q_saddle: np.ndarray, q_land: np.ndarray, mode: np.ndarray) -> bool:
    """Whether the landing ``q_land`` moved off the saddle along the (antisymmetric)
    ``mode``: a landing on the symmetric path (DAS-2D Ex. 3's shuttle, kicked to tilt,
    settles untilted at the far state) has no component along it, M-orthogonal to every
    symmetric motion; a buckled branch has one of the motion's own size."""
    M, d = run.M, q_land - q_saddle
    Md, Mm = M @ d, M @ mode
    along = abs(float(mode @ Md)) / math.sqrt(max(float(mode @ Mm), 1e-300))
    return along > 1e-3 * math.sqrt(max(float(d @ Md), 0.0))


def banded(run: object) -> bool:
    """Whether ``settle`` and ``at_rest`` apply: a band system without locks or pushes."""
    return run.integ._Mb is not None and not run.integ.pairs


def at_rest(run: object, t: float, lam: float, q: np.ndarray) -> tuple[ev.State, dict | None]:
    """The state at rest at ``q`` (band system without locks or pushes) and its
    ``_Run.static_check`` with the tangent test (``chk["tangent"]``), all from one evaluation
    and one band tangent: the accelerations M^-1 (-r), the distance K^-1 r, the lowest
    eigenpair of (K, M) (``band.lowest_mode_band``; the dense test when K is not positive
    definite).  The check is None when the state does not pass it."""
    integ, sys_, o, bw = run.integ, run.sys, run.o, run.integ.bw
    e = sys_.evaluate(q, lam)
    Kb = sys_.tangent_band(e)
    r = np.asarray(e.r, dtype=float)
    acc = np.zeros_like(q) if integ._Msolve is None else integ._Msolve(-r)  # as ``start``
    current = integ.a1 != 0.0 and integ.K0 is None  # current-stiffness damping needs K
    K = sys_.tangent_csr(e) if current else None
    fe = lam * np.asarray(sys_.external(q), dtype=float)
    zero = np.zeros_like(q)
    rest = ev.State(t, lam, q, zero, acc, acc.copy(), np.zeros(0), fe, K)
    tol = o.settle_tol * run.L
    if np.max(np.abs(run.w * acc)) / run.w1**2 > tol:
        return rest, None
    tangent = lowest_mode_band(Kb, integ.M, bw, run.warm)  # before the LU overwrites Kb
    try:
        solve = BandedLU(Kb, bw).solve
        d = solve(r)
        dist = float(np.max(np.abs(run.w * d))) / run.L
    except RuntimeError:
        return rest, None  # singular: no distance (``static_check`` then asks the residual)
    if not dist <= o.settle_tol:
        return rest, None
    if tangent is None:  # not positive definite: the dense test
        K = sys_.tangent_csr(e) if K is None else K
        tangent = modes.tangent_test(K, np.zeros((0, q.size)), integ.M)
    chk = {"residual": float(np.max(np.abs(r))), "distance": dist, "tangent": tangent}
    chk["solve"] = solve  # K^-1 at the state (``ContinuousRamp._ahead``)
    return rest, chk


def _newton(run: object, q: np.ndarray, lam: float) -> tuple[np.ndarray, float] | None:
    """Static equilibrium at ``lam`` by Newton from ``q`` (band LU of the tangent) to the
    replay's Newton tolerance, and the first correction max|w K^-1 r| (a length); None if
    that is above ``CLOSE`` L, the second above ``LINEAR`` of it, or Newton stalls."""
    integ, L, w = run.integ, run.L, run.w
    bound, first = CLOSE * L, None
    for _ in range(NEWTON_MAX):
        e = run.sys.evaluate(q, lam)
        try:
            dq = -BandedLU(run.sys.tangent_band(e), integ.bw).solve(e.r)
        except RuntimeError:
            return None
        err = float(np.max(np.abs(w * dq)))
        if not math.isfinite(err) or err > bound:
            return None
        q = q + dq
        if first is None:
            first, bound = err, LINEAR * err
        else:
            bound = 0.5 * err
        if err <= integ.newton_tol * L:
            return q, first
    return None
