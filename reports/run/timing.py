"""Timing of one pair: CPU and wall time of the solve, repeats, post-processing, BLAS pinning.

CPU time (``time.process_time``: every thread of the worker process) is the model's cost;
wall time is what a user waits, and on a machine shared with other jobs it also counts the
time the worker was not scheduled, so ratios between models are computed from CPU time.
BLAS libraries are pinned to one thread in the workers (``threadpoolctl``): OpenBLAS runs
``ddot`` and norms multi-threaded above ~10k entries, which on 2 shared cores made a
4096-element FE solve several times slower, and a pool of workers is the parallelism.

Repeats: the first call is the answer (its times ``first_s``/``first_cpu_s`` are kept); then
repeats (GC off, as in timeit) until their wall total reaches ``min_total_s`` (and at least
``min_runs`` repeats unless they took twice that) or ``max_runs`` repeats.  A first call
whose CPU time exceeds ``cold_cap_s`` is not repeated (n_repeats = 1, its own time).
"""

from __future__ import annotations

import gc
import math
import sys
import time
from collections.abc import Callable
from typing import Any

# s per pair (first solve) before it is failed: a pair this slow alone breaks the run's budget
# (here, not in the runner, so the CLI's help needs no runner import)
DEFAULT_TIME_LIMIT = 60.0
QUICK_TIME_LIMIT = 20.0

_pinned_modules = -1  # len(sys.modules) when BLAS was last pinned


def pin_blas() -> None:
    """Limit every loaded BLAS/OpenMP pool to one thread (again after new imports).

    A library loaded after the last call (scipy ships its own OpenBLAS) is caught by the next
    call; the check is one ``len(sys.modules)``.
    """
    global _pinned_modules
    if len(sys.modules) == _pinned_modules:
        return
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)
    _pinned_modules = len(sys.modules)


def clocks() -> tuple[float, float]:
    """(wall, cpu) clock readings in seconds (``perf_counter``, ``process_time``)."""
    return time.perf_counter(), time.process_time()


def _stats(prefix: str, values: list[float]) -> dict[str, float]:
    import statistics  # here: fractions and decimal cost a one-off solve ~10 ms to import

    return {
        f"{prefix}median_s": statistics.median(values),
        f"{prefix}min_s": min(values),
        f"{prefix}max_s": max(values),
        f"{prefix}spread_s": max(values) - min(values),
    }


def repeat(
    call: Callable[[], object],
    first: tuple[float, float],
    policy: Any,
    deadline: float = math.inf,
    runs_cpu_s: list[float] | None = None,
) -> dict[str, float]:
    """Wall and CPU statistics of ``call`` (see module docstring).

    Parameters
    ----------
    call : the timed solve.
    first : (wall, cpu) seconds of the first call.
    policy : a ``runner.TimingPolicy`` (min_total_s, max_runs, cold_cap_s, min_runs).
    deadline : ``perf_counter`` time after which no repeat is started.
    runs_cpu_s : if given, the CPU seconds of each repeat are appended to it (the cost
        estimate's first samples, ``reports.verdicts.cost.measure``).

    Returns
    -------
    dict with wall ``median_s``, ``min_s``, ``max_s``, ``spread_s`` and the same with a
    ``cpu_`` prefix, plus ``n_repeats``, ``first_s``, ``first_cpu_s``, ``total_s``.
    """
    first_s, first_cpu = first
    walls, cpus = [first_s], [first_cpu]
    # CPU, not wall: on a loaded machine a cheap pair's wall time would skip its repeats
    repeated = first_cpu <= policy.cold_cap_s and time.perf_counter() + first_s < deadline
    if repeated:
        walls, cpus = [], []
        gc_was_on = gc.isenabled()
        gc.disable()  # as timeit does: a collection is not the model's cost
        try:
            while True:
                w0, c0 = clocks()
                call()
                c1 = time.process_time()
                dt = time.perf_counter() - w0
                walls.append(dt)
                cpus.append(c1 - c0)
                total = sum(walls)
                many = len(walls) >= policy.min_runs or total >= 2 * policy.min_total_s
                enough = total >= policy.min_total_s and many
                late = time.perf_counter() + dt > deadline  # the next repeat would overrun
                if enough or late or len(walls) >= policy.max_runs:
                    break
        finally:
            if gc_was_on:
                gc.enable()
    if repeated and runs_cpu_s is not None:
        runs_cpu_s.extend(cpus)
    out = _stats("", walls) | _stats("cpu_", cpus)
    out.update(
        n_repeats=len(walls),
        first_s=first_s,
        first_cpu_s=first_cpu,
        total_s=first_s + (sum(walls) if repeated else 0.0),
    )
    return out


def timed(call: Callable[[], Any]) -> tuple[Any, float, float]:
    """``(call(), wall s, cpu s)`` of one call."""
    w0, c0 = clocks()
    value = call()
    c1 = time.process_time()
    return value, time.perf_counter() - w0, c1 - c0
