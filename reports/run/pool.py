"""Where the pairs run: serially, on a local process pool or on a Dask cluster
(``execute``), each finished record yielded at once.

The local pool keeps at most one task in flight per worker, kills a worker still running
``KILL_GRACE_S`` after its pair's time limit, and finds the pair that took a dying worker with
it by re-running the pairs in flight with it one at a time.
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import math
import multiprocessing
import os
import time
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

from reports import api
from reports.run import store
from reports.run.pair import solve_and_trim, solve_batch, solve_task

KILL_GRACE_S = 5.0  # after the soft limit (SIGALRM in the worker), the worker is killed


def _crashed(task: dict, why: str) -> dict:
    """A pair lost to its worker (killed, timed out): ``failed``, retried on resume."""
    base = {k: task[k] for k in ("key", "case", "model", "role")}
    return store.record(base, "failed", why, retry=True)


# -- execution backends -----------------------------------------------------------------------
def _preimport(tasks: Iterable[dict]) -> None:
    """Import model modules once before forking so no worker pays it inside a timing."""
    for target in {t["target"] for t in tasks if "target" in t}:  # not figure/teaching jobs
        try:
            api.factory(target)
        except Exception:
            pass  # the task itself will report the import error


def _pool_context() -> multiprocessing.context.BaseContext:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _kill(ex: cf.ProcessPoolExecutor) -> None:
    """Stop a pool now: pending work cancelled, running workers terminated."""
    procs = list((getattr(ex, "_processes", None) or {}).values())  # private, guarded
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(2)


def _submit(
    ex: cf.ProcessPoolExecutor, running: dict, task: dict, suspect: bool, origin: Any
) -> None:
    """Submit one task; if the pool has just died, put it back into ``origin`` and re-raise."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        fut = ex.submit(task.get("call", solve_and_trim), task)  # or a figure job (overlap.py)
    except BrokenProcessPool:
        origin.appendleft(task)
        raise
    running[fut] = (task, time.monotonic(), suspect)


def run_pool(tasks: Sequence[dict], workers: int, time_limit: float | None = None) -> Iterator:
    """Local process pool, at most one task in flight per worker (so a task's start time is
    known).  A pair running past ``time_limit`` + ``KILL_GRACE_S`` has its worker killed; a worker
    that dies takes only its own pair (the pairs in flight with it are re-run one at a time
    to find the culprit).  Killed and timed-out pairs are ``failed`` and retried on resume.
    A deque ``tasks`` is used as the queue itself: the caller may add jobs while iterating."""
    from concurrent.futures.process import BrokenProcessPool

    pending = tasks if isinstance(tasks, collections.deque) else collections.deque(tasks)
    suspects: collections.deque = collections.deque()  # in flight when a worker died
    hard = time_limit + KILL_GRACE_S if time_limit else math.inf
    while pending or suspects:
        ex = cf.ProcessPoolExecutor(workers, mp_context=_pool_context())
        running: dict = {}  # future -> (task, submit time, suspect?)
        broken = killed = False

        try:
            while (pending or suspects or running) and not (broken or killed):
                try:
                    if suspects and not running:  # a suspect always runs alone
                        _submit(ex, running, suspects.popleft(), True, suspects)
                    while pending and not suspects and len(running) < workers:
                        _submit(ex, running, pending.popleft(), False, pending)
                except BrokenProcessPool:
                    broken = True
                    continue
                done, _ = cf.wait(running, timeout=0.25, return_when=cf.FIRST_COMPLETED)
                for fut in done:
                    task, _, suspect = running.pop(fut)
                    try:
                        yield fut.result()
                    except BrokenProcessPool:
                        broken = True
                        if suspect:
                            yield _crashed(task, "worker process died while solving")
                        else:
                            suspects.append(task)
                    except Exception as exc:  # pickling errors and the like
                        yield _crashed(task, f"worker error: {type(exc).__name__}: {exc}")
                now = time.monotonic()
                for fut, (task, t0, _) in list(running.items()):
                    if now - t0 > hard and task.get("killable", True):
                        running.pop(fut)
                        yield _crashed(task, f"time limit of {time_limit:g} s exceeded (killed)")
                        killed = True
            # tasks still in flight: after a death any of them may be the culprit
            for task, _, suspect in running.values():
                if broken or suspect:
                    suspects.append(task)
                else:
                    pending.appendleft(task)
        finally:
            if broken or killed or running:
                _kill(ex)
            else:
                ex.shutdown(wait=True)


def run_dask(tasks: Sequence[dict], address: str) -> Iterator[dict]:
    """The same tasks on a Dask cluster, batched (about four batches per worker thread)."""
    from distributed import Client, as_completed

    client = Client(address, timeout="15s")
    try:
        threads = max(1, sum(client.nthreads().values()))
        size = max(1, math.ceil(len(tasks) / (4 * threads)))
        batches = [list(tasks[i : i + size]) for i in range(0, len(tasks), size)]
        futs = client.map(solve_batch, batches, pure=False)
        owner = {f.key: b for f, b in zip(futs, batches)}
        for fut in as_completed(futs):
            try:
                yield from fut.result()
            except Exception as exc:
                for t in owner[fut.key]:
                    yield _crashed(t, f"dask task failed: {type(exc).__name__}: {exc}")
    finally:
        client.close()


def execute(
    tasks: Sequence[dict],
    workers: int | None = None,
    dask: str | None = None,
    time_limit: float | None = None,
) -> Iterator[dict]:
    """Records as they finish (order not guaranteed)."""
    if not tasks:
        return iter(())
    if dask:
        return run_dask(tasks, dask)
    workers = workers or os.cpu_count() or 1
    if workers == 1 or len(tasks) == 1:
        return (solve_task(t) for t in tasks)
    _preimport(tasks)
    return run_pool(tasks, min(workers, len(tasks)), time_limit)
