"""Flexural-stiffness, critical-load and stable-position synthesis (DAS-2D "Synthesis routines").

The EI of the chosen members is scaled by one factor s (E -> s E); s solves

* ``stiffness``: output(s) at factor_end of the load ramp = target;
* ``critical-load``: the largest |driving force| of the energy sweep before the first
  unstable equilibrium (the switching load of a bistable mechanism) = target;

by secant iterations in log s started from the proportional guess (exact when every load
path scales with EI, e.g. a member-only bistable mechanism), safeguarded (``_log_secant``):
a step changes EI by at most ``MAX_LOG_STEP``, stays inside a sign change once one is
seen, is halved back while the analysis fails, and s stays within 1/``SCALE_MAX`` ..
``SCALE_MAX``; a target the response does not reach there fails with the range it spans.
``stable-position`` scales a rigid link's length instead (its end-b node moves along it)
until the second stable position of the energy sweep is at the target driver coordinate
(DAS-2D "Stable Position Synthesis").
The answer is the path of the synthesised scene (``synthesised_scene``), with
``extras["synthesis"]``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from cases.limits import state_violation
from cases.schema import Member, Scene
from reduced_models.base import Solution, not_applicable
from reduced_models.mechanism import analyses, bistable
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.newton import SolveError
from reduced_models.mechanism.system import SceneError

MAX_IT = 30
RTOL = 1e-9
S_STEP = 0.02  # second secant point of the stable-position synthesis (link length x 1.02)
HALVINGS = 6  # a secant step halved at most this often (the analysis fails past it)
MAX_LOG_STEP = math.log(100.0)  # a secant step scales EI by at most 100x
SCALE_MAX = 1e6  # EI scaled within 1e-6 .. 1e6 (a target beyond is out of reach)


def synthesised_scene(scene: Scene, scale: float) -> Scene:
    """The scene with E of the synthesis members scaled by ``scale`` (a stable-position
    synthesis: its link's length, the end-b node moved along the link) and the analysis
    replaced by the one the goal runs (``load`` or ``energy``)."""
    syn = scene.analysis.synthesis
    kind = "load" if syn.goal == "stiffness" else "energy"
    analysis = replace(scene.analysis, kind=kind, synthesis=None)
    if syn.goal == "stable-position":
        link = scene.member(syn.members[0])
        a, b = scene.node(link.a), scene.node(link.b)
        moved = replace(b, x=a.x + scale * (b.x - a.x), y=a.y + scale * (b.y - a.y))
        nodes = tuple(moved if n.id == b.id else n for n in scene.nodes)
        return replace(scene, nodes=nodes, analysis=analysis)
    members = tuple(replace(m, E=m.E * scale) if m.id in syn.members else m for m in scene.members)
    return replace(scene, members=members, analysis=analysis)


def _second_stable(run: analyses.Run) -> float:
    """Driver coordinate of the second stable position of an energy sweep (the stable
    equilibrium after the first unstable one); raises SolveError when there is none."""
    b = bistable.bistable(run)
    if not b["bistable"]:
        raise SolveError(f"no second stable position: {b['reason']}")
    return float(b["stable"][1])


def _stable_position(scene: Scene, name: str, spec_of: Callable[[Member], tuple]) -> Solution:
    """Stable-position synthesis: the link length scale s with second stable position =
    target, by secant iterations on s from 1 and 1 + ``S_STEP`` (the position moves smoothly
    with the link length)."""
    syn = scene.analysis.synthesis

    def evaluate(s: float) -> tuple[float, analyses.Run]:
        r = analyses.run(build(synthesised_scene(scene, s), spec_of), "energy")
        if r.exc is not None and "equilibria" not in r.extras:
            raise SolveError(f"link scale {s:.6g}: {r.exc}")
        return _second_stable(r) - syn.target, r

    def backtracked(x0: float, x1: float) -> tuple[float, float, analyses.Run, int]:
        """evaluate(x1), the step from x0 halved while the scene at x1 has no second stable
        position (a secant step past the lengths where it exists: where it lands depends on
        round-off, so the drawing's encoding would decide whether the synthesis succeeds)."""
        for k in range(HALVINGS + 1):
            try:
                return (x1, *evaluate(x1), k + 1)
            except SolveError:
                if k == HALVINGS:
                    raise
                x1 = 0.5 * (x0 + x1)
        raise AssertionError("unreachable")

    try:
        x0, x1 = 1.0, 1.0 + S_STEP
        f0, _ = evaluate(x0)
        its = 1
        while True:
            x1, f1, run, n = backtracked(x0, x1)
            its += n
            if abs(f1) <= RTOL * max(abs(syn.target), 1.0):
                break
            if f1 == f0 or its > MAX_IT:
                raise SolveError("the second stable position does not reach the target")
            x0, f0, x1 = x1, f1, x1 - f1 * (x1 - x0) / (f1 - f0)
    except SceneError as err:
        return not_applicable(scene, name, str(err))
    except (SolveError, np.linalg.LinAlgError) as err:
        return Solution(scene.name, name, "failed", f"synthesis: {err}")
    link = syn.members[0]
    length = x1 * scene.member_length(link)
    extras = dict(run.extras)
    extras["synthesis"] = {
        "goal": syn.goal,
        "target": syn.target,
        "achieved": syn.target + f1,
        "scale": x1,
        "lengths": {link: length},
        "evaluations": its,
    }
    extras["bistable"] = bistable.bistable(run)
    msg = f"{link} length {length:.6g} (x {x1:.6g}, {its} analyses); second stable position "
    msg += f"{syn.target + f1:.6g}; " + bistable.describe(extras["bistable"])
    return Solution(scene.name, name, "converged", msg, tuple(run.steps), extras)


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
    if syn.goal == "stable-position":
        return _stable_position(scene, name, spec_of)
    kind = "load" if syn.goal == "stiffness" else "energy"

    def evaluate(s: float) -> tuple[float, analyses.Run]:
        sc = synthesised_scene(scene, s)
        r = analyses.run(build(sc, spec_of), kind)
        # a trial design whose states stretch a member beyond the elastic models (or place a
        # tip beyond an approximate model's reach) is no design: the search halves back
        why = r.exc or next(
            (w for st in r.steps if (w := state_violation(sc, st.outputs, math.inf))), None
        )
        if why is not None:
            raise RuntimeError(f"scale {s:.6g}: {why}")
        return _measure(r, syn.goal, syn.output), r

    try:
        x1, v1, run, its = _log_secant(evaluate, syn.target, syn.goal == "stiffness")
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


def _log_secant(evaluate: Callable, target: float, softens: bool) -> tuple:
    """``(log s, value, run, analyses)`` with ``evaluate(s)`` = ``(value, run)`` at
    ``target`` (relative ``RTOL``): secant iterations on ``g(x) = ln|value| - ln|target|``,
    x = ln s, from 0 and the proportional guess (value ~ 1/s where the response
    ``softens``, ~ s otherwise), safeguarded as the module docstring says.  Raises
    RuntimeError with the reason (the range the response spans where the target is out of
    reach)."""
    lo, hi = -math.log(SCALE_MAX), math.log(SCALE_MAX)
    seen: list[tuple[float, float]] = []  # (x, value) of every analysis that ran

    def g(v: float) -> float:
        if v * target <= 0.0:
            raise RuntimeError(f"the response is {v:.6g}: not of the target's sign at scale 1")
        return math.log(abs(v)) - math.log(abs(target))

    def reach(why: str) -> RuntimeError:
        xs, vs = zip(*seen)
        return RuntimeError(
            f"target {target:.6g} out of reach ({why}): the response spans {min(vs):.6g} to "
            f"{max(vs):.6g} for EI scaled {math.exp(min(xs)):.3g} to {math.exp(max(xs)):.3g}"
        )

    v0, run = evaluate(1.0)
    seen.append((0.0, v0))
    x0, g0 = 0.0, g(v0)
    x1 = float(np.clip(g0 if softens else -g0, -MAX_LOG_STEP, MAX_LOG_STEP))
    its, sign_change = 1, None  # (x, g) of the last point on the other side of the target
    while True:
        for k in range(HALVINGS + 1):  # halved back towards x0 while the analysis fails
            try:
                v1, run = evaluate(math.exp(x1))
                break
            except RuntimeError as err:
                its += 1
                if k == HALVINGS:
                    why = f"past scale {math.exp(x1):.3g} the analysis fails: {err}"
                    raise reach(why) from None
                x1 = 0.5 * (x0 + x1)
        its += 1
        seen.append((x1, v1))
        if abs(v1 - target) <= RTOL * abs(target):
            return x1, v1, run, its
        if v1 * target <= 0.0:
            raise reach(f"at scale {math.exp(x1):.3g} the response changes sign")
        g1 = g(v1)
        if g1 * g0 < 0.0:
            sign_change = (x0, g0)
        if g1 == g0 or its > MAX_IT:
            raise reach("it stops moving" if g1 == g0 else f"{MAX_IT} analyses")
        x2 = x1 - g1 * (x1 - x0) / (g1 - g0)
        if sign_change is not None and not min(x1, sign_change[0]) < x2 < max(x1, sign_change[0]):
            x2 = 0.5 * (x1 + sign_change[0])  # the secant left the bracket: bisect it
        x2 = float(np.clip(x2, x1 - MAX_LOG_STEP, x1 + MAX_LOG_STEP))
        if not lo <= x2 <= hi:
            if x1 in (lo, hi):
                raise reach("at the scale bound")
            x2 = min(max(x2, lo), hi)
        x0, g0, x1 = x1, g1, x2
