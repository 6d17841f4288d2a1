"""Tape-spring booms in the mechanism assembler and the two-phase ``deploy`` analysis.

A boom from node a to node b is, in the potential, a conservative constant push ``F``:
``Pi_boom = -F |x_b - x_a|`` (``BoomForceTerm``), and, where its length is held or locked, the
constraint ``|x_b - x_a| - ell = 0`` (``BoomLength``, target ``ell`` adjustable).

Part 1 (quasi-static, Newton at every report point, no pseudo-time increments): the boom's
length is the path parameter; at each ``ell`` from the drawn length to the deployed length
the rest of the mechanism is in equilibrium and the multiplier ``mu`` of the length
constraint is the boom's surplus: the stationarity ``grad(springs) - F grad(ell) + mu
grad(ell) = 0`` says the mechanism resists with ``P = F - mu``.  While ``mu > 0`` the push
wins and the boom extends; where ``mu`` reaches 0 first the boom stalls (the thesis's
Chapter 6 "insufficient force"): that point is located (Brent on ``ell``) and solved as the
free equilibrium with the push alone.

Part 2: at the deployed length the boom locks; the push is replaced by the bar force.  The
Part 1 end state is already an equilibrium of the locked mechanism (the multiplier takes the
push over), so Part 2 re-solves it with ``F = 0`` (Newton, one iteration) for the bar force
and the verdict: the reduced Hessian of the Lagrangian (springs + multipliers times the
curvature of every constraint, the boom's included) on the tangent space of the constraints.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so

from cases.schema import Scene
from reduced_models.base import Solution, not_applicable
from reduced_models.mechanism.analyses import Run
from reduced_models.mechanism.newton import SolveError, Solver, State
from reduced_models.mechanism.system import MechanismSystem


def _geometry(q: np.ndarray, dofs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Boom vectors d (B, 2), lengths (B,), unit vectors (B, 2)."""
    z = q[dofs]
    d = z[:, 2:] - z[:, :2]
    ell = np.hypot(d[:, 0], d[:, 1])
    return d, ell, d / ell[:, None]


