"""Analyses on an assembled mechanism: load, distance, energy, kinematics (and the steps).

* ``load``: load factor 0 -> factor_end at the scene's steps (continuation with cuts); a step
  that loses stability or stalls is taken again with every substep kept on the stable branch
  (``Run._stable_step``); one that still cannot be followed stably passes a limit or
  bifurcation point and jumps to the stable state at its factor (``snap``), reported in
  ``extras["critical_points"]`` and marked ``info["snap"] = 1``.
* ``distance``: the driver coordinate is a target; the load factor is the unknown
  (``Step.factor`` = load factor), DAS-2D "Distance analysis".
* ``energy``: scene loads held at factor_end, the driver prescribed from start to stop;
  ``Step.factor`` = driver coordinate (degrees for a rotation), outputs ``driver.force`` /
  ``driver.torque`` = the force the driver exerts along +coordinate; ``extras["equilibria"]``
  lists where it crosses zero (stable: energy minimum along the driver) and ``barrier``; a
  sweep stopped by a dead point or lock-up keeps those of the part swept (``stopped_at``).
* ``path``: arc-length continuation (``pathfollow``), ``Step.factor`` = load factor.
* ``kinematics``: constraints only (no flexible members): position analysis along the
  driver, Gauss-Newton with minimum-norm steps; mobility checked.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import null_space

from reduced_models.base import Step, load_factors
from reduced_models.mechanism.newton import SolveError, Solver, State, follow
from reduced_models.mechanism.snap import jumped, snap_step
from reduced_models.mechanism.system import MechanismSystem

# |driving force| / max(its largest magnitude, the force scale) below which it is zero:
# on a grid point (round-off: a tolerance there would pin an equilibrium to the grid), and
# where the refinement between grid points stops
GRID_ZERO, ZERO_FORCE = 1e-12, 1e-9

# a driven path from a drawn state whose tangent is singular (no stability verdict there)
# that lands on an unstable equilibrium at once has been put on a branch by round-off: linear-8
# on DAS-2D Ex. 3 (straight inextensible segments cannot shorten at first order) started at a
# driving force of 8.5 or 1.6 N depending on how the scene was drawn, the elastica at 0.15 N
SINGULAR_START = (
    "the driven path leaves the drawn state, where the model's tangent is singular (no "
    "stability verdict), onto an unstable equilibrium: a branch picked by round-off, not the "
    "path the driver moves the mechanism along"
)


class Run:
    """One analysis on one system; collects steps and extras."""

    def __init__(self, sysm: MechanismSystem, solver_opts: dict | None = None) -> None:
        self.s = sysm
        self.solver = Solver(sysm, **(solver_opts or {}))
        self.scene = sysm.scene
        self.steps: list[Step] = []
        self.states: list[State] = []
        self.extras: dict = {"ndof": int(len(sysm.free)), "constraints": int(sysm.m)}
        self.lazy = False  # shapes and stress left to the model's postprocess (``model``)

    # -- helpers -------------------------------------------------------------------------------
    def zero(self, lam: float = 0.0) -> State:
        return State(self.s.q0.copy(), np.zeros(self.s.m), lam)

    def record(
        self, st: State, factor: float, hold_driver: bool, extra: dict | None = None
    ) -> None:
        s = self.s
        stable, low = self.solver.stable(st, hold_driver)
        out = s.outputs(st.q)
        out.update(extra or {})
        self.states.append(st)
        self.steps.append(
            Step(
                factor=float(factor),
                outputs=out,
                energy=s.strain_energy(st.q),
                iterations=int(st.iterations),
                stable=stable,
                shapes={} if self.lazy else s.shapes(st.q),
                max_stress=None if self.lazy else s.max_stress(st.q),
                info={"residual": float(st.residual), "min_pivot": low, "load_factor": st.lam},
            )
        )

    def add_driver(self) -> tuple[int, float, float]:
        """Append the driver row; returns (row, base value, unit scale)."""
        s, drv = self.s, self.scene.analysis.driver
        i = s.driver_dof
        base = float(s.q0[i]) if drv.kind == "displacement" else 0.0
        s.driver_row = s.linear.add([i], [1.0], base, "driver")
        sv = self.solver
        self.solver = Solver(s, sv.tol, sv.max_iter, sv.sparse)
        return s.driver_row, base, s.driver_scale

    def set_driver(self, row: int, base: float, scale: float) -> Callable:
        lin = self.s.linear

        def apply(st: State, t: float) -> State:
            lin.b[row] = base + t * scale
            return st

        return apply

    # -- analyses ------------------------------------------------------------------------------
    def load(self) -> None:
        st = self.solver.newton(self.zero())
        self.record(st, 0.0, False)
        f = load_factors(self.scene)

        def set_lam(x: State, t: float) -> State:
            x.lam = t
            return x

        points = self.extras.setdefault("critical_points", [])
        for prev, fk in zip(f[:-1], f[1:]):
            # a state settled at round-off above Newton's tolerance (``snap._locate``): Newton
            # cannot follow from it, neither in one step nor in substeps
            stuck = st.residual > self.solver.tol
            try:
                if stuck:
                    raise SolveError("Newton cannot follow from a state above its tolerance")
                new = follow(self.solver, st, float(prev), float(fk), set_lam, "lam")
                new.lam = float(fk)
                lost = self.steps[-1].stable and (
                    self.solver.stable(new, False)[0] is not True
                    or jumped(self, st, new, float(fk - prev))
                )
            except SolveError:
                new, lost = None, self.steps[-1].stable
            if lost and not stuck:  # the step again, every substep kept on the stable branch
                new, lost = self._stable_step(st, float(prev), float(fk), set_lam)
            found = []
            if lost:  # a limit or bifurcation point inside the step: jump (``snap``)
                new, found = snap_step(self, st, float(prev), float(fk))
                points.extend(found)
            elif new is None and len(self.steps) == 1:
                # the unloaded state has no positive-definite stiffness: a mechanism (e.g. a
                # beam pinned at its root swings under any load) has no static load path
                raise SolveError(
                    "the unloaded structure is a mechanism (no stable stiffness at factor 0,"
                    " e.g. a pinned root lets the beam swing): no static load path from it"
                )
            elif new is None:
                raise SolveError(f"load step to factor {fk:.6g} failed from an unstable state")
            st = new
            self.record(st, fk, False)
            if found:  # as fem-auto marks a state beyond a limit point
                self.steps[-1].info["snap"] = 1.0

    def _stable_step(
        self, st: State, lam0: float, lam1: float, set_lam: Callable
    ) -> tuple[State | None, bool]:
        """(state at ``lam1``, False) by load control from the stable ``st`` with every
        substep refused (and cut) that ends unstable or ``jumped``; (None, True) where no
        stable path reaches ``lam1`` (a limit or bifurcation point inside the step).

        A whole load step that lands unstable, jumps or fails may only have been too long
        for a steep, strongly curved stretch of a smooth path (a weakly held pin swinging
        round): whether Newton then landed on the complementary branch is round-off, and
        with it the snap a report would give.  Refined this way, only a path that cannot be
        followed stably at any step down to the cut limit is handed to ``snap_step``."""
        sv = self.solver

        def keep(a: State, b: State, dt: float) -> bool:
            b.lam = a.lam + dt
            return sv.stable(b, False)[0] is True and not jumped(self, a, b, dt)

        try:
            new = follow(sv, st, lam0, lam1, set_lam, "lam", max_cuts=16, accept=keep)
        except SolveError:
            return None, True
        new.lam = lam1
        return new, False

    def driver(self, kind: str) -> None:
        a = self.scene.analysis
        lam_free = kind == "distance"
        lam = 0.0 if lam_free else a.factor_end
        if why := stalled_driver(self.s):
            raise SolveError(why)
        row, base, scale = self.add_driver()
        apply = self.set_driver(row, base, scale)
        vals = np.linspace(a.driver.start, a.driver.stop, a.steps + 1)
        st = self.zero(lam)
        apply(st, float(vals[0]))
        st = self.solver.newton(st, lam_free)
        key = "driver.torque" if a.driver.kind == "rotation" else "driver.force"
        d = self.solver.driver_index()
        for k, v in enumerate(vals):
            if k:
                t0 = float(vals[k - 1])
                try:
                    st = follow(
                        self.solver, st, t0, float(v), apply, "driver", lam_free, rate=scale
                    )
                except SolveError:
                    if kind == "energy" and k > 1:  # the equilibria of the part swept
                        self.extras["stopped_at"] = t0
                        self.equilibria(vals[:k], key, apply)
                    raise
            if lam_free:
                self.record(st, st.lam, False)
                if k == 1 and self.steps[0].stable is None and self.steps[1].stable is False:
                    raise SolveError(SINGULAR_START)
            else:
                self.record(st, v, True, {key: float(-st.mu[d])})
        if kind == "energy":
            self.equilibria(vals, key, apply)

    def equilibria(self, vals: np.ndarray, key: str, apply: Callable) -> None:
        """Zero crossings of the driving force, refined to F = 0 by regula falsi on the
        driver coordinate; the verdict is the reduced Hessian with the driver released
        (the slope of F along the driver where that is singular)."""
        F = np.array([s.outputs[key] for s in self.steps])
        # a force at round-off on a grid point is a zero there (an unstressed drawing's start:
        # exactly 0 or 1e-17, depending on the last Newton update), counted once
        zero = np.abs(F) <= GRID_ZERO * max(float(np.abs(F).max()), self.s.fscale)
        eq = []
        for k in range(len(F) - 1):
            f0, f1 = F[k], F[k + 1]
            if not (zero[k] or (f0 * f1 < 0.0 and not zero[k + 1])):
                continue
            rising = (f1 - f0) * (vals[k + 1] - vals[k]) > 0
            st, v = self._zero_force(k, vals, F, apply)
            stable, _ = self.solver.stable(st, False)
            if stable is None:
                stable = bool(rising)
            eq.append(
                {
                    "coordinate": float(v),
                    "kind": "stable" if stable else "unstable",
                    "energy": self.s.strain_energy(st.q),
                    "outputs": self.s.outputs(st.q),
                }
            )
        self.extras["equilibria"] = eq
        stab = [e for e in eq if e["kind"] == "stable"]
        sign = np.sign(vals[-1] - vals[0])
        after = [
            e
            for e in eq
            if stab
            and e["kind"] == "unstable"
            and (e["coordinate"] - stab[0]["coordinate"]) * sign > 0
        ]
        if after:
            self.extras["barrier"] = after[0]["energy"] - stab[0]["energy"]

    def _zero_force(self, k: int, vals: np.ndarray, F: np.ndarray, apply: Callable):
        """(state, coordinate) where the driving force vanishes between steps k and k + 1."""
        d = self.solver.driver_index()
        a, b, fa, fb = float(vals[k]), float(vals[k + 1]), float(F[k]), float(F[k + 1])
        sa, sb = self.states[k], self.states[k + 1]
        if abs(fa) <= GRID_ZERO * max(abs(F).max(), self.s.fscale):  # see ``equilibria``
            return sa, a
        tol = ZERO_FORCE * max(abs(F).max(), self.s.fscale)
        side = 0
        st, v = sa, a
        for _ in range(40):
            v = (a * fb - b * fa) / (fb - fa)
            w = (v - a) / (b - a)
            guess = State(sa.q + w * (sb.q - sa.q), sa.mu + w * (sb.mu - sa.mu), sa.lam)
            st = self.solver.newton(apply(guess, v))
            f = -float(st.mu[d])
            if abs(f) <= tol:
                break
            if f * fb > 0:  # Illinois: halve the stale end's value
                b, fb, sb = v, f, st
                fa = fa / 2 if side == -1 else fa
                side = -1
            else:
                a, fa, sa = v, f, st
                fb = fb / 2 if side == 1 else fb
                side = 1
        apply(st, float(vals[-1]))  # leave the driver row where the sweep ended
        return st, v

    def kinematics(self) -> None:
        """Position analysis along the driver (Gauss-Newton, minimum-norm steps)."""
        a = self.scene.analysis
        s = self.s
        m0 = s.m
        c, J = s.cons(s.q0)
        nf = len(s.free)
        rank = int(np.linalg.matrix_rank(J[:, s.free])) if m0 else 0
        self.extras["mobility"] = nf - m0
        self.extras["mobility_rank"] = nf - rank
        if a.mobility is not None and a.mobility != nf - rank:
            raise SolveError(
                f"mobility {nf - rank} (Gruebler count {nf - m0}) differs from the "
                f"expected {a.mobility}"
            )
        if why := stalled_driver(self.s):
            raise SolveError(why)
        row, base, scale = self.add_driver()
        apply = self.set_driver(row, base, scale)
        vals = np.linspace(a.driver.start, a.driver.stop, a.steps + 1)
        q = s.q0.copy()
        reached = []
        for v in vals:
            apply(None, float(v))
            q, its, res = self.position(q)
            st = State(q, np.zeros(s.m), 0.0, its, res)
            self.states.append(st)
            self.steps.append(
                Step(
                    factor=float(v),
                    outputs=s.outputs(q),
                    energy=s.strain_energy(q),
                    iterations=its,
                    shapes=s.shapes(q),
                    info={"residual": res},
                )
            )
            reached.append(float(v))
            self.extras["range"] = [reached[0], reached[-1]]

    def position(self, q: np.ndarray) -> tuple[np.ndarray, int, float]:
        s, f = self.s, self.s.free
        cs = s.cscale()
        for it in range(60):
            c, J = s.cons(q)
            res = float(np.max(np.abs(c) / cs, initial=0.0))
            if res <= 1e-14:
                return q, it, res
            dq = np.linalg.lstsq(J[:, f], -c, rcond=None)[0]
            big = float(np.max(np.abs(dq)) / (0.25 * s.lay.Lref))
            q = q.copy()
            q[f] += dq / max(big, 1.0)
        if res <= 1e-12:
            return q, it, res
        raise SolveError(
            f"kinematic lock or dead point: constraints not closed (residual {res:.1e})"
        )


def stalled_driver(s: MechanismSystem, tol: float = 1e-8) -> str | None:
    """Why the driver cannot move from the drawn position (None when it can).

    Every motion the closures admit (rigid links, inextensible members, supports) leaves the
    driver's coordinate stationary to first order there -- a crank tip driven along the
    crank, a shuttle pushed against straight inextensible legs: prescribing it picks one of
    the branches that meet there (the crank turning either way, the legs kinking up or down)
    by round-off, so the drawing's orientation would decide the answer.  Judged on the
    closure Jacobian at ``q0`` (free columns, rotations scaled by Lref to lengths, before the
    driver row is added): the driver's unit vector lies within ``tol`` of the rows' span when
    its projection onto their null space (the admissible motions) is shorter than ``tol``."""
    _, J = s.cons(s.q0)
    cols = s.free
    scale = np.where(np.array(s.lay.kind)[cols] == "r", s.lay.Lref, 1.0)
    A = J[:, cols] / scale
    N = null_space(A, rcond=tol) if A.size else np.eye(len(cols))
    if np.linalg.norm(N[list(cols).index(s.driver_dof)]) >= tol:
        return None
    return (
        "the driver cannot move from the drawn position: every motion the links, inextensible "
        "members and supports admit leaves its coordinate stationary to first order (a "
        "kinematic singularity), so which branch it drives is not determined there"
    )


def run(sysm: MechanismSystem, kind: str, lazy: bool = False) -> Run:
    """Run the analysis ``kind`` on ``sysm``; a numerical failure is kept in ``.exc`` (steps
    so far in ``.steps``).  ``lazy``: steps without shapes and stress (``Run.lazy``)."""
    r = Run(sysm)
    r.exc = None
    r.lazy = lazy
    try:
        if kind == "load":
            r.load()
        elif kind in ("distance", "energy"):
            r.driver(kind)
        elif kind == "kinematics":
            r.kinematics()
        elif kind == "path":
            from reduced_models.mechanism.pathfollow import run_path

            run_path(r)
        else:
            raise ValueError(kind)
    except (SolveError, np.linalg.LinAlgError, FloatingPointError) as err:
        r.exc = f"{type(err).__name__}: {err}" if not isinstance(err, SolveError) else str(err)
    return r


__all__ = ["Run", "run"]
