"""Synthesised scenes re-solved with ``fem-auto`` (issue 9: "Synthesised scenes are re-solved
with fem-auto in the report").

``fe_check(scene, sol)`` runs outside the timed solve, after the model's ``postprocess``
(``reports.api``; it lives in ``reports`` because it needs both the models and the FE): the
scene with the synthesised EI (``synthesis.synthesised_scene``) or, for the ``bistable`` search,
the driver sweep itself, is solved by ``fem-auto`` and the FE's own measure of the goal is put
beside the model's in ``extras["synthesis"]["fem-auto"]`` / ``extras["bistable"]["fem-auto"]``:
the output at factor_end, or the FE's equilibria, barrier and switching loads (grid extremum of
the FE path refined by a parabola through its neighbours).

When every stiffness of a driver sweep is in the synthesis members and no load is held, the
FE response at scale s is exactly s times that at scale 1 (forces, torques, energies; the
positions do not change): the unscaled FE sweep is solved once per scene and scaled.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from cases.schema import Driver, Scene
from fem_reference.auto import FEMAuto
from reduced_models.base import Solution, post_process
from reduced_models.mechanism.bistable import energy_scene
from reduced_models.mechanism.synthesis import synthesised_scene

FE_MODEL = "fem-auto"
_CACHE: dict[tuple, Solution] = {}


def _fe(scene: Scene) -> Solution:
    model = FEMAuto()
    reason = model.applies_to(scene)
    if reason:
        return Solution(scene.name, FE_MODEL, "not-applicable", str(reason))
    return post_process(model, scene, model.solve(scene))


def _proportional(scene: Scene) -> bool:
    """Does the driver response scale exactly with the synthesis members' EI?"""
    syn = scene.analysis.synthesis
    own = set(syn.members)
    return (
        not scene.loads
        and not scene.torsion_springs
        and all(m.kind == "rigid" or m.id in own for m in scene.members)
    )


def _scaled_fe(scene: Scene, scale: float) -> tuple[Solution, float]:
    """(FE solution of the synthesised scene, factor to apply to its forces and energies)."""
    if scene.analysis.synthesis.goal == "critical-load" and _proportional(scene):
        key = ("critical-load", scene.name, repr(scene))
        if key not in _CACHE:
            _CACHE[key] = _fe(synthesised_scene(scene, 1.0))
        return _CACHE[key], scale
    return _fe(synthesised_scene(scene, scale)), 1.0


def path_summary(scene: Scene, steps: tuple, extras: dict, fac: float = 1.0) -> dict:
    """Bistability of a reported driver path (any model): the first stable-unstable-stable
    triple of ``extras["equilibria"]``, barrier, and the switching loads from the grid
    (parabola through the extremum and its neighbours); forces and energies times ``fac``."""
    key = "driver.torque" if scene.analysis.driver.kind == "rotation" else "driver.force"
    x = np.array([s.factor for s in steps])
    F = fac * np.array([s.outputs[key] for s in steps])
    eq = extras.get("equilibria", [])
    kinds = [e["kind"] for e in eq]
    tri = ["stable", "unstable", "stable"]
    i = next((i for i in range(len(eq) - 2) if kinds[i : i + 3] == tri), None)
    if i is None:
        stab = [e["coordinate"] for e in eq if e["kind"] == "stable"]
        un = [e for e in eq if e["kind"] == "unstable"]
        out = {"bistable": False, "stable": stab}
        if un:
            out["forward"] = _extremum(x, F, x[0], un[0]["coordinate"])
        return out
    e1, eu, e2 = eq[i : i + 3]
    return {
        "bistable": True,
        "stable": [e1["coordinate"], e2["coordinate"]],
        "unstable": eu["coordinate"],
        "barrier": {
            "forward": fac * (eu["energy"] - e1["energy"]),
            "backward": fac * (eu["energy"] - e2["energy"]),
        },
        "critical": {
            "forward": _extremum(x, F, e1["coordinate"], eu["coordinate"]),
            "backward": _extremum(x, F, eu["coordinate"], e2["coordinate"]),
        },
    }


