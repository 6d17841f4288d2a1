"""Several booms on the FE reference (``fem-N`` / ``fem-auto`` on ``deploy``, issue 25),
staged physically as in ``kinetostatic`` (``reduced_models/mechanism/deploy_staged.py``):
the unlocked boom with the least of its stroke left is driven (length held, multiplier = its
surplus), the other unlocked booms push freely, locked ones are bars; a free boom reaching
its length locks there (Brent on the driven length), the driven one locks at its length, the
last may stall (located where its surplus vanishes).  Newton on the bordered FE system
``r + sum_held (mu - F) G + sum_free (-F) G = 0``, held lengths fixed; the verdict is the
lowest eigenvalue of the tangent on the held constraints' null space.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.replay import events
from fem_reference.statics.deploy import MAX_ITER, DeployError, booms_as_locks, solve_deploy
from reduced_models.base import Solution, Step


class StagedFE:
    """Held / free / locked booms on one FE system."""

    def __init__(self, scene: Scene, n_elements: int) -> None:
        self.scene, self.sys = scene, build(scene, n_elements)
        self.pairs = events.resolve_locks(self.sys, scene, booms_as_locks(scene))
        self.push = np.array([b.force for b in scene.booms])
        self.target = np.array([b.length for b in scene.booms])
        self.locked = np.zeros(len(self.target), bool)
        self.fs = max(float(np.max(self.push)), float(self.sys.force_scale()))
        self.L = float(self.sys.length_scale())
        self.floor = max(1e-10 * self.fs, 10 * float(self.sys.residual_floor()))
        rot = np.asarray(getattr(self.sys, "is_rotation", np.zeros(self.sys.ndof, bool)), bool)
        self.cap = np.where(rot, 0.5, 0.25 * self.L)
        self.held: list[int] = list(range(len(self.target)))
        self.goal = np.zeros(len(self.target))  # held lengths (held order)
        self.steps: list[Step] = []
        self.order: list[str] = []

    def lengths(self, q: np.ndarray) -> np.ndarray:
        return np.array([p.geometry(q)[0] for p in self.pairs])

    def assemble(self, q: np.ndarray, mu: np.ndarray) -> tuple:
        """Residual, tangent (dense), held gradients (nh, ndof) and held gaps."""
        r, K = self.sys.residual_and_tangent(q, 0.0)
        R, W, Gh, c = np.array(r, float), K.toarray(), [], []
        push = np.where(self.locked, 0.0, self.push)
        for i, p in enumerate(self.pairs):
            ell, G, H = p.geometry(q)
            G = np.asarray(G).ravel()
            coef = (mu[self.held.index(i)] if i in self.held else 0.0) - push[i]
            R, W = R + coef * G, W + coef * H.toarray()
            if i in self.held:
                Gh.append(G)
                c.append(ell - self.goal[self.held.index(i)])
        return R, W, np.array(Gh).reshape(len(Gh), -1), np.array(c)

    def newton(self, q: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Equilibrium with the held lengths at ``goal`` (corrections capped, as FEDeploy;
        failing that, once more with caps 20 times smaller: a released boom's long run)."""
        try:
            return self._newton(q, mu, self.cap, MAX_ITER)
        except (DeployError, np.linalg.LinAlgError):
            return self._newton(q, mu, self.cap / 20, 20 * MAX_ITER)

    def _newton(self, q: np.ndarray, mu: np.ndarray, cap: np.ndarray, its: int) -> tuple:
        n, prev, step = self.sys.ndof, np.inf, np.inf
        for _ in range(its + 1):
            R, W, Gh, c = self.assemble(q, mu)
            res = float(np.max(np.abs(R)))
            floor = step <= 1e-13 * self.L or res > 0.5 * prev
            small = res <= 1e-10 * self.fs or (res <= self.floor and floor)
            if small and np.all(np.abs(c) <= 1e-13 * self.L):
                return q, mu
            prev, m = res, len(c)
            A = np.zeros((n + m, n + m))
            A[:n, :n], A[:n, n:], A[n:, :n] = W, Gh.T, Gh
            dx = np.linalg.solve(A, -np.append(R, c))
            dx *= 1.0 / max(1.0, float(np.max(np.abs(dx[:n]) / cap)))
            q, mu = q + dx[:n], mu + dx[n:]
            step = float(np.max(np.abs(dx[:n])))
        raise DeployError(f"Newton did not converge (residual {res:.2e})")

    def hold(self, idx: list[int], goal: np.ndarray, q: np.ndarray, mu: np.ndarray) -> tuple:
        """Hold booms ``idx`` at ``goal`` (multipliers carried over where held before)."""
        old = dict(zip(self.held, mu))
        self.held, self.goal = list(idx), np.asarray(goal, float)
        mu = np.array([old.get(i, self.push[i]) for i in self.held])
        return self.newton(q, mu)

    def release(self, q: np.ndarray, mu: np.ndarray, ell: np.ndarray, left: np.ndarray) -> tuple:
        """Drive the unlocked boom with the least stroke left, the others free; where Newton
        cannot follow that release (the free booms jump far), drive the next one."""
        held, goal, tried = list(self.held), self.goal.copy(), []
        for d in np.argsort(left)[: int(np.sum(~self.locked))]:
            idx = [int(d), *np.nonzero(self.locked)[0]]
            try:
                return (int(d), *self.hold(idx, np.r_[ell[d], self.target[self.locked]], q, mu))
            except (DeployError, np.linalg.LinAlgError) as err:
                self.held, self.goal = list(held), goal.copy()  # mu still belongs to these
                tried.append(f"{self.scene.booms[d].id}: {err}")
        # no free equilibrium near: a free boom whose push wins runs to its stop -- lock it
        surplus = dict(zip(self.held, mu))
        k = max((i for i in surplus if not self.locked[i]), key=surplus.get, default=None)
        if k is None or surplus[k] <= 0.0:
            raise DeployError(
                "staging: no boom can be driven with the others free: " + "; ".join(tried)
            )
        self.lock(k)
        return None, q, mu

    def drive(self, q: np.ndarray, mu: np.ndarray, a: float, b: float) -> tuple:
        """Driven boom (held row 0) from length ``a`` to ``b``, halving on failure."""
        t, h, cuts = 0.0, 1.0, 0
        while t < 1.0 - 1e-15:
            step = min(h, 1.0 - t)
            self.goal[0] = a + (t + step) * (b - a)
            try:
                (q, mu), t = self.newton(q, mu), t + step
            except (DeployError, np.linalg.LinAlgError):
                cuts += 1
                if cuts > 10:
                    raise
                h = step / 2
        return q, mu

    def surplus(self, mu: np.ndarray) -> float:
        """The driven boom's surplus (its multiplier, push minus resistance): > 0 while its
        push wins."""
        return float(mu[0])

    def record(self, q: np.ndarray, mu: np.ndarray, factor: float | None = None) -> None:
        ell = self.lengths(q)
        if factor is None:
            ell0 = self.lengths(np.zeros_like(q))
            factor = float(np.mean(np.clip((ell - ell0) / (self.target - ell0), 0.0, 1.0)))
        _, W, Gh, _ = self.assemble(q, mu)
        Z = sla.null_space(Gh) if Gh.shape[0] else np.eye(len(q))
        M = self.sys.mass().toarray()
        Kr, Mr = Z.T @ W @ Z, Z.T @ M @ Z
        eig = float(sla.eigh(0.5 * (Kr + Kr.T), Mr, eigvals_only=True, subset_by_index=[0, 0])[0])
        st = self.sys.step(q, factor, 0, bool(eig > 0))
        out = {**st.outputs, **{f"{b.id}.length": v for b, v in zip(self.scene.booms, ell)}}
        info = {"lowest_eigenvalue": eig, "tangent_stable": float(eig > 0)}
        self.steps.append(Step(st.factor, out, st.energy, 0, bool(eig > 0), st.shapes, None, info))

    def free_over(self, q: np.ndarray, free: np.ndarray) -> np.ndarray:
        return np.where(free, self.lengths(q) - self.target, -np.inf)

    def lock(self, k: int) -> None:
        self.locked[k] = True
        self.order.append(self.scene.booms[k].id)

    def run(self) -> tuple[str, bool]:
        """Staged Part 1 and Part 2; returns (message, every boom locked)."""
        n = self.scene.analysis.steps
        q = np.zeros(self.sys.ndof)
        ell0 = self.lengths(q)
        q, mu = self.hold(list(range(len(ell0))), ell0, q, self.push.copy())
        self.record(q, mu)
        while not self.locked.all():
            ell = self.lengths(q)
            left = np.where(self.locked, np.inf, (self.target - ell) / (self.target - ell0))
            d, q, mu = self.release(q, mu, ell, left)
            if d is None:  # a boom ran to its stop: lock it there and stage the rest
                continue
            free = ~self.locked
            free[d] = False
            if np.any(self.free_over(q, free) >= 0.0):
                self.lock(int(np.argmax(self.free_over(q, free))))
                continue
            a0, k_n = ell[d], max(1, int(np.ceil(n * max(left[d], 0.0))))
            for k in range(1, k_n + 1):
                a = a0 + (k - 1) / k_n * (self.target[d] - a0)
                b = a0 + k / k_n * (self.target[d] - a0)
                q1, mu1 = self.drive(q, mu, a, b)
                if self.surplus(mu1) <= 0.0:
                    if free.any():
                        raise DeployError(
                            f"boom {self.scene.booms[d].id!r} would stall while others are free"
                        )
                    return self.stall(q, mu, d, a, b), False
                if np.any(self.free_over(q1, free) >= 0.0):
                    q, mu = self.crossing(q, mu, a, b, free)
                    break
                q, mu = q1, mu1
                self.record(q, mu)
            else:
                self.lock(d)
        q, mu = self.hold(list(range(len(self.target))), self.target, q, mu)
        self.record(q, mu, 2.0)
        return (
            f"booms staged (order {', '.join(self.order)}); bar forces {np.round(mu, 6).tolist()}",
            True,
        )

    def crossing(
        self, q: np.ndarray, mu: np.ndarray, a: float, b: float, free: np.ndarray
    ) -> tuple:
        def g(x: float) -> float:
            return float(np.max(self.free_over(self.drive(q, mu, a, x)[0], free)))

        x = so.brentq(g, a, b, xtol=1e-13) if g(a) < 0.0 else a
        q, mu = self.drive(q, mu, a, x)
        self.record(q, mu)
        self.lock(int(np.argmax(self.free_over(q, free))))
        return q, mu

    def stall(self, q: np.ndarray, mu: np.ndarray, d: int, a: float, b: float) -> str:
        def g(x: float) -> float:
            return self.surplus(self.drive(q, mu, a, x)[1])

        x = so.brentq(g, a, b, xtol=1e-14) if g(a) > 0.0 else a
        q, mu = self.drive(q, mu, a, x)
        self.record(q, mu)
        ell = self.lengths(q)[d]
        return f"boom {self.scene.booms[d].id!r} stalled at length {ell:.6g} < {self.target[d]:g}"


def solve_staged(scene: Scene, name: str, n_elements: int) -> Solution:
    """Several booms, staged; the Solution as ``solve_deploy``'s."""
    run = StagedFE(scene, n_elements)
    try:
        msg, done = run.run()
    except (DeployError, np.linalg.LinAlgError, ValueError) as err:
        return Solution(scene.name, name, "failed", str(err), tuple(run.steps), {})
    extras = {"boom_reached": done, "boom_lock_order": run.order}
    return Solution(scene.name, name, "converged", msg, tuple(run.steps), extras)


def solve_any(scene: Scene, name: str, n_elements: int) -> Solution:
    """The FE deploy: one boom (``deploy.solve_deploy``) or several, staged."""
    if len(scene.booms) > 1 and all(b.stop == "lock" for b in scene.booms):
        return solve_staged(scene, name, n_elements)
    return solve_deploy(scene, name, n_elements)
