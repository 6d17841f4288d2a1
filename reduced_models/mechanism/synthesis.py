"""Flexural-stiffness and critical-load synthesis (DAS-2D "Synthesis routines").

The EI of the chosen members is scaled by one factor s (E -> s E); s solves

* ``stiffness``: output(s) at factor_end of the load ramp = target;
* ``critical-load``: the largest |driving force| of the energy sweep before the first
  unstable equilibrium (the switching load of a bistable mechanism) = target;

by secant iterations in log s started from the proportional guess (exact when every load
path scales with EI, e.g. a member-only bistable mechanism).  The answer is the path of the
synthesised scene (``synthesised_scene``), with ``extras["synthesis"]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from cases.schema import Member, Scene
from reduced_models.base import Solution, not_applicable
from reduced_models.mechanism import analyses, bistable
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.newton import SolveError
from reduced_models.mechanism.system import SceneError

MAX_IT = 30
RTOL = 1e-9


def synthesised_scene(scene: Scene, scale: float) -> Scene:
    """The scene with E of the synthesis members scaled by ``scale`` and the analysis
    replaced by the one the goal runs (``load`` or ``energy``)."""
    syn = scene.analysis.synthesis
    members = tuple(replace(m, E=m.E * scale) if m.id in syn.members else m for m in scene.members)
    kind = "load" if syn.goal == "stiffness" else "energy"
    return replace(
        scene, members=members, analysis=replace(scene.analysis, kind=kind, synthesis=None)
    )


def _measure(run: analyses.Run, goal: str, output: str | None) -> float:
    """The synthesised quantity: the output at factor_end, or the largest |driving force|
    before the first unstable equilibrium (refined off the grid, ``bistable.peak``)."""
    if goal == "stiffness":
        return float(run.steps[-1].outputs[output])
    vals = np.array([s.factor for s in run.steps])
    F = np.array([s.outputs[bistable.force_key(run)] for s in run.steps])
    un = [e for e in run.extras.get("equilibria", []) if e["kind"] == "unstable"]
    hi = un[0]["coordinate"] if un else float(vals[-1])
    inside = (vals - vals[0]) * (vals - hi) <= 0.0
    sign = float(np.sign(F[inside][np.argmax(np.abs(F[inside]))])) or 1.0
    return abs(bistable.peak(bistable.At(run), float(vals[0]), hi, sign)[1])


def synthesise(scene: Scene, name: str, spec_of: Callable[[Member], tuple]) -> Solution:
    """Solve the synthesis of ``scene`` with the member laws of ``spec_of``."""
    syn = scene.analysis.synthesis
    if syn.goal == "bistable":
        if scene.analysis.driver is None:
            return bistable.search_drivers(scene, name, spec_of)
        return bistable.search(scene, name, spec_of)
    if syn.goal != "stiffness" and scene.analysis.driver is None:
        return not_applicable(scene, name, f"{syn.goal} synthesis needs analysis.driver")
    kind = "load" if syn.goal == "stiffness" else "energy"

    def evaluate(s: float) -> tuple[float, analyses.Run]:
        sc = synthesised_scene(scene, s)
        r = analyses.run(build(sc, spec_of), kind)
        if r.exc is not None:
            raise RuntimeError(f"scale {s:.6g}: {r.exc}")
        return _measure(r, syn.goal, syn.output), r

    try:
        v0, run = evaluate(1.0)
        # first guess: response proportional to 1/s (stiffness) or s (critical load)
        target = syn.target
        if syn.goal == "stiffness":
            s1 = v0 / target if v0 * target > 0 else 1.0
        else:
            s1 = target / v0 if v0 > 0 else 1.0
        x0, f0 = 0.0, math.log(abs(v0)) - math.log(abs(target))
        x1, its = math.log(s1), 1
        while True:
            v1, run = evaluate(math.exp(x1))
            its += 1
            if abs(v1 - target) <= RTOL * abs(target):
                break
            f1 = math.log(abs(v1)) - math.log(abs(target)) if v1 * target > 0 else math.inf
            if not math.isfinite(f1) or f1 == f0:
                raise RuntimeError("response does not reach the target (sign or plateau)")
            if its > MAX_IT:
                raise RuntimeError(f"no convergence in {MAX_IT} secant steps")
            x0, f0, x1 = x1, f1, x1 - f1 * (x1 - x0) / (f1 - f0)
    except SceneError as err:
        return not_applicable(scene, name, str(err))
    except RuntimeError as err:
        return Solution(scene.name, name, "failed", f"synthesis: {err}")
    s = math.exp(x1)
    extras = dict(run.extras)
    extras["synthesis"] = {
        "goal": syn.goal,
        "target": syn.target,
        "achieved": v1,
        "scale": s,
        "EI": {m.id: m.E * s * m.I for m in scene.members if m.id in syn.members},
        "evaluations": its,
    }
    msg = f"EI scaled by {s:.6g} ({its} analyses); {syn.goal} = {v1:.6g}"
    if syn.goal == "critical-load":  # both stable positions, the barrier, both switching loads
        try:
            extras["bistable"] = bistable.bistable(run)
        except SolveError as err:
            return Solution(scene.name, name, "failed", f"bistable summary: {err}", run.steps)
        msg += "; " + bistable.describe(extras["bistable"])
    return Solution(scene.name, name, "converged", msg, tuple(run.steps), extras)
