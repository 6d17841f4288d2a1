"""Solving one pair (runs in the workers): build the model, solve it under the pair's limits,
time the solve alone and its repeats, post-process once, write the exports and serialise the
record (``store.record``; the record layout is in ``reports.run.runner``'s docstring).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from typing import Any

from cases.schema import Scene
from reports import api
from reports.run import limits, store, timing
from reports.run.exports import (
    export_outputs,
)
from reports.run.tables import (
    step_shapes,
)
from reports.verdicts import cost, pick


def solve_task(task: dict) -> dict:
    """Solve, time and serialise one pair; never raises (a crash becomes ``failed``).

    ``task["time_limit"]`` (s, optional) bounds the first solve; timing repeats stop early
    rather than run past it.
    """
    base = {k: task[k] for k in ("key", "case", "model", "role")}
    scene: Scene = task["scene"]
    limit = task.get("time_limit")
    try:
        model = api.build(task["model"], task["target"], task["n"], task["options"])
    except Exception as exc:
        return store.record(base, "failed", f"cannot build model: {type(exc).__name__}: {exc}")
    card = getattr(model, "card", None)
    card = store.jsonable(dataclasses.asdict(card)) if dataclasses.is_dataclass(card) else None
    timing.pin_blas()
    t_start, c_start = timing.clocks()
    sol = None
    try:
        with limits.guard(limit, task.get("memory_limit")):
            sol = api.run_model(model, scene, post=False)  # the solve alone is timed
            sol = limits.explain(sol, task.get("memory_limit"))
            first = (time.perf_counter() - t_start, time.process_time() - c_start)
            if sol.status == "not-applicable":
                return store.record(base, sol.status, sol.message, card=card)
            deadline = t_start + 0.8 * limit if limit else math.inf
            solve_again = lambda: api.run_model(model, scene, post=False)  # noqa: E731
            runs: list[float] = []  # the repeats' CPU s: the cost estimate's first samples
            times = timing.repeat(solve_again, first, task["timing"], deadline, runs)
            more = pick_inputs(task, solve_again, first[1], runs)
            sol, post_s, post_cpu_s = timing.timed(lambda: api.finish(model, scene, sol))
            times.update(post_s=post_s, post_cpu_s=post_cpu_s)
    except limits.LimitExceeded as exc:
        if sol is None:
            return store.record(base, "failed", str(exc), card=card, retry=True)
        policy = dataclasses.replace(task["timing"], cold_cap_s=0)
        times = timing.repeat(lambda: None, first, policy)
        more = {}
    trace = sol.extras.get("traceback") if isinstance(sol.extras, Mapping) else None
    steps, shapes, warnings = store.steps_json(sol)
    more["shape_steps"] = store.jsonable(step_shapes(sol))  # report: shapes along the path
    exports, export_warnings = export_outputs(task, sol)
    return store.record(
        base,
        sol.status,
        sol.message,
        steps=store.jsonable(steps),
        shapes=store.jsonable(shapes),
        extras=store.extras_json(dict(sol.extras)),
        card=card,
        timing=times,
        warnings=warnings + export_warnings,
        traceback=trace,
        exports=store.jsonable(exports),
        **more,
    )


def pick_inputs(
    task: dict, solve_again: Any, first_cpu_s: float, runs_cpu_s: Sequence[float] = ()
) -> dict:
    """A pick candidate's ``cost`` (``reports.verdicts.cost``: the estimate ``flexbench recommend``
    reads and writes, so the front page ranks by the same numbers) and a-priori
    ``unknowns``; {} for other pairs.  Sweep points (hundreds, timed once) get no estimate:
    their pick ranks by the one CPU time.  ``runs_cpu_s``: CPU s of the timing repeats of
    ``solve_again``, reused as samples."""
    scene, name = task["scene"], task["model"]
    if task["role"] != "model" and name not in pick.EXACT:
        return {}
    out: dict[str, Any] = {"unknowns": pick.unknowns(name, scene)}
    if scene.sweep_parent is None:
        est = cost.estimate(scene, name, task["options"], solve_again, first_cpu_s, runs_cpu_s)
        out["cost"] = est.as_json()
    return out


def solve_and_trim(task: dict) -> dict:
    """``solve_task`` in a pool worker, then the heap trimmed after a long pair (a long solve
    is the one that grows the heap; trimming costs ~1 ms)."""
    rec = solve_task(task)
    if ((rec.get("timing") or {}).get("first_cpu_s") or 0.0) >= 0.05:
        limits.trim_heap()
    return rec


def solve_batch(tasks: Sequence[dict]) -> list[dict]:
    """Several pairs in one worker call (amortises Dask's per-task overhead)."""
    return [solve_task(t) for t in tasks]
