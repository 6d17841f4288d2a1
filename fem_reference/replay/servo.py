"""Replay of ``distance`` and ``path`` analyses: a servo holds a coordinate, the load follows.

A load-controlled replay cannot reach the states of a distance sweep that lie on the falling
branch of a snap-through (DAS-2D Ex. 3: every target between the limit point and the load
minimum), and bracketing the load factor on settled states finds only the stable ones.  So
the replay does what a displacement-controlled test rig does: the target coordinate (the
driver of a ``distance`` analysis, the ``stop_output`` of a ``path``) is moved slowly as a
prescribed motion -- ramped between report points and held until settled, as loads are
ramped -- and a servo sets the load factor of the scene's loads so that the coordinate needs
no other force to follow.  The load factor is an algebraic unknown of the equations of motion
(no inertia), bordering the FE tangent::

    M' qdd + C' qd + r(q, lam) = 0     (all rows; q_i prescribed, lam in slot i)

``ServoSystem`` puts ``lam * ell`` in the slot of the prescribed DOF ``i`` (ell: the start
compliance max|w K0^-1 f|, so the slot is a length and the settling tolerance bounds the
load factor's error by ``settle_tol * L / ell``): the tangent is K with column i replaced by
``-f / ell`` (still banded when the loads sit within the band of DOF i), M' is M with column i
zeroed (the prescribed DOF's inertia is neglected, as in ``driver``).  A settled state
is then exactly a static equilibrium with the coordinate at its target: the static distance
answer.  The servo holds the loads' own DOF when they act on exactly one (a rigid test
machine on the load point: a conservative control) and lands the target coordinate by
secant / Illinois on settled states; a servo on a DOF far from the loads is an ill-posed
index-3 problem (Lee's frame: Newton fails).  If the target jumps under the load point's
servo (it snaps), the replay holds the target coordinate itself instead (a feedback that may
pick another branch at a bifurcation; the equilibria are the same set) and says so.
The stability of a settled state is judged as the FE judges a distance step -- under load
control, the servo off: tangent test of the full system and an impulse probe of a
load-controlled replay at the settled load factor.  A path whose stop coordinate turns back
cannot be held by a servo on it: the replay fails there with that reason.  A ``path``
without a stop output is replayed under load control to ``factor_end`` (snaps are jumps).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.error.richardson import gci
from fem_reference.replay import honesty as honest
from fem_reference.replay import integrator as ev
from fem_reference.replay import modes
from fem_reference.replay.finish import note as finish_note
from fem_reference.statics.driver_post import post_process
from reduced_models.base import Solution, Step, not_applicable

#: a report point's target coordinate is landed to this fraction of the sweep's range (the
#: factor then differs from the one at the exact target by dlam/ds x 1e-5 x range, far below
#: the mesh error the replay states), but no closer than 10 x what settling resolves
AIM_RANGE, AIM_SETTLE = 1e-5, 10.0


def aim_tolerance(values: np.ndarray, func: tuple, settle_tol: float, full: object) -> float:
    """Landing tolerance of the target coordinate, in the units of its DOF."""
    span = float(np.max(np.abs(np.asarray(values) - values[0]), initial=0.0)) / abs(func[1])
    return max(AIM_RANGE * span, AIM_SETTLE * settle_tol * full.length_scale())


class ServoSystem:
    """A ``DiscreteSystem`` whose DOF ``i`` follows the parameter ``p`` (its ``lam``) while
    slot ``i`` of its unknowns holds ``lam_load * ell``."""

    outputs_need_factor = True  # the prescribed coordinate is not in u

    def __init__(self, full: object, i: int) -> None:
        self.full, self.i = full, int(i)
        n = self.ndof = full.ndof
        self.n_elements = full.n_elements
        self.algebraic = np.array([self.i])
        self.is_rotation = np.array(full.is_rotation, dtype=bool)
        # the full system's follower DOFs: a servo-held replay under follower loads gives no
        # static stability verdict either (``bifurcation.is_conservative``)
        self.fol_dofs = getattr(full, "fol_dofs", None)
        self.is_rotation[self.i] = False  # slot i is a length (lam * ell)
        self._p = 0.0
        M = sp.csr_matrix(full.mass())
        self._M_full = M
        self._M = (M @ sp.diags(np.where(np.arange(n) == self.i, 0.0, 1.0))).tocsr()
        self._M.eliminate_zeros()
        z = np.zeros(n)
        self.f = np.asarray(full.external(z), dtype=float)
        self.ell = self._compliance()
        self._follow = bool(getattr(full.fast, "follow", False))
        rows = np.flatnonzero(self.f)
        bw = full.fast.scatter.bw
        inside = bw is not None and (rows.size == 0 or np.abs(rows - self.i).max() <= bw)
        self.bandwidth = full.bandwidth if inside else None

    def _compliance(self) -> float:
        """max |w K0^-1 f| at the start (length per unit load factor), L if K0 is singular."""
        L = float(self.full.length_scale())
        try:
            x = self.full.factor(self.full.evaluate(np.zeros(self.ndof), 0.0)).solve(self.f)
        except RuntimeError:
            return L
        if not np.all(np.isfinite(x)):
            return L
        w = np.where(np.asarray(self.full.is_rotation, dtype=bool), L, 1.0)
        ell = float(np.max(np.abs(w * x), initial=0.0))
        return ell if ell > 0.0 else L

    # -- state maps ------------------------------------------------------------------------
    def full_state(self, u: np.ndarray, p: float) -> tuple[np.ndarray, float]:
        """(q of the FE system, load factor) of servo state ``u`` at parameter ``p``."""
        q = np.array(u, dtype=float)
        q[self.i] = p
        return q, float(u[self.i]) / self.ell

    def _f(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.full.external(q), dtype=float) if self._follow else self.f

    # -- fast path (band storage) ----------------------------------------------------------
    def evaluate(self, u: np.ndarray, p: float) -> SimpleNamespace:
        self._p = p
        q, lam = self.full_state(u, p)
        e = self.full.evaluate(q, lam)
        return SimpleNamespace(r=e.r, ev=e, q=q)

    def tangent_band(self, e: SimpleNamespace) -> np.ndarray:
        """K with column i replaced by -f / ell, ``dgbtrf`` band storage (Fortran)."""
        ab = self.full.tangent_band(e.ev)
        bw, i = self.bandwidth, self.i
        j = np.arange(max(0, i - bw), min(self.ndof, i + bw + 1))
        ab[:, i] = 0.0
        ab[2 * bw + j - i, i] = -self._f(e.q)[j] / self.ell
        return ab

    def tangent_csr(self, e: SimpleNamespace) -> sp.csr_matrix:
        K = self.full.tangent_csr(e.ev).tocsc()
        col = sp.csc_matrix(-self._f(e.q)[:, None] / self.ell)
        return sp.hstack([K[:, : self.i], col, K[:, self.i + 1 :]]).tocsr()

    # -- DiscreteSystem protocol -----------------------------------------------------------
    def residual(self, u: np.ndarray, p: float) -> np.ndarray:
        return self.evaluate(u, p).r

    def residual_and_tangent(self, u: np.ndarray, p: float) -> tuple:
        e = self.evaluate(u, p)
        return e.r, self.tangent_csr(e)

    def external(self, u: np.ndarray) -> np.ndarray:
        return np.zeros(self.ndof)  # the servo's work is not booked (see driver.py)

    def mass(self) -> sp.csr_matrix:
        return self._M

    def modal_pair(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Tangent and mass at the start with the coordinate held (slot i removed)."""
        return self.modal_pair_at(np.zeros(self.ndof), 0.0)

    def modal_pair_at(self, u: np.ndarray, p: float) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Tangent (load factor fixed) and mass at servo state ``u`` with the coordinate held."""
        keep = np.delete(np.arange(self.ndof), self.i)
        q, lam = self.full_state(u, p)
        K = sp.csr_matrix(self.full.residual_and_tangent(q, lam)[1])
        return K[keep][:, keep], self._M_full[keep][:, keep]

    def strain_energy(self, u: np.ndarray) -> float:
        return float(self.full.strain_energy(self.full_state(u, self._p)[0]))

    def outputs(self, u: np.ndarray, p: float | None = None) -> dict[str, float]:
        return self.full.outputs(self.full_state(u, self._p if p is None else p)[0])

    def length_scale(self) -> float:
        return float(self.full.length_scale())

    def step(self, u: np.ndarray, p: float, iterations: int, stable: bool | None) -> Step:
        q, lam = self.full_state(u, p)
        return replace(self.full.step(q, lam, iterations, stable), factor=lam)


def _probe_under_load(servo: ServoSystem, options: object, scene: Scene) -> object:
    """The ``stability`` hook of ``replay_system``: tangent test and impulse probe of the full
    system at the settled load factor (servo off), as the FE tests a distance step."""
    from fem_reference.replay.probe import kick, unprobed
    from fem_reference.replay.run import _Run

    aux: list = []

    def stab(run: object, s: ev.State, chk: dict, want: str, sc: Scene | None) -> tuple:
        q, lam = servo.full_state(s.q, s.lam)
        if not aux:
            aux.append(_Run(servo.full, scene, replace(options, settle_tol=1e-7)))
            aux[0].deadline = run.deadline  # one wall-clock budget for both
        a = aux[0]
        _, K = servo.full.residual_and_tangent(q, lam)
        eig, mode = modes.tangent_test(sp.csr_matrix(K), np.zeros((0, servo.ndof)), a.M)
        pr = unprobed(a, eig, want)  # the full system's omega_1 sets the margin
        if pr is not None:
            return eig, pr
        return eig, kick(a, a.integ.start(s.t, lam, q, np.zeros(servo.ndof)), eig, mode, sc)

    return stab


def servo_dof(full: object, j: int) -> int:
    """The DOF the servo holds: the loads' own DOF when they act on exactly one (a rigid test
    machine on the load point; a servo on a DOF the loads do not act on is an ill-posed
    index-3 problem when they are far apart), else the target DOF ``j``."""
    nz = np.flatnonzero(full.external(np.zeros(full.ndof)))
    return int(nz[0]) if nz.size == 1 else int(j)


class _Aim:
    """The ``reach`` hook of ``replay_system``: settle with the target coordinate ``off + c
    q[j]`` at the report value T, moving the servo DOF ``i``.  For i != j: the first guess is
    the quadratic through the last three settled (target, servo) points, then secant, each
    move at most twice the last settled increment (unit slope for the very first), Illinois
    regula falsi once T is bracketed."""

    MAX_SETTLES = 30
    END_RTOL = 1e-10  # the end point's load factor: relative to factor_end

    def __init__(
        self, servo: ServoSystem, func: tuple[int, float, float], tol: float, end: float | None
    ) -> None:
        self.sv, (self.j, self.c, self.off) = servo, func
        self.tol, self.seen = tol, [(0.0, 0.0)]  # settled (target value - off, servo DOF)
        self.jumped = False
        self.end, self.last = end, (0.0, 0.0)  # factor_end; (servo DOF, load factor) settled
        self.ended = False  # the path reached factor_end: ``replay_system`` stops there

    def __call__(self, run: object, T: float) -> tuple[ev.State, dict]:
        """Settle at report value ``T``; a path that passes ``factor_end`` on the way settles
        where the load factor equals it instead (and ends there, as fem-auto's does)."""
        s, chk = self._aim(run, T)
        if self.end is None:
            return s, chk
        prev, self.last = self.last, (s.lam, self.sv.full_state(s.q, s.lam)[1])
        if self.last[1] * math.copysign(1.0, self.end) <= abs(self.end):
            return s, chk
        return self._land(run, prev, self.last)

    def _land(self, run: object, a: tuple, b: tuple) -> tuple[ev.State, dict]:
        """Settle at the servo position between ``a`` and ``b`` ((servo DOF, load factor),
        on either side of factor_end) where the load factor is factor_end (Illinois)."""
        from fem_reference.replay.run import ramp_and_hold

        (p0, g0), (p1, g1) = (a[0], a[1] - self.end), (b[0], b[1] - self.end)
        for _ in range(self.MAX_SETTLES):
            p = p1 - g1 * (p1 - p0) / (g1 - g0)
            s, chk = ramp_and_hold(run, p)
            g = self.sv.full_state(s.q, s.lam)[1] - self.end
            if abs(g) <= self.END_RTOL * abs(self.end):
                self.ended, self.last = True, (p, g + self.end)
                return s, chk
            if (g > 0.0) == (g1 > 0.0):
                g0 *= 0.5  # the same end kept twice: halve the other's value (Illinois)
            else:
                p0, g0 = p1, g1
            p1, g1 = p, g
        raise ev.ReplayError(f"the servo did not settle at factor_end = {self.end:g}")

    def _aim(self, run: object, T: float) -> tuple[ev.State, dict]:
        """Settle with the target coordinate at report value ``T`` (class docstring)."""
        from fem_reference.replay.run import ramp_and_hold

        T = (T - self.off) / self.c  # in the units of q[j]
        if self.sv.i == self.j:
            return ramp_and_hold(run, T)
        y1, p1 = self.seen[-1]
        y0, p0 = self.seen[-2] if len(self.seen) > 1 else (y1, p1)
        slope = (p1 - p0) / (y1 - y0) if y1 != y0 else 1.0
        cap = 2.0 * (abs(p1 - p0) or abs(T - y1))
        ends: dict[bool, tuple[float, float]] = {}  # bracket: side (y > T) -> (y - T, p)
        p, y, last = p1, y1, None
        for _ in range(self.MAX_SETTLES):
            if len(ends) == 2:  # Illinois regula falsi inside the bracket
                (g0, q0), (g1, q1) = ends[False], ends[True]
                if abs(q1 - q0) <= 1e-9 * max(abs(q0), abs(q1), self.tol):
                    self.jumped = True
                    raise ev.ReplayError(
                        f"the target coordinate jumps across {T:.6g} (from {g0 + T:.6g} to "
                        f"{g1 + T:.6g}) at servo position {q0:.6g}: a snap under this servo"
                    )
                p_new = q1 - g1 * (q1 - q0) / (g1 - g0)
            elif last is None and len(self.seen) > 2:  # first guess: quadratic through the
                p_new = _lagrange(self.seen[-3:], T)  # last three settled points
                p_new = p + float(np.clip(p_new - p, -cap, cap))
            else:
                p_new = p + float(np.clip(slope * (T - y), -cap, cap))
            s, chk = ramp_and_hold(run, p_new)
            y_new = float(self.sv.full_state(s.q, s.lam)[0][self.j])
            if abs(y_new - T) <= self.tol:
                if (y_new, p_new) != self.seen[-1]:
                    self.seen.append((y_new, p_new))
                return s, chk
            if y_new != y:
                slope = (p_new - p) / (y_new - y)
            side = y_new > T
            if last == side and (not side) in ends:  # same side twice: halve the other's g
                g, q = ends[not side]
                ends[not side] = (0.5 * g, q)
            ends[side], last, p, y = (y_new - T, p_new), side, p_new, y_new
        self.jumped = len(ends) == 2  # bracketed but not landed: a jump, or too slow
        raise ev.ReplayError(f"the servo did not bring the target to {T:.6g} (last {y:.6g})")


def _lagrange(pts: list[tuple[float, float]], y: float) -> float:
    """p(y) of the quadratic through three (y, p) points (distinct y)."""
    (y0, p0), (y1, p1), (y2, p2) = pts
    if len({y0, y1, y2}) < 3:
        return p2 + (p2 - p1) / (y2 - y1) * (y - y2) if y2 != y1 else p2
    return (
        p0 * (y - y1) * (y - y2) / ((y0 - y1) * (y0 - y2))
        + p1 * (y - y0) * (y - y2) / ((y1 - y0) * (y1 - y2))
        + p2 * (y - y0) * (y - y1) / ((y2 - y0) * (y2 - y1))
    )


def target(scene: Scene, full: object) -> tuple[tuple[int, float, float], np.ndarray] | str:
    """The servo's coordinate ``(i, c, off)`` and its report values, or why there is none."""
    a = scene.analysis
    if a.kind == "distance":
        func = full.driver_functional()
        values = np.linspace(a.driver.start, a.driver.stop, a.steps + 1)
        what = "the driver coordinate"
    else:
        try:
            func = full.output_functional(a.stop_output)
        except KeyError:
            return f"stop output {a.stop_output!r} is not a node coordinate"
        values = np.linspace(func[2], a.stop_value, a.steps + 1)
        what = f"the stop output {a.stop_output}"
    if func[0] < 0 or func[1] == 0.0:
        return f"{what} is fixed by a support: a servo cannot move it"
    if not np.any(full.external(np.zeros(full.ndof))):
        return "no load scaled by the load factor: nothing for the servo to set"
    return func, values


def applies(scene: Scene) -> str | None:
    """None if a distance/path analysis of ``scene`` can be replayed, else why not."""
    a = scene.analysis
    if a.kind == "path" and a.stop_output is None:
        return None  # load control to factor_end
    try:
        full = build(scene, 1)
    except Exception as err:  # noqa: BLE001 - any build failure is a reason, not a crash
        return f"not representable: {err}"
    got = target(scene, full)
    return got if isinstance(got, str) else None


def solve(scene: Scene, n_elements: int, options: object) -> Solution:
    """Replay the distance or path analysis of ``scene`` (module doc)."""
    from fem_reference.replay.run import replay_system

    a = scene.analysis
    full = build(scene, n_elements)
    if a.kind == "path" and a.stop_output is None:
        lams = np.linspace(0.0, a.factor_end, a.steps + 1)
        return replay_system(full, lams, scene=scene, case=scene.name, options=options)
    got = target(scene, full)
    if isinstance(got, str):
        return not_applicable(scene, "replay", got)
    func, values = got
    # mass damping (C = a0 M' keeps the servo slot free of inertia); the jump test weighs
    # dissipation against booked work, which misses the servo's: no jumps are assessed
    options = replace(options, damping="mass", jump_dissipation=math.inf)
    i = servo_dof(full, func[0])
    sol, system = _run(scene, full, i, func, values, options)
    note = ""
    if sol.status == "failed" and sol.extras.get("servo_jump") and i != func[0]:
        # the target jumps under the load point's servo (a snap of the target coordinate):
        # hold the target coordinate itself instead
        note = f"; servo on the target coordinate (on the load point: {sol.message})"
        i = func[0]
        sol, system = _run(scene, full, i, func, values, options)
    extras = dict(sol.extras)
    fr = dict(extras.get("frames", {}))
    if "q" in fr and len(fr["q"]):  # frames in FE coordinates (the animation rebuilds the FE)
        fr["q"] = np.array(fr["q"], dtype=float)
        fr["q"][:, i] = np.asarray(fr["factor"])
        extras["frames"] = fr
    extras["settle"] = {**extras.get("settle", {}), "energy_balance_error": math.nan}
    extras["settle"]["note"] = "servo-held coordinate: the servo's work is not booked"
    extras["jumps"], extras["jumps_note"] = [], "not assessed under a servo-held coordinate"
    extras["critical_points"] = []
    extras["servo"] = {"dof": i, "compliance_ell": system.ell}
    steps, msg = sol.steps, sol.message + note
    end = ""
    if a.kind == "path" and math.isfinite(a.factor_end) and steps:
        sgn, top = math.copysign(1.0, a.factor_end), abs(a.factor_end) * (1 + _Aim.END_RTOL)
        cut = next((k for k, st in enumerate(steps) if sgn * st.factor > top), None)
        if cut is not None:
            steps = steps[:cut]
            end = f"; path cut where the factor passes factor_end = {a.factor_end:g}"
        elif extras.get("reached_factor_end"):
            end = f"; path ends where the factor reaches factor_end = {a.factor_end:g}"
    if sol.status == "converged":
        res = max(st.info["residual"] for st in steps)
        msg = f"settled {len(steps)} servo-held states; max residual {res:.2e}{note}{end}"
        msg += finish_note(extras)
        if "stability" in extras:  # follower loads: no static verdict, said as load replays do
            msg += f"; {extras['stability']}"
    else:
        msg += end
    return post_process(scene, Solution(sol.case, sol.model, sol.status, msg, steps, extras))


def _run(scene: Scene, full: object, i: int, func: tuple, values: np.ndarray, options: object):
    """``replay_system`` with the servo on DOF ``i`` aiming the target ``func`` at ``values``;
    returns (solution, servo system); ``extras["servo_jump"]`` when the target jumped."""
    from fem_reference.replay.run import replay_system

    system = ServoSystem(full, i)
    stab = _probe_under_load(system, options, scene)
    a = scene.analysis
    end = a.factor_end if a.kind == "path" and math.isfinite(a.factor_end) else None
    aim = _Aim(system, func, aim_tolerance(values, func, options.settle_tol, full), end)
    sol = replay_system(
        system, values, scene=scene, case=scene.name, options=options, stability=stab, reach=aim
    )
    if aim.jumped:
        sol = replace(sol, extras={**sol.extras, "servo_jump": True})
    if aim.ended:
        sol = replace(sol, extras={**sol.extras, "reached_factor_end": True})
    return sol, system


def factor_mesh_error(scene: Scene, n: int) -> float | None:
    """Estimate (``richardson.gci``) of the n-element error of the last load factor (static FE
    on n and n // 2 elements), None if either fails."""
    from fem_reference.models import FEM

    if n < 2:
        return None
    a = scene.analysis
    if a.kind == "distance":
        a = dataclasses.replace(a, steps=max(1, min(a.steps, 4)))
    sc = dataclasses.replace(scene, analysis=a)
    runs = [FEM(m, stability=False, bifurcation=False).solve(sc) for m in (n // 2, n)]
    if any(r.status != "converged" or not r.steps for r in runs):
        return None
    return float(gci(runs[0].steps[-1].factor, runs[1].steps[-1].factor, n / (n // 2)))


def solve_checked(scene: Scene, n: int, options: object) -> Solution:
    """``solve`` with its mesh error against fem-auto stated (as load replays do)."""
    sol = solve(scene, n, options)
    if sol.status != "converged" or scene.analysis.kind != "distance" and not sol.steps:
        return sol
    if sol.extras.get("reached_factor_end"):  # the factor is factor_end: the outputs' error
        est = honest.mesh_error(scene, n, dict(sol.steps[-1].outputs))
        if est is None:
            return sol
        worst = honest.worst_mesh_error(est, float(build(scene, 1).length_scale()))
        msg = f"{sol.message}; mesh error vs fem-auto ~{worst:.1e} L (n = {n})"
        extras = {**sol.extras, "mesh_error_estimate": est, "mesh_error_worst": worst}
        return replace(sol, message=msg, extras=extras)
    err = factor_mesh_error(scene, n)
    if err is None:
        return sol
    scale = max(abs(st.factor) for st in sol.steps) or 1.0
    msg = f"{sol.message}; mesh error of the factor vs fem-auto ~{err / scale:.1e} (n = {n})"
    return replace(sol, message=msg, extras={**sol.extras, "mesh_error_factor": err})