def _extremum(x: np.ndarray, F: np.ndarray, lo: float, hi: float) -> float:
    """Largest |F| on [lo, hi] of a sampled path, parabola-refined (signed)."""
    inside = np.flatnonzero((x - lo) * (x - hi) <= 0.0)
    k = int(inside[np.argmax(np.abs(F[inside]))])
    if 0 < k < len(F) - 1:
        f0, f1, f2 = F[k - 1], F[k], F[k + 1]
        den = f0 - 2 * f1 + f2
        if den * f1 < 0:  # a true extremum of |F| between the neighbours
            t = 0.5 * (f0 - f2) / den
            return float(f1 - 0.25 * (f0 - f2) * t)
    return float(F[k])


def fe_check(scene: Scene, sol: Solution) -> Solution:
    """``sol`` with the fem-auto check of its synthesised scene (module doc)."""
    a = scene.analysis
    if sol.status != "converged" or a.kind != "synthesis" or a.synthesis is None:
        return sol
    goal = a.synthesis.goal
    slot = "bistable" if goal == "bistable" else "synthesis"
    if slot not in sol.extras:  # not a synthesis the assembler ran
        return sol
    extras = dict(sol.extras)
    if goal == "bistable":  # the same sweep for every model: solved once per scene
        key = ("bistable", scene.name, repr(scene))
        if key not in _CACHE:
            _CACHE[key] = _fe(energy_scene(scene))
        fe, fac = _CACHE[key], 1.0
    else:
        syn = extras["synthesis"]
        fe, fac = (
            _scaled_fe(scene, syn["scale"])
            if goal == "critical-load"
            else (_fe(synthesised_scene(scene, syn["scale"])), 1.0)
        )
    check: dict = {"model": FE_MODEL, "status": fe.status}
    if fe.status != "converged" or not fe.steps:
        check["message"] = fe.message
    elif goal == "stiffness":
        v = float(fe.steps[-1].outputs[a.synthesis.output])
        check.update(
            achieved=v, relative_error=abs(v - a.synthesis.target) / abs(a.synthesis.target)
        )
    else:
        summ = path_summary(scene, fe.steps, fe.extras, fac)
        check["bistable"] = summ
        if goal == "critical-load":
            v = abs(
                summ["critical"]["forward"] if summ["bistable"] else summ.get("forward", np.nan)
            )
            check.update(
                achieved=v, relative_error=abs(v - a.synthesis.target) / a.synthesis.target
            )
    extras[slot] = {**extras[slot], FE_MODEL: check}
    return dataclasses.replace(sol, extras=extras)


__all__ = ["fe_check", "path_summary"]


def check_drivers(scene: Scene, sol: Solution) -> Solution:
    """A driver search re-solved by fem-auto: every bistable candidate's sweep, its FE
    summary in its ``extras["drivers"]`` entry (and in ``extras["bistable"]`` for the one
    shown)."""
    drivers = []
    for e in sol.extras["drivers"]:
        if e["bistable"]:
            # the FE sweeps the bistable stretch (a quarter of the stable-unstable distance
            # past the second stable position, inside the range the model swept): a sweep
            # on to a lock-up would fail the whole FE run
            s2, su, reach = e["stable"][1], e["unstable"], e["swept"][1]
            stop = s2 + 0.25 * (s2 - su)
            stop = stop if (reach - stop) * (stop - e["start"]) > 0 else reach
            keys = ("kind", "start", "node", "direction", "member")
            drv = Driver(stop=stop, **{k: e[k] for k in keys if k in e})
            sc = dataclasses.replace(
                scene, analysis=dataclasses.replace(scene.analysis, driver=drv)
            )
            one = dataclasses.replace(sol, extras={"bistable": e})
            e = fe_check(sc, one).extras["bistable"]
        drivers.append(e)
    extras = {**sol.extras, "drivers": drivers}
    label = extras.get("bistable", {}).get("label")
    shown = next((e for e in drivers if e["bistable"] and e["driver"] == label), None)
    if shown is not None and "fem-auto" in shown:
        extras["bistable"] = {**extras["bistable"], "fem-auto": shown["fem-auto"]}
    return dataclasses.replace(sol, extras=extras)
