"""``elastica-bvp``: the same exact elastica solved by ``scipy.integrate.solve_bvp`` (baseline).

A speed baseline for the elliptic/shooting ``elastica`` model (same equations, a general
collocation BVP solver instead of closed forms): state (theta, kappa, x, y, U) along the arc
length, EI kappa' = fx sin(theta) - fy cos(theta) with the tip force (fx, fy) in the beam frame
(follower: the direction is theta(L) + gamma, an unknown parameter of the BVP), boundary
conditions theta(0) = x(0) = y(0) = U(0) = 0 and kappa(L) = M/EI (free tip) or theta(L) = 0
(guided tip).  Load continuation reuses the previous solution as the initial guess and halves
the load increment (up to ``MAX_HALVINGS`` times) when ``solve_bvp`` fails.  ``tol`` = 1e-10.
A wall-clock limit (``time_limit_s``, checked inside the collocation residual, so a single
long ``solve_bvp`` call is cut too) fails the run with the reason and the states so far.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import solve_bvp

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.beam.elastica import PERFECT, PERFECT_COLUMN
from reduced_models.beam.single_beam import (
    Cantilever,
    cantilever_of,
    stress_from_curvature,
    tip_outputs,
)
from reduced_models.options import Option

MAX_HALVINGS = 14
TIME_LIMIT_S = 60.0  # default wall clock (s): the runner's DEFAULT_TIME_LIMIT
N_SHAPE = 41
EULER = 0.25 * math.pi**2  # a cantilever column's Euler load P L^2 / EI


class _TimeUp(Exception):
    """Raised from the collocation residual once the wall-clock limit has passed."""


class _Stalled(Exception):
    """The load increment was halved ``MAX_HALVINGS`` times without a solution."""


class ElasticaBVP:
    """Inextensible elastica of a single clamped beam by collocation (``solve_bvp``)."""

    name = "elastica-bvp"
    OPTIONS = {
        "tol": Option("float", 1e-14, 1e-3, doc="solve_bvp tolerance"),
        "max_nodes": Option("int", 10, 10_000_000, doc="solve_bvp mesh limit"),
        "time_limit_s": Option("float", 1e-3, 1e6, doc="wall clock (s) before the run fails"),
    }
    card = ModelCard(
        name="elastica-bvp",
        family="elastica",
        summary="exact inextensible elastica by scipy.integrate.solve_bvp at tol 1e-10: a "
        "speed baseline for the elliptic-integral model",
        assumptions=(
            "inextensible, shear-rigid Euler-Bernoulli beam, M = EI kappa",
            "one clamped end; tip free or guided; dead, moment or follower tip loads",
            "load continuation with the previous solution as initial guess",
        ),
        validity="same as the elastica; collocation residual below 1e-10 (4th-order "
        "Lobatto IIIA with mesh refinement)",
        references=(
            "Kierzenka J., Shampine L.F. (2001) A BVP solver based on residual control and the "
            "MATLAB PSE. ACM TOMS 27:299-316, doi 10.1145/502800.502801",
            "Bisshopp K.E., Drucker D.C. (1945) Q. Appl. Math. 3:272",
        ),
    )

    def __init__(
        self, tol: float = 1e-10, max_nodes: int = 20000, time_limit_s: float = TIME_LIMIT_S
    ) -> None:
        self.tol = tol
        self.max_nodes = max_nodes
        self.time_limit_s = time_limit_s
        self.end = math.inf  # perf_counter() deadline of the running solve

    def applies_to(self, scene: Scene) -> str | None:
        """None for a single clamped beam loaded at its tip, else the reason."""
        beam = cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if not (beam.L > 0.0 and math.isfinite(beam.EI) and beam.EI > 0.0):
            return "the beam needs a positive length and finite positive E*I"
        return None

    def _solve_at(self, beam: Cantilever, t: float, guess: tuple) -> tuple | None:
        """solve_bvp at load factor t from ``guess`` = (mesh, y, p); None if it fails.

        Dimensionless (s / L, curvature * L, x / L, y / L, energy * L / EI): ``tol`` then
        means the same in any units the scene is written in.
        """
        w = beam.L**2 / beam.EI  # force -> dimensionless load
        follower = beam.follower and not beam.guided and (beam.fx or beam.fy)
        P, gamma = t * w * math.hypot(beam.fx, beam.fy), math.atan2(beam.fy, beam.fx)
        fx, fy, kL = t * w * beam.fx, t * w * beam.fy, t * beam.m * beam.L / beam.EI

        def rhs(s: np.ndarray, y: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
            if time.perf_counter() > self.end:  # solve_bvp calls it every few milliseconds
                raise _TimeUp
            th, kap = y[0], y[1]
            if follower:  # force direction phi = p[0] (= theta(L) + gamma at the solution)
                dk = P * np.sin(th - p[0])
            else:
                dk = fx * np.sin(th) - fy * np.cos(th)
            return np.vstack([kap, dk, np.cos(th), np.sin(th), 0.5 * kap * kap])

        def bc(ya: np.ndarray, yb: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
            tip = yb[0] if beam.guided else yb[1] - kL
            res = [ya[0], ya[2], ya[3], ya[4], tip]
            if follower:
                res.append(p[0] - yb[0] - gamma)
            return np.array(res)

        mesh, y, p = guess
        sol = solve_bvp(
            rhs, bc, mesh, y, p=p if follower else None, tol=self.tol, max_nodes=self.max_nodes
        )
        if sol.status != 0:
            return None
        return sol.x, sol.y, sol.p if follower else None, sol

    def solve(self, scene: Scene) -> Solution:
        """Load-ramp equilibrium path (``path`` analyses: ``max_steps`` equal increments).

        Continuation: secant predictor of the whole solution on a fixed 201-point mesh (the
        mesh solve_bvp refines is not carried over, so it cannot grow without bound); a step is
        halved when solve_bvp fails or when the tip rotation departs from the prediction by more
        than 0.25 rad or half its own size (a jump to another branch, e.g. the mirror branch of
        an imperfect column).
        """
        why = self.applies_to(scene)
        if why is not None:
            return not_applicable(scene, self.name, why)
        self.end = time.perf_counter() + self.time_limit_s
        steps: list[Step] = []
        try:
            self._path(scene, cantilever_of(scene), steps)
        except _TimeUp:
            last = steps[-1].factor if steps else 0.0
            msg = (
                f"time limit {self.time_limit_s:g} s reached beyond factor {last:.6g}: "
                "solve_bvp's continuation stalled (increments halved, collocation mesh grown)"
            )
            return Solution(scene.name, self.name, "failed", msg, tuple(steps))
        except _Stalled as exc:
            return Solution(scene.name, self.name, "failed", str(exc), tuple(steps))
        return Solution(
            scene.name, self.name, "converged", f"solve_bvp, {len(steps)} steps", tuple(steps)
        )

    def _path(self, scene: Scene, beam: Cantilever, steps: list[Step]) -> None:
        """Append the Step of every reported factor to ``steps`` (continuation: ``solve``);
        raises ``_Stalled`` when the increment cannot be halved further."""
        a = scene.analysis
        factors = (
            np.linspace(0.0, a.factor_end, a.max_steps + 1)
            if a.kind == "path"
            else load_factors(scene)
        )
        mesh = np.linspace(0.0, 1.0, 201)  # s / L
        Y = np.zeros((5, mesh.size))
        Y[2] = mesh
        follower = beam.follower and not beam.guided and (beam.fx or beam.fy)
        p = np.array([math.atan2(beam.fy, beam.fx)]) if follower else None
        slope = np.zeros_like(Y)
        t_prev, dt = 0.0, float(np.max(factors))
        # the closed form's rule (``elastica.PERFECT``): past Euler a perfect column has two
        # mirror branches and the straight one; which one collocation converges to would be
        # decided by the round-off of how the scene is drawn
        perfect = not (follower or beam.guided or beam.m) and beam.fx < 0.0
        perfect = perfect and abs(beam.fy) <= PERFECT * abs(beam.fx)
        for t in factors:
            if perfect and t * abs(beam.fx) * beam.L**2 / beam.EI > EULER * (1.0 + 1e-12):
                raise _Stalled(f"factor {t:.6g}: {PERFECT_COLUMN}")
            iters, sol = 0, None
            while sol is None or t_prev < t:
                h = min(dt, t - t_prev)
                if t - t_prev - h <= 1e-6 * h:  # land exactly on the target, no sliver steps
                    h, t_new = t - t_prev, t
                else:
                    t_new = t_prev + h
                guess = Y + slope * h
                out = self._solve_at(beam, t_new, (mesh, guess, p))
                iters += 1
                if out is not None:
                    Yn = out[3].sol(mesh)
                    th, pred = Yn[0, -1], guess[0, -1]
                    bound = 0.25 if not steps[1:] else min(0.25, 0.5 * max(abs(th), abs(pred)))
                    if abs(th - pred) > bound + 1e-9:
                        out = None
                if out is None:
                    dt = 0.5 * h
                    if h == 0.0 or dt < 2.0**-MAX_HALVINGS * float(np.max(factors)):
                        msg = f"solve_bvp failed beyond factor {t_prev:.6g} (tol {self.tol:g})"
                        raise _Stalled(msg)
                    continue
                if h > 0.0:
                    slope = (Yn - Y) / h
                    dt = min(2.0 * dt, float(np.max(factors)))
                Y, p, sol, t_prev = Yn, out[2], out[3], t_new
            ys = beam.L * sol.sol(np.linspace(0.0, 1.0, N_SHAPE))
            th, kap, x, y, U = sol.y[:, -1] * [1.0, 1.0 / beam.L, beam.L, beam.L, beam.EI / beam.L]
            steps.append(
                Step(
                    factor=float(t),
                    outputs=tip_outputs(scene, beam, float(x), float(y), float(th)),
                    energy=float(U),
                    iterations=iters,
                    stable=None,
                    shapes={beam.member: beam.rotate_to_global(ys[2:4].T)},
                    max_stress=stress_from_curvature(scene, beam, sol.y[1] / beam.L),
                    info={"nodes": float(sol.x.size)},
                )
            )
