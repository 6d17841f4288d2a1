"""How the benchmarks measure: median CPU time of a call (``time.process_time``, after one
warm-up, garbage collection off), a model's solve and post-processing as the runner times
them, a scaling exponent, and the table cells."""

from __future__ import annotations

import gc
import statistics
import time
from collections.abc import Callable, Sequence

import numpy as np

from cases.schema import Scene
from reports import api


def cpu_median(call: Callable[[], object], rounds: int) -> tuple[float, float, float]:
    """(min, median, max) CPU seconds of ``call`` over ``rounds`` calls after one warm-up."""
    call()
    ts = []
    gc.disable()
    try:
        for _ in range(rounds):
            c0 = time.process_time()
            call()
            ts.append(time.process_time() - c0)
    finally:
        gc.enable()
    return min(ts), statistics.median(ts), max(ts)


def solve_cost(scene: Scene, name: str, rounds: int) -> tuple[float, float, float] | None:
    """CPU (min, median, max) seconds of one model's solve on a scene; None if it declines
    or fails."""
    model = api.make_model(name, scene)
    sol = api.run_model(model, scene, post=False)
    if sol.status != "converged":
        return None
    # long solves: fewer rounds (the spread says how noisy)
    n = rounds if sol_cost_guess(model, scene) < 0.2 else max(3, rounds // 3)
    return cpu_median(lambda: api.run_model(model, scene, post=False), n)


def sol_cost_guess(model: object, scene: Scene) -> float:
    """CPU seconds of one solve (one call)."""
    c0 = time.process_time()
    api.run_model(model, scene, post=False)
    return time.process_time() - c0


def post_cost(scene: Scene, name: str, rounds: int) -> float | None:
    """Median CPU seconds of a model's post-processing of its own solution."""
    model = api.make_model(name, scene)
    sol = api.run_model(model, scene, post=False)
    if not sol.steps:
        return None
    return cpu_median(lambda: api.finish(model, scene, sol), rounds)[1]


def fit_exponent(ns: Sequence[int], ts: Sequence[float]) -> float:
    """Least-squares slope of log t against log N."""
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def ms(t: float | None) -> str:
    """Seconds as milliseconds for a table cell (``n/a`` when not measured)."""
    return "n/a" if t is None else f"{t * 1e3:.3g}"


def verdict(value: float, limit: float) -> str:
    """``met``, or by how much ``value`` missed its ``limit``."""
    return "met" if value <= limit else f"missed by {value / limit:.2f}x"
