"""``replay`` on a deploy scene: the booms push from t = 0 and lock exactly at their length
(``deploy.booms_as_locks``), the mechanism settles and is probed."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import scipy.sparse.linalg as spla

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.replay import events, modes
from fem_reference.replay.deploy_history import time_history
from fem_reference.replay.probe import kick, unprobed
from fem_reference.replay.run import replay_system
from fem_reference.statics.deploy import booms_as_locks
from reduced_models.base import Solution, Step

# the thesis's perturbation (seed 001, Chapter 5): "1N impulse forces using the STEP function
# on Joint 4"; neither the STEP's duration nor its direction is given: 1 N for 10 ms, at 45
# deg downwards, so it both moves the mechanism and pushes on the boom (where a damper gives)
IMPULSE_NODE = "J4"
IMPULSE = (0.01 / math.sqrt(2), -0.01 / math.sqrt(2))  # N s: 1 N x 10 ms, 45 deg down


def replay_deploy(scene: Scene, model: object) -> Solution:
    """``replay`` on a deploy scene: the booms (``booms_as_locks``) push from t = 0 (ramped
    in), lock exactly when they reach their length, the mechanism settles; the settled state
    is probed (kick along the lowest mode, or the case's ``probe_node`` impulse).  One step:
    factor 2 (Part 2) when every boom locked, else the stall's extension progress."""
    locks = tuple(model.options.locks) + booms_as_locks(scene)
    opts = replace(model.options, locks=locks, probe="last")
    probes = _ProbeBoth(scene, opts, record=opts.deploy_start != "static")
    if opts.deploy_start == "static":
        from fem_reference.replay.deploy_static import replay_static

        return replay_static(scene, model, probes)
    system = build(scene, model.n_elements)
    sol = replay_system(
        system, np.array([0.0]), scene=scene, case=scene.name, options=opts, stability=probes
    )
    if sol.status == "failed" and "locating the boom lock" in sol.message:
        # the lock search re-integrates one step at fractions of it; a step that large can
        # fail Newton there: once more with ten times tighter local error (smaller steps)
        opts = replace(opts, lte_tol=opts.lte_tol / 10)
        sol = replay_system(
            system, np.array([0.0]), scene=scene, case=scene.name, options=opts, stability=probes
        )
        sol = replace(sol, message=sol.message + " (retried with lte_tol / 10)")
    if not sol.steps:
        return Solution(scene.name, model.name, sol.status, sol.message, (), sol.extras)
    last = sol.steps[-1]
    pairs = events.resolve_locks(system, scene, booms_as_locks(scene))
    q = probes.settled if probes.settled is not None else _settled_q(sol, system, last)
    ends = {e.get("ends") for e in sol.extras.get("events", []) if e.get("kind") == "lock"}
    out, factor, stalled = dict(last.outputs), 2.0, []
    for boom, pair in zip(scene.booms, pairs):  # every boom reported, none dropped
        ell = pair.geometry(q)[0] if q is not None else math.nan
        out[f"{boom.id}.length"] = ell
        damper = boom.stop == "damper" and ell >= boom.length  # its stop holds it (no latch)
        if f"{boom.a} - {boom.b}" not in ends and not damper:
            ell0 = pair.geometry(np.zeros(system.ndof))[0]
            factor = min(factor, (ell - ell0) / (boom.length - ell0))
            stalled.append(f"boom {boom.id!r} stalled at length {ell:.6g}")
    locked = not stalled
    step = Step(
        factor, out, last.energy, last.iterations, last.stable, last.shapes, None, last.info
    )
    msg = "; ".join([sol.message, *stalled])
    extras = {**sol.extras, "boom_reached": locked}
    extras["time_history"] = time_history(
        scene, system, sol.extras["frames"], pairs, sol.extras.get("events", []),
        last.info.get("t_settled", math.nan), q,
    )  # fmt: skip
    if probes.perturbed is not None:
        extras["time_history"]["perturbation"] = probes.perturbed
    if probes.impulse is not None:
        extras["impulse_probe"] = probes.impulse
    return Solution(scene.name, model.name, sol.status, msg, (step,), extras)


def _settled_q(sol: Solution, system: object, last: Step) -> np.ndarray | None:
    """The settled state's DOFs: the history frame whose outputs match the settled step."""
    frames = sol.extras.get("frames", {})
    qs = frames.get("q") if isinstance(frames, dict) else None
    if qs is None or not len(qs):
        return None
    keys = [k for k in last.outputs if k.endswith((".x", ".y"))]
    best = min(qs, key=lambda q: max(abs(system.outputs(q)[k] - last.outputs[k]) for k in keys))
    return np.asarray(best)


class _ProbeBoth:
    """``replay_system``'s stability hook on a deploy: the tangent test and the modal kick
    (``run._stability``), then, when the probe is wanted and the scene has the node, the
    thesis's perturbation -- an impulse on ``IMPULSE_NODE`` (or the case's ``probe_node``)
    -- from the same settled state, timed on its own (``impulse``: verdict, peak, cpu_s)."""

    def __init__(self, scene: Scene, opts: object, record: bool = True) -> None:
        self.record = record  # replay the impulse once more into the history (figures)
        self.node = opts.probe_node or (IMPULSE_NODE if _has_node(scene, IMPULSE_NODE) else None)
        self.vec = tuple(opts.probe_impulse) if opts.probe_node else IMPULSE
        self.impulse: dict | None = None
        self.settled: np.ndarray | None = None  # the settled state's DOFs
        self.perturbed: dict | None = None  # the recorded response to the impulse

    def __call__(self, run: object, s: object, chk: dict, want: str, scene: Scene) -> tuple:
        eig, mode = modes.tangent_test(chk["K"], chk["G"], run.M)
        pr = unprobed(run, eig, want)
        if pr is not None:
            return eig, pr
        t0 = time.process_time()
        pr = kick(run, s, eig, mode, scene)
        if run.o.probe_node is not None:  # the case's own impulse was the probe
            imp = dict(pr)
        elif self.node is None:
            return eig, pr
        else:
            saved, t0 = run.o, time.process_time()
            run.o = replace(saved, probe_node=self.node, probe_impulse=self.vec)
            try:
                imp = kick(run, s, eig, mode, scene)
            finally:
                run.o = saved
        imp.update(node=self.node, impulse=list(self.vec), cpu_s=time.process_time() - t0)
        self.impulse, self.settled = imp, s.q.copy()
        if self.record:
            self.perturbed = _record_impulse(run, s, imp["node"], self.vec, imp.get("time", 0.0))
        return eig, pr


def _record_impulse(run: object, s: object, node: str, vec: tuple, seconds: float) -> dict:
    """The thesis's "before and after perturbation" (Figures 5-26, 5-27): the impulse given
    again from the settled state ``s``, integrated into the run's history for ``seconds``
    (at least two lowest periods).  Returns its start time and the impulse."""
    f = np.zeros(run.sys.ndof)
    for k, i, c in events.node_map(run.sys, node)[1]:
        f[i] += c * vec[k]
    v0 = spla.spsolve(run.M.tocsc(), f)
    run.s = run.integ.start(s.t, s.lam, s.q, s.v + v0)
    run.advance(s.t + max(seconds, 2.0 * run.T1), lambda t: s.lam)
    return {"t": float(s.t), "node": node, "impulse": list(vec)}


def _has_node(scene: Scene, node: str) -> bool:
    return any(n.id == node for n in scene.nodes) and any(node in (m.a, m.b) for m in scene.members)
