"""``replay`` on a deploy scene: the booms push from t = 0 and lock exactly at their length
(``deploy.booms_as_locks``), the mechanism settles and is probed."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.replay import events
from fem_reference.replay.run import replay_system
from fem_reference.statics.deploy import booms_as_locks
from reduced_models.base import Solution, Step


def replay_deploy(scene: Scene, model: object) -> Solution:
    """``replay`` on a deploy scene: the booms (``booms_as_locks``) push from t = 0 (ramped
    in), lock exactly when they reach their length, the mechanism settles; the settled state
    is probed (kick along the lowest mode, or the case's ``probe_node`` impulse).  One step:
    factor 2 (Part 2) when every boom locked, else the stall's extension progress."""
    locks = tuple(model.options.locks) + booms_as_locks(scene)
    opts = replace(model.options, locks=locks, probe="last")
    system = build(scene, model.n_elements)
    sol = replay_system(system, np.array([0.0]), scene=scene, case=scene.name, options=opts)
    if sol.status == "failed" and "locating the boom lock" in sol.message:
        # the lock search re-integrates one step at fractions of it; a step that large can
        # fail Newton there: once more with ten times tighter local error (smaller steps)
        opts = replace(opts, lte_tol=opts.lte_tol / 10)
        sol = replay_system(system, np.array([0.0]), scene=scene, case=scene.name, options=opts)
        sol = replace(sol, message=sol.message + " (retried with lte_tol / 10)")
    if not sol.steps:
        return Solution(scene.name, model.name, sol.status, sol.message, (), sol.extras)
    last = sol.steps[-1]
    pairs = events.resolve_locks(system, scene, booms_as_locks(scene))
    q = _settled_q(sol, system, pairs[0], last)
    ends = {e.get("ends") for e in sol.extras.get("events", []) if e.get("kind") == "lock"}
    out, factor, stalled = dict(last.outputs), 2.0, []
    for boom, pair in zip(scene.booms, pairs):  # every boom reported, none dropped
        ell = pair.geometry(q)[0] if q is not None else math.nan
        out[f"{boom.id}.length"] = ell
        if f"{boom.a} - {boom.b}" not in ends:
            ell0 = pair.geometry(np.zeros(system.ndof))[0]
            factor = min(factor, (ell - ell0) / (boom.length - ell0))
            stalled.append(f"boom {boom.id!r} stalled at length {ell:.6g}")
    locked = not stalled
    step = Step(
        factor, out, last.energy, last.iterations, last.stable, last.shapes, None, last.info
    )
    msg = "; ".join([sol.message, *stalled])
    extras = {**sol.extras, "boom_reached": locked}
    return Solution(scene.name, model.name, sol.status, msg, (step,), extras)


def _settled_q(sol: Solution, system: object, pair: object, last: Step) -> np.ndarray | None:
    """The settled state's DOFs: the history frame whose outputs match the settled step."""
    frames = sol.extras.get("frames", {})
    qs = frames.get("q") if isinstance(frames, dict) else None
    if qs is None or not len(qs):
        return None
    keys = [k for k in last.outputs if k.endswith((".x", ".y"))]
    best = min(qs, key=lambda q: max(abs(system.outputs(q)[k] - last.outputs[k]) for k in keys))
    return np.asarray(best)
