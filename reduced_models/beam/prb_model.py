"""The shared Model-protocol layer of the PRB models (``reduced_models.beam.prb``).

A PRB model of a single cantilever is a chain of rigid segments described by a PRB matrix
``[[k_theta, k_ex, gamma], ...]`` (see ``prb_tables``).  ``PRBModel`` checks the scene, asks
its subclass for the matrix (``setup``), follows the equilibrium path of the chain
(``prb_chain``: kinematics, analytic gradient and Hessian, the continuation engine) and turns
the converged states into ``Step``s; ``postprocess`` adds the end loads recovered by
pinv(J^T), the PRB's own shape and its bending stress (``prb_post``).  With the option
``das2d = true`` the shape and stress are DAS-2D's instead: the Euler (elastica) beam solved
under the recovered end loads, with the PRB-vs-Euler tip gap as DAS-2D's accuracy indicator in
``extras["das2d_indicator"]`` (``prb_das2d``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.beam.prb_chain import RESIDUAL_TOL, PRBChain, check_matrix, equilibrium_path
from reduced_models.beam.prb_das2d import OPTION as DAS2D
from reduced_models.beam.prb_das2d import das2d_shapes
from reduced_models.beam.prb_post import recover_tip_loads_batch, shape_and_stress
from reduced_models.beam.single_beam import Cantilever, cantilever_of, output_map, unstable_note
from reduced_models.options import SHAPES

__all__ = ["COMMON", "PRBModel"]

# what every PRB model assumes (the registered models add their own lines)
COMMON = (
    "rigid segments joined by linear torsion springs (PRB matrix)",
    "dead tip loads only (energy formulation; follower loads are declined)",
    "shape: the PRB's own pivots and rigid links; stress from the bending moment of the end "
    "loads recovered from the PRB's spring forces by pinv(J^T), at the root, pivots and tip "
    "(option das2d: the Euler beam under those loads and the PRB-vs-Euler tip gap, DAS-2D)",
)


class PRBModel:
    """A PRB model of a single cantilever defined by a PRB matrix (subclasses pick it)."""

    # small- or intermediate-deflection kinematics: a tip beyond the member's reach under
    # loads is this model's error, not a stretch (reports.api.checked)
    approximate_kinematics = True

    name = "prb"
    card = ModelCard(name="prb", family="prb", summary="PRB chain", assumptions=COMMON)

    OPTIONS = {**SHAPES, **DAS2D}

    def __init__(self, matrix: object = None, shapes: bool = True, das2d: bool = False) -> None:
        self._matrix = None if matrix is None else check_matrix(matrix)
        self.shapes = bool(shapes)
        self.das2d = bool(das2d)  # DAS-2D's Euler shape and accuracy indicator (prb_das2d)

    # subclasses override: (matrix, tip-angle factor, note) for this cantilever, or a reason
    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """PRB matrix, tip-angle factor and a note for this cantilever, or why not."""
        if self._matrix is None:
            return "no PRB matrix given"
        return self._matrix, 1.0, ""

    def _beam(self, scene: Scene) -> Cantilever | str:
        beam = cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if beam.follower:
            return (
                "follower tip loads are non-conservative; energy-based PRB models take dead loads"
            )
        if scene.analysis.kind != "load":
            return f"analysis kind {scene.analysis.kind!r}: PRB models follow a load ramp only"
        if not (math.isfinite(beam.EI) and beam.EI > 0):
            return "flexural rigidity EI of the beam is not given"
        return beam

    def _prepare(self, scene: Scene) -> tuple[Cantilever, tuple] | str:
        """The cantilever and its ``setup``, or the reason this model declines the scene
        (kept for the last scene: ``applies_to`` and ``solve`` ask for the same one)."""
        last = self.__dict__.get("_ready")
        if last is not None and last[0] is scene:
            return last[1]
        ready = self._prepare_new(scene)
        self._ready = (scene, ready)
        return ready

    def _prepare_new(self, scene: Scene) -> tuple[Cantilever, tuple] | str:
        beam = self._beam(scene)
        if isinstance(beam, str):
            return beam
        s = self.setup(beam)
        if isinstance(s, str):
            return s
        nj = int(np.isfinite(s[0][:, 0]).sum())
        if beam.guided and nj < 2:
            return "a guided tip needs at least two PRB joints (tip angle held at zero)"
        return beam, s

    def applies_to(self, scene: Scene) -> str | None:
        """None if this PRB model can solve the scene, else the reason."""
        ready = self._prepare(scene)
        return ready if isinstance(ready, str) else None

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of the scene's load ramp."""
        ready = self._prepare(scene)  # checked and set up once
        if isinstance(ready, str):
            return not_applicable(scene, self.name, ready)
        beam, (matrix, rot_factor, note) = ready
        chain = self._chain_of(matrix, beam)
        f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
        path = equilibrium_path(chain, f1, load_factors(scene), guided=beam.guided)
        steps = []
        failed = "" if path.ok else path.reason
        # residual max |grad V| in EI/L (forces times L); the path already demanded it
        res = (path.residuals * (chain.L / chain.EI)).tolist()
        m = next((j for j, r in enumerate(res) if not r <= RESIDUAL_TOL), len(res))
        if m < len(res):
            failed = (
                f"residual {res[m]:.2e} EI/L above {RESIDUAL_TOL:g} at factor {path.factors[m]:.6g}"
            )
        # per-step quantities for all reported states at once (batched numpy)
        Q = path.states[:m]
        # plain floats from here (one conversion per array, not one per entry)
        tips, energy = chain.tips(Q).tolist(), chain.strain_energy(Q).tolist()
        per_step = zip(
            path.factors[:m].tolist(),
            tips,
            energy,
            path.iterations[:m].tolist(),
            path.stable,
            res[:m],
            path.cuts[:m].astype(float).tolist(),
        )
        outputs = output_map(scene, beam)
        for lam, (x, y, phi), e, its, stable, r, cuts in per_step:
            rot = 0.0 if beam.guided else rot_factor * phi
            steps.append(
                Step(
                    factor=lam,
                    outputs=outputs(x, y, rot),
                    energy=e,
                    iterations=its,
                    stable=stable,
                    info={"residual": r, "step_cuts": cuts},
                )
            )
        extras = {
            "prb_matrix": matrix.tolist(),
            "tip_angle_factor": rot_factor,
            # chain coordinates [psi (rad), u (length)] per reported step (mechanism assembly)
            "prb_states": Q.tolist(),
        }
        if failed:
            return Solution(scene.name, self.name, "failed", failed, tuple(steps), extras)
        msg = "converged" + (f"; {note}" if note else "")
        if np.any(np.isfinite(matrix[:, 1])) and chain.ne == 0:
            msg += "; axial springs treated as rigid (EA not given)"
        msg += unstable_note(steps)
        return Solution(scene.name, self.name, "converged", msg, tuple(steps), extras)

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """Shapes and stress of the reported states from the PRB itself (not timed as solve).

        Shape: the PRB's own pivots and rigid links (its tip is the reported tip).  End loads
        from the spring forces through pinv(J^T) (``info`` ``load_fx``, ``load_fy``,
        ``load_m``, ``jt_rank``); stress from the bending moment these loads give at the
        root, every pivot and the tip, ``m + (tip - p) x f`` (linear along a rigid link).
        """
        if not sol.steps or not (self.shapes or self.das2d):
            return sol
        beam = self._beam(scene)
        chain = self._chain_of(np.asarray(sol.extras["prb_matrix"]), beam)
        Q = np.asarray(sol.extras["prb_states"], dtype=float).reshape(len(sol.steps), chain.n)
        f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
        lam = np.array([s.factor for s in sol.steps])
        loads, rank = recover_tip_loads_batch(chain, Q, None if beam.guided else lam[:, None] * f1)
        if self.das2d:  # the Euler beam under the recovered loads, and the tip gap
            rot = 0.0 if beam.guided else sol.extras["tip_angle_factor"]
            shapes, stress, indicator = das2d_shapes(scene, beam, chain, Q, loads, rot)
            sol = replace(sol, extras={**sol.extras, "das2d_indicator": indicator})
        else:
            shapes, stress = shape_and_stress(scene, beam, chain, Q, loads)
        stress = [None] * len(Q) if stress is None else stress.tolist()
        steps = []
        for step, xy, (fx, fy, fm), r, sig in zip(
            sol.steps, shapes, loads.tolist(), rank.tolist(), stress
        ):
            info = {**step.info, "load_fx": fx, "load_fy": fy, "load_m": fm, "jt_rank": float(r)}
            steps.append(
                Step(
                    step.factor,
                    step.outputs,
                    step.energy,
                    step.iterations,
                    step.stable,
                    {beam.member: xy},
                    sig,
                    info,
                )  # fmt: skip
            )
        return replace(sol, steps=tuple(steps))

    def _chain_of(self, matrix: np.ndarray, beam: Cantilever) -> PRBChain:
        """The PRBChain of this PRB matrix and beam, built once for a solve and its
        postprocess (the last one is kept)."""
        key = (matrix.tobytes(), matrix.shape, beam.L, beam.EI, beam.EA)
        last = self.__dict__.get("_chain")
        if last is None or last[0] != key:
            self._chain = last = (key, PRBChain(matrix, beam.L, beam.EI, beam.EA))
        return last[1]
