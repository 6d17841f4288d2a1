"""Two-phase boom deployment on the FE reference (``fem-N`` / ``fem-auto`` on ``deploy``).

The scene's ``[[booms]]`` become ``replay.events.LengthLock`` pairs on the FE DOFs (distance
``ell(q)``, gradient ``G``, Hessian ``H``).  Phase 1: the boom is a constant push ``F`` along
its line (potential ``-F ell``), its length the path parameter: at each report length the FE
system is solved with ``ell`` held by a multiplier ``mu`` (bordered Newton on
``r(q) + (mu - F) G = 0``, ``ell(q) = ell_k``); ``mu > 0`` means the push still wins.  Where
``mu`` first reaches 0 the boom stalls: located by Brent and solved free (push only).
Phase 2: at the deployed length the boom locks into a member (``F = 0``, ``mu`` = its bar
force).  Stability: the lowest eigenvalue of the tangent ``K + (mu - F) H`` on the null space
of ``G`` (the constrained FE tangent test).  Rigid links are the FE's stiff elements
(compliance ~1e-6 of the scene's stiffness), so positions agree with the rigid-link answer to
about that relative level.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.optimize as so

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.replay import events
from fem_reference.statics.deploy_stiffness import joint_compliance
from reduced_models.base import Solution, Step

MAX_ITER = 30


class DeployError(RuntimeError):
    """Newton failed in the deploy analysis (message = why)."""


def booms_as_locks(scene: Scene) -> tuple[events.LengthLock, ...]:
    """The scene's booms as the replay's length-lock events (one contract for both)."""
    return tuple(
        events.LengthLock(b.a, b.b, b.length, b.force, b.stop_stiffness) for b in scene.booms
    )


class FEDeploy:
    """Held-length, free and locked equilibria of one FE system with one boom."""

    def __init__(self, system: object, scene: Scene) -> None:
        self.sys, self.scene = system, scene
        self.pair = events.resolve_locks(system, scene, booms_as_locks(scene))[0]
        self.F = scene.booms[0].force
        self.fs = max(self.F, float(system.force_scale()))
        self.tol = max(1e-10 * self.fs, 10 * float(system.residual_floor()))
        self.L = float(system.length_scale())
        rot = np.asarray(getattr(system, "is_rotation", np.zeros(system.ndof, bool)), bool)
        self.cap = np.where(rot, 0.5, 0.25 * self.L)  # largest Newton correction per DOF

    def follow(self, q: np.ndarray, mu: float, ell_a: float, ell_b: float) -> tuple:
        """Held-length equilibrium at ``ell_b`` from the one at ``ell_a``, halving the
        length step when Newton fails (at most 10 times)."""
        t, h, cuts, its = 0.0, 1.0, 0, 0
        while t < 1.0 - 1e-15:
            step = min(h, 1.0 - t)
            try:
                q1, mu1, k = self.newton(q, mu, self.F, ell_a + (t + step) * (ell_b - ell_a))
            except (DeployError, np.linalg.LinAlgError):
                cuts += 1
                if cuts > 10:
                    raise
                h = step / 2
                continue
            q, mu, t, its = q1, mu1, t + step, its + k
        return q, mu, its

    def ell(self, q: np.ndarray) -> float:
        return self.pair.geometry(q)[0]

    def newton(
        self, q: np.ndarray, mu: float, push: float, target: float | None
    ) -> tuple[np.ndarray, float, int]:
        """Equilibrium with push ``push``; length held at ``target`` (None: free).  Newton
        with corrections capped at 0.25 L / 0.5 rad; if that fails, once more with caps five
        times smaller and more iterations (far from the solution, e.g. preloaded springs
        released from the drawn pose)."""
        try:
            return self._newton(q, mu, push, target, self.cap, MAX_ITER)
        except (DeployError, np.linalg.LinAlgError):
            return self._newton(q, mu, push, target, 0.2 * self.cap, 4 * MAX_ITER)

    def _newton(
        self,
        q: np.ndarray,
        mu: float,
        push: float,
        target: float | None,
        cap: np.ndarray,
        max_iter: int,
    ) -> tuple[np.ndarray, float, int]:
        n = self.sys.ndof
        step, prev = np.inf, np.inf
        for it in range(max_iter + 1):
            r, K = self.sys.residual_and_tangent(q, 0.0)
            ell, G, H = self.pair.geometry(q)
            G = np.asarray(G).ravel()
            held = target is not None
            R = r + ((mu if held else 0.0) - push) * G
            c = ell - target if held else 0.0
            res = float(np.max(np.abs(R)))
            # converged: residual at 1e-10 of the push, or within the FE's round-off floor
            # (stiff rigid-link elements) once Newton stops gaining: corrections at
            # round-off or the residual no longer halving
            floor = step <= 1e-13 * self.L or res > 0.5 * prev
            small = res <= 1e-10 * self.fs or (res <= self.tol and floor)
            prev = res
            if small and abs(c) <= 1e-13 * self.L:
                return q, mu, it
            if it == max_iter:
                break
            W = K.toarray() + ((mu if held else 0.0) - push) * H.toarray()
            if held:
                A = np.zeros((n + 1, n + 1))
                A[:n, :n], A[:n, n], A[n, :n] = W, G, G
                dx = np.linalg.solve(A, -np.append(R, c))
            else:
                dx = np.linalg.solve(W, -R)
            dx *= 1.0 / max(1.0, float(np.max(np.abs(dx[:n]) / cap)))  # damped far off
            q = q + dx[:n]
            mu = mu + dx[n] if held else mu
            step = float(np.max(np.abs(dx[:n])))
        raise DeployError(f"Newton did not converge (residual {np.max(np.abs(R)):.2e})")

    def stability(self, q: np.ndarray, mu: float, push: float, held: bool) -> float:
        """Lowest eigenvalue of the (constrained) tangent against the mass."""
        _, K = self.sys.residual_and_tangent(q, 0.0)
        _, G, H = self.pair.geometry(q)
        K = K.toarray() + ((mu if held else 0.0) - push) * H.toarray()
        Grow = np.asarray(G).reshape(1, -1) if held else np.zeros((0, K.shape[0]))
        M = self.sys.mass().toarray()
        if Grow.shape[0]:
            Z = sla.null_space(Grow)
            K, M = Z.T @ K @ Z, Z.T @ M @ Z
        return float(sla.eigh(0.5 * (K + K.T), M, eigvals_only=True, subset_by_index=[0, 0])[0])

    def step(self, q: np.ndarray, factor: float, its: int, eig: float) -> Step:
        st = self.sys.step(q, factor, its, bool(eig > 0))
        out = {**st.outputs, f"{self.scene.booms[0].id}.length": self.ell(q)}
        info = {"lowest_eigenvalue": eig, "tangent_stable": float(eig > 0)}
        return Step(st.factor, out, st.energy, st.iterations, bool(eig > 0), st.shapes, None, info)


def solve_deploy(scene: Scene, name: str, n_elements: int) -> Solution:
    """Phase 1 at ``steps`` + 1 boom lengths (stall located), then Phase 2 locked."""
    if any(b.stop != "lock" for b in scene.booms):
        why = "a collision-damper boom stop is dynamic: only replay models it"
        return Solution(scene.name, name, "not-applicable", why)
    if len(scene.booms) > 1:
        why = "FE deploy drives one boom (several: deploy_staged.solve_any)"
        return Solution(scene.name, name, "not-applicable", why)
    b0 = scene.booms[0]
    d = FEDeploy(build(scene, n_elements), scene)
    q, mu = np.zeros(d.sys.ndof), 0.0
    ell0, Lend = d.ell(q), scene.booms[0].length
    steps: list[Step] = []
    extras: dict[str, object] = {}
    try:
        q, mu, its = d.newton(q, mu, d.F, ell0)
        path = [(0.0, q, mu, its)]
        n = scene.analysis.steps
        for k in range(1, n + 1):
            target = ell0 + k / n * (Lend - ell0)
            q1, mu1, its = d.follow(q, mu, target - (Lend - ell0) / n, target)
            if mu1 <= 0.0:
                return _stall(d, scene, name, path, target - (Lend - ell0) / n, target)
            q, mu = q1, mu1
            path.append((k / n, q, mu, its))
        for f, qk, mk, ik in path:
            steps.append(d.step(qk, f, ik, d.stability(qk, mk, d.F, True)))
        q2, bar, its = d.newton(q, mu - d.F, 0.0, Lend)
        steps.append(d.step(q2, 2.0, its, d.stability(q2, bar, 0.0, True)))
        extras.update(boom_reached=True, boom_bar_force=[bar])
        ends = {m.a for m in scene.members} | {m.b for m in scene.members}
        joint = "J4" if "J4" in ends else b0.b  # the thesis's Joint 4, else the pushed joint
        extras["structure"] = joint_compliance(d, q2, bar, joint)
    except (DeployError, np.linalg.LinAlgError, ValueError) as err:
        return Solution(scene.name, name, "failed", str(err), tuple(steps), extras)
    eig = steps[-1].info["lowest_eigenvalue"]
    msg = f"boom locked at {Lend:g}; bar force {bar:.4g} N; lowest tangent eigenvalue {eig:.4g}"
    return Solution(scene.name, name, "converged", msg, tuple(steps), extras)


def _stall(
    d: FEDeploy, scene: Scene, name: str, path: list, ell_a: float, ell_b: float
) -> Solution:
    """Where the push stops winning: Brent on the held length, then the free equilibrium."""
    _, q_a, mu_a, _ = path[-1]

    def surplus(ell: float) -> float:
        return d.newton(q_a, mu_a, d.F, ell)[1]

    ell_star = so.brentq(surplus, ell_a, ell_b, xtol=1e-14) if surplus(ell_a) > 0 else ell_a
    q_s, _, _ = d.newton(q_a, mu_a, d.F, ell_star)
    q_f, _, its = d.newton(q_s, 0.0, d.F, None)
    steps = [d.step(qk, f, ik, d.stability(qk, mk, d.F, True)) for f, qk, mk, ik in path]
    L = d.ell(q_f)
    ell0 = d.ell(np.zeros_like(q_f))
    prog = (L - ell0) / (scene.booms[0].length - ell0)
    steps.append(d.step(q_f, float(prog), its, d.stability(q_f, 0.0, d.F, False)))
    msg = f"boom {scene.booms[0].id!r} stalled at length {L:.6g} < {scene.booms[0].length:g}"
    return Solution(scene.name, name, "converged", msg, tuple(steps), {"boom_reached": False})


__all__ = ["booms_as_locks", "solve_deploy"]
