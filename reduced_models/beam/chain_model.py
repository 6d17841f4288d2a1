"""ChainModel: the shared Model-protocol layer of the linear-N, bcm and cbcm-N models.

A chained-segment model of a single clamped beam with tip loads: ``applies_to`` checks the
scene, ``solve`` builds the normalised ``chain.ChainProblem`` (kinematics, mixed Lagrangian
and its banded Hessian -- see ``reduced_models.beam.chain``), follows the load path and
turns the converged states into ``Step``s (tip outputs, energy, shapes, stress, validity
warnings).  The path: for dead loads on N > 1 segments Newton in the chain's own coordinates
(``chain_path.ChainPath``), on one segment plain floats (``chain_small``; with P = Q = 0,
linear beam theory, one solve per path), and the general continuation
(``paths.engine.minimize_path``) for follower loads and wherever the fast path hands back.
Subclasses (``linear.LinearChain``, ``bcm.ChainedBCM``) supply the segment law, the local
shape and the validity checks.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.beam import single_beam
from reduced_models.beam.chain import ChainProblem, SegmentLaw, chain_shape, local_coords
from reduced_models.beam.chain_path import ChainPath
from reduced_models.beam.chain_small import solve_linear_segment, solve_single_segment
from reduced_models.options import Option
from reduced_models.paths.engine import minimize_path
from reduced_models.paths.path_result import PathResult

__all__ = ["ChainModel"]


class ChainModel:
    """A chained-segment energy model of a single beam (base of LinearChain and ChainedBCM).

    Subclasses set ``law`` (SegmentLaw), ``family``, ``_card`` (ModelCard template) and
    implement ``shape(ux, y, a, p, k, sigma) -> (xl, yl, kappa)`` (each (N, s), segment
    units; called once with the segments of all reported steps) and
    ``warning_flags(ux, y, a, p, k) -> [(message, (m,) bool)]`` ((m, N) segment arrays).

    Parameters
    ----------
    n : number of segments.
    shape_points : sample points per segment for shapes and stress (default: about 48 per
        beam, at least 5 per segment).
    """

    # small- or intermediate-deflection kinematics: a tip beyond the member's reach under
    # loads is this model's error, not a stretch (reports.api.checked)
    approximate_kinematics = True

    law: SegmentLaw
    family = "chain"
    _card: ModelCard
    extensible = False

    def __init_subclass__(cls, **kwargs: object) -> None:
        # a class-level card for listings (``flexbench models``) before N is known
        super().__init_subclass__(**kwargs)
        template = cls.__dict__.get("_card")
        if template is not None:
            cls.card = dataclasses.replace(template, summary=template.summary.format(N="N"))

    OPTIONS = {"shape_points": Option("int", 2, 100_000, doc="points per segment shape")}

    def __init__(self, n: int = 1, shape_points: int | None = None) -> None:
        if int(n) < 1:
            raise ValueError("segment count must be >= 1")
        self.N = int(n)
        self.shape_points = shape_points or max(5, math.ceil(48 / self.N) + 1)
        self.name = f"{self.family}-{self.N}"
        self.card = ModelCard(
            name=self.name,
            family=self._card.family,
            summary=self._card.summary.format(N=self.N),
            assumptions=self._card.assumptions,
            validity=self._card.validity,
            references=self._card.references,
        )

    # -- subclass hooks --------------------------------------------------------------------
    def shape(
        self,
        ux: np.ndarray,
        y: np.ndarray,
        a: np.ndarray,
        p: np.ndarray,
        k: float,
        sigma: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local segment shapes from segment states (each (N,)) at positions sigma (s,).

        Returns xl, yl (segment units, xl[:, 0] = 0) and curvature kappa (1/h), each (N, s).
        """
        raise NotImplementedError

    def warning_flags(
        self, ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float
    ) -> list[tuple[str, np.ndarray]]:
        """Validity-range violations: (message, (m,) bool per reported step) pairs for
        segment states given as (m, N) arrays (none here)."""
        return []

    # -- Model protocol --------------------------------------------------------------------
    def applies_to(self, scene: Scene) -> str | None:
        """None if ``scene`` is a clamped beam with tip loads, else the reason."""
        beam = single_beam.cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if not (math.isfinite(beam.EI) and beam.EI > 0 and beam.L > 0):
            return "flexible member needs finite positive E and I"
        return None

    def problem(self, beam: single_beam.Cantilever) -> ChainProblem:
        """The normalised chain problem of a cantilever."""
        L, EI = beam.L, beam.EI
        h = L / self.N
        k = EI / (beam.EA * h**2) if (self.extensible and math.isfinite(beam.EA)) else 0.0
        loads = (beam.fx * L**2 / EI, beam.fy * L**2 / EI, beam.m * L / EI)
        return ChainProblem(self.law, self.N, k, loads, beam.follower, beam.guided)

    def _path(self, prob: ChainProblem, factors: np.ndarray) -> PathResult:
        """The general continuation (banded, retraction, follower loads)."""
        return minimize_path(
            prob.grad_hess,
            prob.x0,
            factors,
            scale=prob.scale,
            fixed=prob.fixed,
            max_step=prob.max_step,
            stability=prob.stability,
            update=prob.update,
            load_gradient=prob.load_gradient,
        )

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """Shapes and bending stress of the reported states (``shape`` of every segment from
        its tip state and axial force in ``extras``), outside the timed solve: every step's
        at once, the steps built once."""
        beam = single_beam.cantilever_of(scene)
        L, N, m = beam.L, self.N, len(sol.steps)
        h = 1.0 / N  # ChainProblem.h: segment length over L
        nodes = np.asarray(sol.extras["nodes"], dtype=float)[:m] / np.array([L, L, 1.0])
        p = np.asarray(sol.extras["axial"], dtype=float)[:m]
        xi, eta, a, _, _ = local_coords(nodes, h)
        flat = (xi.ravel() - 1.0, eta.ravel(), a.ravel(), p.ravel(), float(sol.extras["k"]))
        sigma = np.linspace(0.0, 1.0, self.shape_points)
        xl, yl, kappa = (v.reshape(m, N, sigma.size) for v in self.shape(*flat, sigma))
        pts = beam.rotate_to_global(chain_shape(nodes, xl, yl, h) * L)  # (m, P, 2)
        kmax = np.abs(kappa).max(axis=(1, 2), initial=0.0) * N / L
        steps = single_beam.steps_with_shapes(scene, beam, sol.steps, pts, kmax)
        return dataclasses.replace(sol, steps=steps)

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path by load continuation (module docstring: which path solver)."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        beam = single_beam.cantilever_of(scene)
        prob = self.problem(beam)
        factors = load_factors(scene)
        if self.N == 1 and not beam.follower and not (self.law.P.any() or self.law.Q.any()):
            res = solve_linear_segment(prob, factors)  # linear beam theory: one 2x2 solve
        elif self.N == 1 and not beam.follower:  # a handful of unknowns: plain floats
            res = solve_single_segment(prob, factors)
        else:  # dead loads: the condensed fast path where it applies (chain_path)
            res = None if beam.follower else ChainPath(prob).follow(factors.tolist())
            res = self._path(prob, factors) if res is None else res
        L, EI, N, k = beam.L, beam.EI, self.N, prob.k
        # every per-step quantity for all reported states at once: (m, N) segment arrays
        m = len(res.factors)
        nodes, p = prob.split(res.states)  # (m, N + 1, 3), (m, N)
        xi, eta, a, c, s = local_coords(nodes, prob.h)
        ux = xi - 1.0
        flat = (ux.ravel(), eta.ravel(), a.ravel(), p.ravel(), k)
        energy = EI / L * N * self.law.energy(*flat).reshape(m, N).sum(axis=1)
        last = (xi[:, -1], eta[:, -1], a[:, -1], c[:, -1], s[:, -1], p[:, -1])
        loads = prob.tip_loads_of(*last) * np.array([EI / L**2, EI / L**2, EI / L])
        ymax = np.abs(eta).max(axis=1, initial=0.0)
        flags = self.warning_flags(ux, eta, a, p, k)
        steps = []
        a_cfg = scene.analysis
        stop = a_cfg.kind == "path" and a_cfg.stop_output and a_cfg.stop_value is not None
        v0 = None
        outputs_of = single_beam.output_map(scene, beam)  # keys and frames looked up once
        # plain floats from here (one conversion per array, not one per entry)
        per_step = zip(
            res.factors.tolist(),
            (nodes[:, -1] * np.array([L, L, 1.0])).tolist(),
            energy.tolist(),
            res.iterations.tolist(),
            res.stable,
            loads.tolist(),
            res.residuals.tolist(),
            res.cuts.astype(float).tolist(),
            ymax.tolist(),
        )
        for j, (lam, (tx, ty, tr), e, its, st, (lx, ly, lm), r, cuts, ym) in enumerate(per_step):
            outputs = outputs_of(tx, ty, tr)
            info = {"tip.fx": lx, "tip.fy": ly, "tip.m": lm, "residual": r, "cuts": cuts}
            info["max_segment_y"] = ym
            steps.append(Step(lam, outputs, e, its, st, info=info))
            # a "path" analysis stops once its stop output reaches the stop value
            if stop:
                v = outputs.get(a_cfg.stop_output)
                v0 = v if v0 is None else v0
                if (
                    v is not None
                    and j > 0
                    and (v - a_cfg.stop_value) * (v0 - a_cfg.stop_value) <= 0
                ):
                    break
        m = len(steps)
        # warning -> first reported factor it appeared at
        first = sorted((int(np.argmax(f[:m])), w) for w, f in flags if np.any(f[:m]))
        warned = {w: f"{w} (from factor {res.factors[j]:.4g})" for j, w in first}
        all_nodes, all_p = nodes[:m] * np.array([L, L, 1.0]), p[:m]
        extras: dict[str, object] = {
            "nodes": all_nodes,
            "axial": all_p,
            "k": prob.k,
        }
        if warned:
            extras["validity_warning"] = True
            extras["validity_message"] = "; ".join(warned.values())
        if not res.ok:
            return Solution(scene.name, self.name, "failed", res.reason, tuple(steps), extras)
        msg = f"{len(steps)} steps, {int(res.iterations.sum())} Newton iterations"
        if warned:
            msg += "; outside validity range: " + "; ".join(warned.values())
        msg += single_beam.unstable_note(steps)
        return Solution(scene.name, self.name, "converged", msg, tuple(steps), extras)
