"""Damped dynamics replay (MSC-ADAMS style): the second, dynamic reference ``replay``.

The FE discretisation the static reference solves (``assembly.build``) gets mass and damping
and is integrated by generalised-alpha (``integrator.GenAlpha``): the load factor is ramped
through the reported factors in one continuous ramp (``ramp_periods`` lowest periods T1 per
increment, ``sweep.ContinuousRamp``) and each sample settled -- directly when it is
quasi-static (Newton to the stable equilibrium it comes to rest at), else by holding the load
until max|w v|/omega_1, max|w qdd|/omega_1^2 and the static distance max|w K^-1 r| are all
below ``settle_tol * L`` (w: 1 for translations, L for rotations), and then finished by
Newton on the same mesh and load from the held state (``finish``: where a held state lies
within that ball is round-off, and differs between encodings of one scene) -- kept as held,
and said in the message, if Newton does not converge or leaves a ball of 100 settle_tol L.
The equation of motion holds exactly at every step, so a state at rest is an exact static
equilibrium: the settled states are the static FE ones of that mesh to round-off (to the
settling tolerance where a finish was not accepted), whatever the step, density or damping
(those shape only the transient, and so which branch a snap lands on).  Each settled
state gets the tangent test (lowest eigenvalue of (K, M)); under conservative loads that is
its stability verdict where it is clear, and the state is kicked (lowest mode, or a nodal
impulse as the thesis did with 1 N pulses in ADAMS) and watched -- returns = stable,
departs = unstable -- where it is near zero and at the last state (``probe`` = "auto";
"all" kicks every state).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from cases.schema import Scene
from fem_reference.replay import events, modes, probe, records
from fem_reference.replay import honesty as honest
from fem_reference.replay import integrator as ev
from fem_reference.replay.finish import finished, note
from fem_reference.replay.sweep import ContinuousRamp
from fem_reference.statics.bifurcation import is_conservative
from fem_reference.statics.integrity import violation
from reduced_models.base import Solution, Step


@dataclass(frozen=True)
class ReplayOptions:
    """Knobs of the replay (dimensionless; times in lowest undamped periods T1).

    zeta : damping ratio at the lowest mode(s) of (K0, M).  damping : "mass" (a0 M, a0 =
    2 zeta omega_1), "current" (Rayleigh a0 M + a1 K(q_n) at the two lowest modes; objective,
    damps impact-excited high modes) or "initial" (a1 K0: spurious forces under large
    rotations, Charney 2008).  rho_inf : generalised-alpha spectral radius at h -> inf.
    ramp_periods : ramp per load increment.  settle_tol : see module docstring.  lte_tol :
    local displacement error per step / L.  dt_max : largest step; max_hold : give up after.
    probe : "auto" | "all" | "last" | "none": which settled states are kicked ("auto": those
    whose tangent test is near its limit, |lowest eigenvalue| < ``PROBE_MARGIN`` omega_1^2,
    and the last; the others get the tangent's verdict, ``probe_plan``);
    probe_amplitude : modal kick (excursion ~ amplitude * L);
    probe_node, probe_impulse : nodal impulse (node id, (Ix, Iy)) instead.
    jump_dissipation : an increment that dissipates more than this fraction of the work
    done (or strain energy change) is checked for a jump (snap-through; ``records.jump``:
    its settled end on another branch than its start); a quasi-static ramp dissipates
    ~ 1 / (omega_1 T_ramp) of it, a snap most of it.  inf: jumps are not assessed.
    history_samples, frames : caps on stored samples.  locks : boom events (``LengthLock``).
    deploy_start : on a deploy scene, "dynamic" (the booms push from the drawn pose) or
    "static" (start locked at the FE deploy equilibrium and only probe it: a sweep's verdicts
    at ~1/10 of the cost, no time history; ``fem_reference.replay.deploy_static``).
    """

    zeta: float = 1.0
    damping: str = "mass"
    rho_inf: float = 0.0
    ramp_periods: float = 4.0
    settle_tol: float = 1e-7
    lte_tol: float = 3e-4
    dt_max: float = 0.5
    max_hold: float = 400.0
    probe: str = "auto"
    probe_amplitude: float = 1e-3
    probe_node: str | None = None
    probe_impulse: tuple[float, float] = (0.0, 1.0)
    jump_dissipation: float = 0.5
    history_samples: int = 2000
    frames: int = 120
    time_limit_s: float = 600.0  # wall clock; past it the replay fails with the reason
    locks: tuple[events.LengthLock, ...] = ()
    deploy_start: str = "dynamic"


SOFT_AFTER = 20.0  # T1 of holding after which a soft mode gets its own critical damping


class _Run:
    """Mutable replay of one system: the current state, the energy books and the history."""

    def __init__(self, system: object, scene: Scene | None, o: ReplayOptions) -> None:
        self.sys, self.o = system, o
        self.L = float(system.length_scale())
        self.w = modes.dof_weights(system, self.L)
        n = system.ndof
        alg = getattr(system, "algebraic", None)
        Mfull, self.point_masses = modes.point_masses(system.mass(), self.w, alg)
        modal = getattr(system, "modal_pair", None)  # (K0, M) of the free vibration, if not
        if modal is not None:  # the system's own (a servo's bordered, singular-mass one)
            K0, M = modal()
            M = modes.point_masses(M, self.w if alg is None else np.delete(self.w, alg))[0]
        else:
            M, (_, K0) = Mfull, system.residual_and_tangent(np.zeros(n), 0.0)
        a0, a1, self.w1, self.damping_note = modes.rayleigh(sp.csr_matrix(K0), M, o.zeta)
        if o.damping == "mass":
            a0, a1, self.damping_note = 2 * o.zeta * self.w1, 0.0, "mass-proportional"
        self.T1 = 2 * math.pi / self.w1
        pairs = events.resolve_locks(system, scene, o.locks)
        damp = (a0, a1, K0 if o.damping == "initial" else None)
        self.integ = ev.GenAlpha(
            system,
            damp,
            pairs,
            self.w,
            self.L,
            rho_inf=o.rho_inf,
            newton_tol=1e-2 * o.settle_tol,
            mass=Mfull,
        )
        self.integ.act_ramp = o.ramp_periods * self.T1  # the boom pushes ramp in, like loads
        self.M = self.integ.M
        self.h = self.T1 / 40.0
        self.W = self.D = self.D_impact = 0.0
        self.U0 = float(system.strain_energy(np.zeros(n)))
        keys = ("t", "factor", "kinetic", "strain", "dissipated", "external_work", "q")
        self.hist = SimpleNamespace(**{k: [] for k in keys})
        self.events: list[dict] = []
        self.s = self.integ.start(0.0, 0.0, np.zeros(n), np.zeros(n))
        self._record(self.s)
        self.deadline = honest.Deadline(o.time_limit_s)
        self.warm: dict = {}  # the last tangent test's mode (band.lowest_mode's start)
        self.tied: list[float] = []  # factors held at a saddle between mirror branches

    def tangent_test(self, chk: dict) -> tuple[float, np.ndarray]:
        """Lowest eigenpair of the settled state's tangent (``static_check``'s K, G)."""
        return modes.tangent_test(chk["K"], chk["G"], self.M, self.integ.bw, self.warm)

    def _record(self, s: ev.State) -> None:
        h = self.hist
        h.t.append(s.t)
        h.factor.append(s.lam)
        h.kinetic.append(0.5 * float(s.v @ self.integ.mass_times(s.v)))
        h.strain.append(None)  # on demand (``strain``): a full element pass per time step
        h.dissipated.append(self.D)
        h.external_work.append(self.W)
        h.q.append(s.q)

    def strain(self, i: int) -> float:
        """Strain energy of history state ``i`` (computed once, when first asked for)."""
        h = self.hist
        if h.strain[i] is None:
            h.strain[i] = float(self.sys.strain_energy(h.q[i]))
        return h.strain[i]

    def advance(
        self,
        t_stop: float,
        lam_of_t: Callable,
        until: Callable | None = None,
        books: bool = True,
        hmax: float | None = None,
        lte: float | None = None,
        steady: bool = False,
        through: bool = False,
    ) -> tuple[ev.State, object]:
        """Integrate to ``t_stop`` (or until ``until(state)`` returns non-None); steps at most
        ``hmax`` (default ``dt_max`` T1), local error per step at most ``lte`` L (default
        ``lte_tol``).  ``steady``: keep the step while the error test would change it by
        less than x0.8 .. x1.5 (so a kept factorisation stays valid).  ``through``: the
        motion goes on smoothly past ``t_stop`` (a sample of a continuous ramp), so the step
        cut short to land on it does not shrink the next one."""
        o, integ, hmin = self.o, self.integ, 1e-10 * self.T1
        hmax = o.dt_max * self.T1 if hmax is None else hmax
        lte = o.lte_tol if lte is None else lte
        s = self.s
        while s.t < t_stop * (1 - 1e-14):
            if self.deadline.passed():
                raise ev.ReplayError(
                    f"time limit {self.deadline.seconds:g} s reached at t = {s.t:.4g} "
                    f"(factor {s.lam:.6g}, step {self.h:.2g}): the replay stalled"
                )
            h_want = min(self.h, hmax)
            h = min(h_want, t_stop - s.t)
            s1 = integ.step(s, h, lam_of_t(s.t + h))
            err = math.inf if s1 is None else integ.error(s, s1, h)
            if err > lte:
                if h <= hmin:
                    raise ev.ReplayError(f"step size underflow at t = {s.t:.6g} (Newton failed)")
                self.h = h * (0.25 if s1 is None else max(0.2, 0.9 * (lte / err) ** (1 / 3)))
                continue
            pair = integ.crossing(s, s1)
            if pair is not None:
                s1 = integ.locate(s, h, lam_of_t, pair)
                if s1 is None:
                    raise ev.ReplayError("could not locate the boom lock event")
                h = s1.t - s.t
            if books:
                dq = s1.q - s.q
                self.W += 0.5 * float((s.f_ext + s1.f_ext) @ dq)
                self.D += 0.5 * h * (integ.damping_power(s, s.v) + integ.damping_power(s, s1.v))
            if pair is not None:
                g_hit = pair.gap(s1.q)
                s1, lost = integ.lock(s1, pair)
                if books:
                    self.D += lost
                    self.D_impact += lost
                ends = f"{pair.lock.a} - {pair.lock.b}"
                self.events.append(dict(kind="lock", ends=ends, t=s1.t, gap=g_hit, lost=lost))
            s = s1
            if books:
                self.s = s
                self._record(s)
            grow = min(2.0, 0.9 * (lte / max(err, 1e-300)) ** (1 / 3))
            self.h = h if steady and 0.8 <= grow < 1.5 else h * grow
            if through and h < h_want:  # cut short by t_stop: says nothing of h_want
                self.h = max(self.h, h_want)
            if until is not None:
                res = until(s)
                if res is not None:
                    return s, res
        return s, None

    # -- settling ------------------------------------------------------------------------------
    def static_check(self, s: ev.State) -> dict | None:
        """Static residual r + G^T mu at ``s``, its Newton correction ``step`` = (dq, dmu)
        (bordered by the locked booms) and the distance max|w dq| / L to equilibrium."""
        o, tol = self.o, self.o.settle_tol * self.L
        if np.max(np.abs(self.w * s.v)) / self.w1 > tol:
            return None
        if np.max(np.abs(self.w * s.acc)) / self.w1**2 > tol:
            return None
        r, K, _, Gc, gc, Hs = self.integ.forces(s.q, s.lam, s.t)
        rt = r + Gc.T @ s.mu
        K = ev.combine([(1.0, K)] + [(m_, H) for m_, H in zip(s.mu, Hs)])
        step = None
        try:
            solve = ev.factor(K, getattr(self.sys, "bandwidth", None))
            dq, dmu = -solve(rt), np.zeros(0)
            if Gc.shape[0]:
                dq, dmu = ev.bordered(solve, Gc, dq, gc)
            dist = float(np.max(np.abs(self.w * dq))) / self.L
            step = (dq, dmu)
        except RuntimeError:  # singular tangent: no distance; the residual itself must be tiny
            dist = float("nan")
        if not (dist <= o.settle_tol):  # nan passes only on a residual at the settle level
            fs = float(np.max(np.abs(self.sys.external(s.q)), initial=0.0)) * max(abs(s.lam), 1)
            rf = float(np.max(np.abs(rt), initial=0.0)) / max(fs, 1e-300)
            if not (math.isnan(dist) and rf <= o.settle_tol):
                return None
        res = float(np.max(np.abs(rt)))
        return {"residual": res, "distance": dist, "K": K, "G": Gc, "step": step}

    def hold(self, lam: float) -> tuple[ev.State, dict]:
        """Hold the load at ``lam`` until settled (static_check passes), then finish by
        Newton (``finish.finished``: the equilibrium it came to rest at, at rest)."""
        if any(p.lock.force and not p.locked for p in self.integ.pairs):
            self.advance(self.integ.act_ramp, lambda t: lam)  # let the boom pushes ramp in
        chk = self.static_check(self.s) if self.s.lam == lam else None  # else: a step change
        if chk is not None:
            return finished(self, self.s, chk)
        t_end = self.s.t + self.o.max_hold * self.T1
        t_soft = min(t_end, self.s.t + SOFT_AFTER * self.T1)
        s, chk = self.advance(t_soft, lambda t: lam, until=self.static_check)
        a0 = self.integ.a0
        if chk is None and self.integ.a1 == 0.0:  # a soft mode creeps, overdamped at a0:
            w = modes.soft_frequency(self.sys, self.integ, s)  # damp it critically instead
            if w is not None and 2.0 * self.o.zeta * w < a0:
                self.integ.a0, self.integ._C0 = 2.0 * self.o.zeta * w, None
        if chk is None:
            s, chk = self.advance(t_end, lambda t: lam, until=self.static_check)
        self.integ.a0, self.integ._C0 = a0, None
        if chk is None:
            raise ev.ReplayError(f"did not settle at factor {lam:.6g} within {self.o.max_hold} T1")
        return finished(self, s, chk)


NO_VERDICT = "stable = None: no static stability verdict under follower (non-conservative) loads"


def ramp_and_hold(run: _Run, lam: float) -> tuple[ev.State, dict]:
    """Ramp the load factor to ``lam`` (over ``ramp_periods`` T1) and hold until settled."""
    if run.s.lam != lam or run.s.t == 0.0 and lam != 0.0:
        la, t0, Tr = run.s.lam, run.s.t, run.o.ramp_periods * run.T1
        run.advance(t0 + Tr, ev.ramp_path(la, lam, t0, Tr))
    return run.hold(lam)


def _integrity(system: object, s: ev.State) -> str | None:
    """None, or why settled state ``s`` is outside the FE model (``integrity.violation``):
    a system with a prescribed coordinate (driver, servo) is checked on its full state."""
    full_state = getattr(system, "full_state", None)
    if full_state is None:
        return violation(system, s.q)
    return violation(system.full, full_state(s.q, s.lam)[0])


def replay_system(
    system: object,
    factors: np.ndarray,
    *,
    scene: Scene | None = None,
    case: str = "",
    options: ReplayOptions | None = None,
    stability: Callable = probe.stability,
    reach: Callable | None = None,
) -> Solution:
    """Replay ``system`` through the load ``factors`` (the heart of the ``replay`` model).

    Parameters
    ----------
    system : a ``DiscreteSystem`` (``assembly.build(scene, n)`` or any test system).
    factors : (nsteps,) reported load factors, starting with the initial one.
    scene : the scene (node coordinates for boom events and nodal probes), optional.
    case : case name for the Solution; options : ReplayOptions (defaults if None).
    stability : ``(run, state, static_check, want, scene) -> (eigenvalue, probe dict)`` at
        each settled state, ``want`` from ``probe_plan`` (a servo replay tests the
        load-controlled system instead).
    reach : ``(run, factor) -> (settled state, static_check)``: how a report point is
        reached (default: one continuous ramp through ``factors``, ``sweep.ContinuousRamp``;
        a servo replay aims its coordinate).

    Returns
    -------
    Solution with one settled Step per factor; extras: ``history`` (time series, lists),
    ``jumps`` (snap-throughs), ``critical_points`` (the jumps as snaps), ``events`` (boom
    locks), ``probes``, ``frames`` (arrays for the animation), ``settle`` (timing/damping
    figures).
    """
    o = options or ReplayOptions()
    reach = reach or ContinuousRamp(factors)
    steps: list[Step] = []
    jumps: list[dict] = []
    probes: list[dict] = []
    unfinished: list[dict] = []  # held states the Newton finish was not accepted on
    try:
        run = _Run(system, scene, o)
    except (ev.ReplayError, RuntimeError, ValueError) as exc:
        return Solution(case, "replay", "failed", f"replay set-up failed: {exc}")
    status, message = "converged", ""
    prev_q, prev_step = run.s.q, None
    stable_from = None  # (q, factor) of the last settled state found stable
    tied = None  # the bifurcation between mirror branches the replay was held at
    # follower loads: no potential energy, so neither the tangent test nor a settled probe
    # decides static stability (flutter needs a dynamic analysis): no verdict, as fem-auto
    verdict = is_conservative(system)
    for k, lam in enumerate(np.asarray(factors, dtype=float)):
        it0, h = run.integ.newton_iterations, run.hist
        mark = (len(h.t), run.W, run.strain(-1), run.D - run.D_impact, prev_q)
        move = getattr(reach, "move", 0.0)  # the ramp's tangent prediction (0: unknown)
        try:
            s, chk = reach(run, float(lam))
            want = probe.probe_plan(o, k, len(factors), verdict)
            eig, pr = stability(run, s, chk, want, scene)
        except (ev.ReplayError, RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
            status, message = "failed", f"factor {lam:.6g}: {exc}"
            break
        why = _integrity(system, s)  # a settled state the FE model cannot stand behind
        if why:
            status, message = "failed", f"factor {lam:.6g}: {why}"
            break
        pr.update(factor=float(lam), eigenvalue=eig, tangent_stable=verdict and bool(eig > 0))
        probes.append(pr)
        if "unfinished" in chk:
            unfinished.append({"factor": float(lam), "why": chk["unfinished"]})
        info = {
            "finished": float("unfinished" not in chk),
            "residual": chk["residual"],
            "distance": chk["distance"],
            "t_settled": s.t,
            "lowest_eigenvalue": eig,
            "tangent_stable": float(eig > 0) if verdict else math.nan,
            "probe_stable": math.nan
            if pr["stable"] is None or pr["verdict"] == "tangent"
            else float(pr["stable"]),
            "probe_peak": pr.get("peak", math.nan),
        }
        st = system.step(s.q, s.lam, run.integ.newton_iterations - it0, pr["stable"])
        st = replace(st, info={**dict(st.info), **info}, stable=pr["stable"])
        if k > 0:
            jp = records.jump(run, mark, prev_step, st, stable_from, move or None)
            if jp is not None:
                jumps.append(jp)
        if run.tied and tied is None:  # held at a saddle between mirror branches
            tied = records.tied_point(run, stable_from, float(lam))
        steps.append(st)
        prev_q, prev_step = s.q, st
        if verdict and (st.stable or eig >= probe.PROBE_MARGIN * run.w1**2):  # clearly stable:
            stable_from = (s.q, float(lam))  # the static path from it starts stable
        if getattr(reach, "ended", False):  # the reach ended the path (a servo at factor_end)
            break
    extras = records.extras(run, system, jumps, probes)
    extras["settle"]["unfinished"] = unfinished
    if tied is not None:
        extras["critical_points"].append(tied)
    if status == "converged":
        res = max(s.info["residual"] for s in steps)
        message = f"settled {len(steps)} states; max residual {res:.2e}; {len(jumps)} jump(s)"
        message += note(extras)
        message += "".join(  # where, as the FE says it
            f"; {p['kind']} at factor {p['factor']:.6g} (critical_points: from, to)"
            for p in extras["critical_points"]
            if p is not tied
        )
        message += "" if tied is None else records.TIED_NOTE.format(tied["factor"])
        if not verdict:
            extras["stability"] = NO_VERDICT
            message += f"; {NO_VERDICT}"
        if steps and steps[-1].stable is False:  # said, and not used as a reference
            message += "; the last state is an unstable equilibrium"
            extras["reference_usable"] = False
    return Solution(case, "replay", status, message, tuple(steps), extras)
