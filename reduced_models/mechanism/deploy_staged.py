"""Several booms deployed physically in ``kinetostatic`` (issue 25): each boom pushes until it
reaches its own length, then locks.

Quasi-statically one boom at a time is the path parameter: the unlocked boom with the least
of its stroke left is *driven* (its length held and stepped towards its deployed length, its
multiplier the surplus of its push), the other unlocked booms are *free* (their push alone;
their lengths follow from equilibrium) and the locked ones are bars.  A free boom that reaches
its length locks there (the crossing located by Brent on the driven length); the driven boom
locks at its length; then the next unlocked boom is driven.  A driven boom whose surplus
vanishes would stall: not staged here (message says so).  Part 2: every boom locked, pushes
off (the bar forces are the multipliers).
"""

from __future__ import annotations

import numpy as np
import scipy.optimize as so

from reduced_models.base import Solution
from reduced_models.mechanism.deploy import BoomLength, NotStaged, _geometry, deploy, hold
from reduced_models.mechanism.newton import SolveError, Solver, State


class Staged:
    """Staged Part 1 and Part 2 on a ``deploy.Deploy`` run (its system, booms, records)."""

    def __init__(self, run: object) -> None:
        self.r = run
        self.dofs = run.length.dofs.copy()
        self.push = run.force.force.copy()
        self.target = np.array([b.length for b in run.scene.booms])
        self.locked = np.zeros(len(self.target), bool)
        self.order: list[str] = []  # lock order (boom ids)

    def lock(self, k: int) -> None:
        self.locked[k] = True
        self.order.append(self.r.ids[k])

    def lengths(self, q: np.ndarray) -> np.ndarray:
        return _geometry(q, self.dofs)[1]

    def release(self, st: State, ell: np.ndarray, left: np.ndarray) -> tuple[int, State]:
        """Drive the unlocked boom with the least stroke left and free the others; where
        Newton cannot follow that release (the free booms jump far), drive the next one."""
        tried = []
        # a tie (at the start every boom has its whole stroke left) goes to the boom listed
        # first, not to the round-off of the units, frame or node numbering
        for d in np.argsort(np.round(left, 12), kind="stable")[: int(np.sum(~self.locked))]:
            idx = [int(d), *np.nonzero(self.locked)[0]]
            try:
                return int(d), self.held(idx, np.r_[ell[d], self.target[self.locked]], st)
            except SolveError as err:
                tried.append(f"{self.r.ids[d]}: {err}")
        raise SolveError(
            "staging: no boom can be driven with the others free (" + "; ".join(tried) + ")"
        )

    def held(self, idx: list[int], ell: np.ndarray, st: State) -> State:
        """Hold booms ``idx`` at lengths ``ell`` (the others free); re-solve from ``st``."""
        r = self.r
        old, new = r.length, BoomLength(self.dofs[idx], ell)
        top = float(np.max(self.push))
        hold(r.s, old, False, top)
        hold(r.s, new, True, top)
        r.length, r.solver = new, Solver(r.s)
        m_st = len(st.mu) - (r.s.m - new.m)  # boom rows of st (the other families are fixed)
        mu = np.concatenate([st.mu[: r.row], np.zeros(new.m), st.mu[r.row + m_st :]])
        self.r.force.force = np.where(self.locked, 0.0, self.push)
        return r.solver.newton(State(st.q, mu, st.lam))

    def record(self, st: State) -> None:
        ell = self.lengths(st.q)
        prog = np.clip((ell - self.r.ell0) / (self.target - self.r.ell0), 0.0, 1.0)
        extra = {f"{i}.length": float(v) for i, v in zip(self.r.ids, ell)}
        self.r.record(st, float(np.mean(prog)), True, extra)

    def drive(self, st: State, d: int, a: float, b: float) -> State:
        """The driven boom (row 0 of the held family) from length ``a`` to ``b``."""
        t, h, cuts = 0.0, 1.0, 0
        while t < 1.0 - 1e-15:
            step = min(h, 1.0 - t)
            self.r.length.target[0] = a + (t + step) * (b - a)
            try:
                st, t = self.r.solver.newton(st), t + step
            except SolveError:
                cuts += 1
                if cuts > 12:
                    raise
                h = step / 2
        return st

    def over(self, st: State, free: np.ndarray) -> np.ndarray:
        """Free booms' lengths past their deployed lengths (> 0: crossed)."""
        return np.where(free, self.lengths(st.q) - self.target, -np.inf)

    def run(self) -> str:
        """Part 1 staged, Part 2 locked; returns the message."""
        r, n = self.r, int(self.r.scene.analysis.steps)
        st = r.at(r.zero(), r.ell0)
        self.record(st)
        while not self.locked.all():
            ell = self.lengths(st.q)
            left = np.where(self.locked, np.inf, (self.target - ell) / (self.target - r.ell0))
            d, st = self.release(st, ell, left)
            free = ~self.locked
            free[d] = False
            if np.any(self.over(st, free) >= 0.0):  # released, a free boom ran to its stop
                self.lock(int(np.argmax(self.over(st, free))))
                continue
            # the stroke left is 1 at the start only to the round-off of the lengths: ceil
            # must not make 20 + 4e-15 steps 21 (the path sampled by the encoding)
            a0, k_steps = ell[d], max(1, int(np.ceil(n * max(left[d], 0.0) - 1e-9)))
            for k in range(1, k_steps + 1):
                a, b = (
                    a0 + (k - 1) / k_steps * (self.target[d] - a0),
                    a0 + k / k_steps * (self.target[d] - a0),
                )
                new = self.drive(st, d, a, b)
                if r.surplus(new)[0] <= 0.0 and free.any():
                    raise NotStaged(
                        f"boom {r.ids[d]!r} would stall (surplus {r.surplus(new)[0]:.4g} at "
                        f"{b:.6g}) while staging; a stalled boom among several is not staged "
                        "here: the replay does it"
                    )
                if r.surplus(new)[0] <= 0.0:  # the last boom stalls: the others are bars
                    return self.stall(st, d, a, b)
                if np.any(self.over(new, free) >= 0.0):  # a free boom reaches its length
                    st = self.crossing(st, d, a, b, free)
                    break
                st = new
                self.record(st)
            else:
                self.lock(d)
        r.force.force = np.zeros_like(self.push)  # Part 2: the bars replace the pushes
        st = self.held(list(range(len(self.target))), self.target.copy(), st)
        r.record(
            st, 2.0, True, {f"{i}.length": float(v) for i, v in zip(r.ids, self.lengths(st.q))}
        )
        bar = r.surplus(st)
        r.extras["boom_bar_force"] = bar.tolist()
        r.extras["boom_reached"] = True
        r.extras["boom_lock_order"] = self.order
        return (
            f"booms staged (each locks at its own length; order {', '.join(self.order)}); bar "
            f"forces {np.round(bar, 6).tolist()}"
        )

    def stall(self, st: State, d: int, a: float, b: float) -> str:
        """Where the last unlocked boom's surplus vanishes (Brent on its length): held there
        with zero surplus, the state is the free equilibrium under its push alone."""
        base = st

        def g(x: float) -> float:
            return float(self.r.surplus(self.drive(base, d, a, x))[0])

        x = so.brentq(g, a, b, xtol=1e-14) if g(a) > 0.0 else a
        st = self.drive(base, d, a, x)
        self.record(st)
        self.r.extras["boom_reached"] = False
        self.r.extras["boom_lock_order"] = self.order
        ell = self.lengths(st.q)[d]
        done = ", ".join(self.order)
        short = f"{ell:.6g} < {self.target[d]:g}"
        return f"boom {self.r.ids[d]!r} stalled at length {short} (locked: {done})"

    def crossing(self, st: State, d: int, a: float, b: float, free: np.ndarray) -> State:
        """Where the first free boom reaches its length (Brent on the driven length); it
        locks there."""
        base = st

        def g(x: float) -> float:
            return float(np.max(self.over(self.drive(base, d, a, x), free)))

        x = so.brentq(g, a, b, xtol=1e-13) if g(a) < 0.0 else a
        st = self.drive(base, d, a, x)
        self.record(st)
        self.lock(int(np.argmax(self.over(st, free))))
        return st


def deploy_any(sysm: object, name: str) -> Solution:
    """``kinetostatic``'s deploy: one boom (``deploy.deploy``) or several, staged."""
    return deploy(sysm, name, Staged if len(sysm.scene.booms) > 1 else None)