def _length_derivs(ell: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gradient (B, 4) and Hessian (B, 4, 4) of |x_b - x_a| in (xa, ya, xb, yb)."""
    g = np.concatenate([-e, e], axis=1)
    P = (np.eye(2) - e[:, :, None] * e[:, None, :]) / ell[:, None, None]
    H = np.zeros((len(ell), 4, 4))
    H[:, :2, :2] = H[:, 2:, 2:] = P
    H[:, :2, 2:] = H[:, 2:, :2] = -P
    return g, H


class BoomForceTerm:
    """Constant pushes ``force`` (B,) along the booms: energy ``-sum F |x_b - x_a|``."""

    def __init__(self, dofs: np.ndarray, force: np.ndarray) -> None:
        self.dofs = np.asarray(dofs, np.int64)
        self.force = np.asarray(force, float)

    def energy(self, q: np.ndarray) -> float:
        _, ell, _ = _geometry(q, self.dofs)
        return float(-np.sum(self.force * ell))

    def local(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        _, ell, e = _geometry(q, self.dofs)
        g, H = _length_derivs(ell, e)
        return self.dofs, -self.force[:, None] * g, -self.force[:, None, None] * H


class BoomLength:
    """Constraints ``|x_b - x_a| - target = 0`` (one row per boom; ``target`` mutable)."""

    def __init__(self, dofs: np.ndarray, target: np.ndarray) -> None:
        self.dofs = np.asarray(dofs, np.int64)
        self.target = np.asarray(target, float).copy()
        self.m = len(self.dofs)

    def values(self, q: np.ndarray) -> np.ndarray:
        _, ell, _ = _geometry(q, self.dofs)
        return ell - self.target

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        _, ell, e = _geometry(q, self.dofs)
        g, _ = _length_derivs(ell, e)
        rows = np.repeat(np.arange(self.m), 4)
        return rows, self.dofs.ravel(), g.ravel()

    def curvature(self, q: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, ell, e = _geometry(q, self.dofs)
        _, H = _length_derivs(ell, e)
        return self.dofs, mu[:, None, None] * H


def add_booms(sysm: MechanismSystem, scene: Scene) -> tuple[BoomForceTerm, BoomLength]:
    """Append the push term and the (held) length constraints of ``scene.booms``.

    The length family goes in through ``hold`` (before the linear family, which stays last).
    """
    lay = sysm.lay
    dofs = np.array(
        [
            [lay.node_dof[b.a], lay.node_dof[b.a] + 1, lay.node_dof[b.b], lay.node_dof[b.b] + 1]
            for b in scene.booms
        ]
    )
    force = BoomForceTerm(dofs, np.array([b.force for b in scene.booms]))
    _, ell0, _ = _geometry(sysm.q0, dofs)
    length = BoomLength(dofs, ell0)
    sysm.terms.append(force)
    hold(sysm, length, True, float(np.max(force.force)))
    return force, length


def hold(sysm: MechanismSystem, length: BoomLength, on: bool, push: float) -> None:
    """Put the boom-length family in (``on``) or take it out of the system's constraints and
    re-``finish`` it (sizes, scatter maps; the linear family stays last), then scale the
    residual with the push as well (``finish`` sees only the scene's loads)."""
    keep = [c for c in sysm.constraints if c is not sysm.linear and c is not length]
    sysm.constraints = keep + ([length] if on else [])
    sysm.finish()
    sysm.fscale = max(sysm.fscale, push)
    kind = np.array(sysm.lay.kind)
    sysm.rscale = np.where(kind == "r", sysm.fscale * sysm.lay.Lref, sysm.fscale)


class NotStaged(Exception):
    """Several booms whose proportional Part 1 path is not physical (message = why)."""


class Deploy(Run):
    """Part 1 (boom length as path parameter, stall located) then Part 2 (locked)."""

    def __init__(self, sysm: MechanismSystem) -> None:
        self.force, self.length = add_booms(sysm, sysm.scene)
        super().__init__(sysm)
        self.solver = Solver(sysm)
        self.row = sum(c.m for c in sysm.constraints[: sysm.constraints.index(self.length)])
        self.ell0 = self.length.target.copy()
        self.ids = [b.id for b in sysm.scene.booms]

    def record(
        self, st: State, factor: float, hold_driver: bool, extra: dict | None = None
    ) -> None:
        """As ``Run.record``, plus ``info["reduced_hessian_min"]``: the lowest eigenvalue of
        the reduced Hessian Z' W Z (N m; Z an orthonormal basis of the constraints' tangent
        space in coordinates scaled to length Lref and radians) -- the stability margin the
        report maps."""
        super().record(st, factor, hold_driver, extra)
        s = self.s
        _, W, _, J = s.reduced(st.q, st.lam, st.mu)
        kind = np.array(s.lay.kind)[s.free]
        d = np.where(kind == "r", 1.0, s.lay.Lref)
        Z = sla.null_space(J * d[None, :]) if J.shape[0] else np.eye(len(d))
        low = float(np.linalg.eigvalsh(Z.T @ (d[:, None] * W * d[None, :]) @ Z)[0])
        last = self.steps[-1]
        self.steps[-1] = replace(last, info={**last.info, "reduced_hessian_min": low})

    def at(self, st: State, ell: np.ndarray) -> State:
        """Equilibrium with the boom lengths held at ``ell`` (Newton from ``st``)."""
        self.length.target = np.asarray(ell, float)
        return self.solver.newton(st)

    def surplus(self, st: State) -> np.ndarray:
        """Boom multipliers: push minus the mechanism's resistance (> 0: the boom extends)."""
        return st.mu[self.row : self.row + self.length.m]

    def lengths(self, st: State) -> dict[str, float]:
        _, ell, _ = _geometry(st.q, self.length.dofs)
        return {f"{i}.length": float(v) for i, v in zip(self.ids, ell)}

    def follow(self, st: State, ell_a: np.ndarray, ell_b: np.ndarray) -> State:
        """From ``st`` (at ``ell_a``) to ``ell_b`` with step halving on Newton failure."""
        t, h, cuts = 0.0, 1.0, 0
        while t < 1.0 - 1e-15:
            step = min(h, 1.0 - t)
            try:
                new = self.at(st, ell_a + (t + step) * (ell_b - ell_a))
            except SolveError:
                cuts += 1
                if cuts > 12:
                    raise
                h = step / 2
                continue
            st, t = new, t + step
            h = min(1.0, 2 * step) if new.iterations <= 4 else step
        return st

    def run_deploy(self) -> str:
        """Both parts; returns the message (raises SolveError on a numerical failure)."""
        target = np.array([b.length for b in self.scene.booms])
        n = self.scene.analysis.steps
        st = self.at(self.zero(), self.ell0)
        path = [(0.0, st)]
        for k in range(1, n + 1):
            ell_prev = self.ell0 + (k - 1) / n * (target - self.ell0)
            ell = self.ell0 + k / n * (target - self.ell0)
            new = self.follow(st, ell_prev, ell)
            if np.any(self.surplus(new) <= 0.0):
                return self.stall(path, st, ell_prev, ell)
            st = new
            path.append((k / n, st))
        for f, s in path:
            self.record(s, f, True, self.lengths(s))
        self.force.force = np.zeros_like(self.force.force)  # Part 2: the bar replaces the push
        locked = self.solver.newton(st)
        self.record(locked, 2.0, True, self.lengths(locked))
        bar = self.surplus(locked)
        self.extras["boom_bar_force"] = bar.tolist()
        self.extras["boom_reached"] = True
        return f"booms locked at {target.tolist()}; bar forces {np.round(bar, 6).tolist()}"

    def stall(self, path: list, st: State, ell_a: np.ndarray, ell_b: np.ndarray) -> str:
        """Locate where the surplus first vanishes, then solve the free equilibrium there."""
        if len(ell_a) != 1:
            low = self.surplus(self.follow(st, ell_a, ell_b))
            k = int(np.argmin(low))
            raise NotStaged(
                f"several booms: the one-parameter Part 1 path (lengths held proportionally) "
                f"would pull boom {self.ids[k]!r} (surplus {low[k]:.4g} at length "
                f"{ell_b[k]:.6g}); staging several booms (each pushing until it locks at its "
                "own length) is not implemented here: the replay does it"
            )
        base = st

        def g(s: float) -> float:
            return float(self.surplus(self.follow(base, ell_a, ell_a + s * (ell_b - ell_a)))[0])

        s_star = so.brentq(g, 0.0, 1.0, xtol=1e-13) if g(0.0) > 0 else 0.0
        held = self.follow(base, ell_a, ell_a + s_star * (ell_b - ell_a))
        for f, s in path:
            self.record(s, f, True, self.lengths(s))
        L = self.release(held)
        self.extras["boom_reached"] = False
        return f"boom {self.ids[0]!r} stalled at length {L:.6g} < {self.scene.booms[0].length:g}"

    def release(self, held: State) -> float:
        """Solve and record the free equilibrium (push only, no length constraint) from a
        held state; returns the stalled length."""
        s = self.s
        push = float(np.max(self.force.force))
        hold(s, self.length, False, push)
        mu = np.delete(held.mu, np.s_[self.row : self.row + self.length.m])
        solver = self.solver
        try:
            self.solver = Solver(s)
            free = self.solver.newton(State(held.q, mu, held.lam))
            ell = self.lengths(free)
            L = ell[f"{self.ids[0]}.length"]
            prog = (L - self.ell0[0]) / (self.scene.booms[0].length - self.ell0[0])
            self.record(free, float(prog), True, ell)
        finally:
            hold(s, self.length, True, push)
            self.solver = solver
        return L


def deploy(sysm: MechanismSystem, name: str, staged: object = None) -> Solution:
    """The ``deploy`` analysis as a Solution (numerical trouble -> ``failed``); ``staged``:
    the class that runs Part 1 instead of ``Deploy.run_deploy``."""
    scene = sysm.scene
    if any(b.stop != "lock" for b in scene.booms):
        why = "a collision-damper boom stop is dynamic: only replay models it"
        return not_applicable(scene, name, why)
    r = Deploy(sysm)
    try:  # several booms: ``staged`` (deploy_staged.Staged) stages them physically
        msg = r.run_deploy() if staged is None else staged(r).run()
    except NotStaged as why:
        return not_applicable(scene, name, str(why))
    except (SolveError, ValueError, np.linalg.LinAlgError) as err:
        return Solution(scene.name, name, "failed", str(err), tuple(r.steps), r.extras)
    return Solution(scene.name, name, "converged", msg, tuple(r.steps), r.extras)
