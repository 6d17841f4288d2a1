"""The cost of a model on a scene: a CPU-time estimate that is stable, noisy-honest and cached.

What is timed: the model's own solve, ``api.run_model(model, scene, post=False)`` (no shapes,
no stress), in this process, with BLAS pinned to one thread and the garbage collector off (as
``timeit``: a collection belongs to no particular solve), by ``time.process_time`` (CPU time:
on a machine shared with other jobs wall time also counts the time the process was not
scheduled).

How long: the answer's own solve is a sample when it took ``FIRST_SAMPLE_S`` or more (below
that, cold caches and the timer make a first call 4-33 % slow; above it the first CPU time was
within 1-2 % of its repeats' median, ``reports.run.timing``).  Each sample runs the solve
``k`` times, ``k`` chosen from the first solve so that a sample takes at least ``SAMPLE_S``
(timer resolution and call overhead stay below 1e-3 of it).  Samples are taken until the 95 %
confidence interval of their median (distribution-free, ``scipy.stats.quantile_test``; the
range of the samples below 6 of them) has a half-width of at most ``REL`` of the median, or
``MAX_SAMPLES`` samples, or ``BUDGET_S`` CPU seconds spent (at least ``MIN_SAMPLES``), or
``WALL_BUDGET_S`` of wall time (a solve that waits costs little CPU).  A
solve slower than ``BUDGET_S`` is measured once (its first solve; its noise is then not
measured and given as 0: a first solve this long reads within a few % of its repeats, well
inside the pick's 20 % tie band).  The runner's timing
repeats of the same call (``reports.run.timing.repeat``, same conditions) are the first
samples, not solved again.  The estimate is the median
per solve, its noise that half-width (s); ``spent_s`` the CPU the samples cost beyond the solves
already made (the answer's, the timing repeats).

Cache: one JSON file per code version, ``$FLEXBENCH_CACHE`` (default ``~/.cache/flexbench/``)
``/costs-<version>.json``, keyed by the scene's content, the model name and its options.  The
version hashes the sources of what the timed call runs (``cases``, ``reduced_models``,
``fem_reference``, ``reports/api.py``) and of this module: a change to a report or a figure
does not invalidate it, a change to a solver does.  ``flexbench recommend`` and the runner
(``flexbench run``) read and write the same entries, so the CLI and the report rank the same
models by the same numbers.  Writers lock the file (``fcntl.flock``): the runner's pool workers
add entries concurrently.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import functools
import gc
import hashlib
import json
import os
import statistics
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

SAMPLE_S = 1e-3  # CPU s per sample at least (fast solves are batched)
MIN_SAMPLES = 3
MAX_SAMPLES = 20
# stop when the median's 95 % interval half-width is within 5 % of it: well inside the pick's
# 20 % tie band (reports.verdicts.pick.TIE); a tighter target mostly buys samples on a loaded
# machine (at load 12 on 2 cores most estimates ran into a 30-sample cap at 3 %)
REL = 0.05
# CPU s of samples after which the estimate stands as it is: 0.3 s cost the default run ~55 s
# of CPU on ~150 pairs of 20-300 ms, each solved again 3-7 times to move its estimate by a few %
BUDGET_S = 0.1
FIRST_SAMPLE_S = 0.02  # a first solve this long is a sample (module docstring)
WALL_BUDGET_S = 2.0  # wall s after which it stands too (a solve that mostly waits)
_PACKAGES = ("cases", "reduced_models", "fem_reference")
_FILES = ("reports/api.py", "reports/verdicts/cost.py")


@dataclasses.dataclass(frozen=True)
class Estimate:
    """CPU seconds per solve (median of samples), the half-width of its 95 % interval (s),
    the number of samples, whether it came from the cache and the CPU seconds its sampling
    cost beyond the solves already made (0 from the cache)."""

    cpu_s: float
    noise_s: float
    n: int
    cached: bool = False
    spent_s: float = 0.0

    def as_json(self) -> dict[str, Any]:
        """``{"cpu_s", "noise_s", "n", "cached", "spent_s"}``."""
        return dataclasses.asdict(self)


def cache_dir() -> Path:
    """``$FLEXBENCH_CACHE``, else ``~/.cache/flexbench``."""
    return Path(os.environ.get("FLEXBENCH_CACHE") or Path.home() / ".cache" / "flexbench")


@functools.cache
def code_version() -> str:
    """Hash of the sources the timed solve runs and of this module (see module docstring)."""
    import importlib

    root = Path(__file__).resolve().parents[2]  # the repository: _FILES are relative to it
    files = [root / f for f in _FILES]
    for name in _PACKAGES:
        for base in getattr(importlib.import_module(name), "__path__", []):
            files += sorted(Path(base).rglob("*.py"))
    h = hashlib.sha1()
    for f in files:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def key(scene: Any, name: str, options: Mapping | None) -> str:
    """Cache key: scene content (its file path left out), model name, options."""
    content = repr(dataclasses.replace(scene, path=""))
    opts = json.dumps(dict(options or {}), sort_keys=True, default=repr)
    return hashlib.sha1(f"{content}|{name}|{opts}".encode()).hexdigest()[:16]


def _path() -> Path:
    return cache_dir() / f"costs-{code_version()}.json"


def lookup(k: str) -> Estimate | None:
    """The cached estimate under key ``k`` (None: absent or unreadable)."""
    try:
        entry = json.loads(_path().read_text(encoding="utf-8"))[k]
        return Estimate(float(entry["cpu_s"]), float(entry["noise_s"]), int(entry["n"]), True)
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store(k: str, est: Estimate) -> None:
    """Add an estimate to the cache file (locked read-modify-write; never raises)."""
    path = _path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path.with_suffix(".lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                table = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                table = {}
            table[k] = {"cpu_s": est.cpu_s, "noise_s": est.noise_s, "n": est.n}
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps(table, sort_keys=True), encoding="utf-8")
            tmp.replace(path)
    except OSError:
        pass  # not cached: measured again next time


@contextlib.contextmanager
def quiet_process() -> Iterator[None]:
    """BLAS pinned to one thread and the garbage collector off while timing."""
    from threadpoolctl import threadpool_limits

    was_on = gc.isenabled()
    gc.disable()
    try:
        with threadpool_limits(1):
            yield
    finally:
        if was_on:
            gc.enable()


def half_width(samples: list[float]) -> float:
    """Half-width of the 95 % distribution-free interval of the samples' median (their
    range below 6 samples, where no such interval reaches 95 %)."""
    if len(samples) < 6:
        return (max(samples) - min(samples)) / 2
    from scipy.stats import quantile_test

    ci = quantile_test(np.asarray(samples), p=0.5).confidence_interval(0.95)
    return float(ci.high - ci.low) / 2


def measure(
    call: Callable[[], object], first_cpu_s: float, runs_cpu_s: Sequence[float] = ()
) -> Estimate:
    """Sample ``call`` until its median is stable (module docstring); ``first_cpu_s`` is the
    CPU time of the answer's own (untimed) solve.  ``WALL_BUDGET_S`` of wall time ends the
    sampling whatever the CPU count says: a solve that waits (I/O, a sleep) costs little CPU
    and would otherwise be batched thousands of times.

    ``runs_cpu_s`` are CPU times (s) of single calls of the same ``call`` already made under
    the same conditions (the runner's timing repeats: after the answer's solve, BLAS on one
    thread, GC off); each full group of ``k`` of them is a sample, so those solves are not
    made again; so is the first solve when it took ``FIRST_SAMPLE_S`` or more."""
    if first_cpu_s >= BUDGET_S:
        return Estimate(first_cpu_s, 0.0, 1)
    k = max(1, int(np.ceil(SAMPLE_S / max(first_cpu_s, 1e-7))))
    groups = len(runs_cpu_s) // k
    samples = [sum(runs_cpu_s[i * k : (i + 1) * k]) / k for i in range(groups)]
    if first_cpu_s >= FIRST_SAMPLE_S:  # k = 1 here
        samples.insert(0, first_cpu_s)
    wall_end = time.perf_counter() + WALL_BUDGET_S
    cpu0 = time.process_time()
    with quiet_process():
        while not _stable(samples, k, wall_end):
            t0, n = time.process_time(), 0
            while n < k and (n == 0 or time.perf_counter() < wall_end):
                call()
                n += 1
            samples.append((time.process_time() - t0) / n)
    spent = time.process_time() - cpu0
    return Estimate(statistics.median(samples), half_width(samples), len(samples), False, spent)


def _stable(samples: list[float], k: int, wall_end: float) -> bool:
    """Whether sampling stops (module docstring): never before a sample, then at the wall
    budget, else from ``MIN_SAMPLES`` on at the target interval, ``MAX_SAMPLES`` or
    ``BUDGET_S`` CPU seconds of samples (``k`` solves each)."""
    if not samples:
        return False
    if time.perf_counter() >= wall_end:
        return True
    if len(samples) < MIN_SAMPLES:
        return False
    if len(samples) >= 6 and half_width(samples) <= REL * statistics.median(samples):
        return True
    return len(samples) >= MAX_SAMPLES or sum(samples) * k >= BUDGET_S


def estimate(
    scene: Any,
    name: str,
    options: Mapping | None,
    call: Callable[[], object],
    first_cpu_s: float,
    runs_cpu_s: Sequence[float] = (),
) -> Estimate:
    """The cached estimate of ``name`` on ``scene`` (with ``options``), else measured by
    sampling ``call`` (the model's solve; ``runs_cpu_s``: CPU times of its calls already
    timed, ``measure``) and cached."""
    k = key(scene, name, options)
    hit = lookup(k)
    if hit is not None:
        return hit
    est = measure(call, first_cpu_s, runs_cpu_s)
    store(k, est)
    return est
