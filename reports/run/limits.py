"""Time and memory limits for one solve, in a worker process, a Dask thread or the CLI.

``guard(seconds, memory_mb)`` bounds the code in its ``with`` block:

* on the main thread of a process (local pool workers, ``flexbench solve``, serial runs) the
  time limit is a ``SIGALRM`` timer and the memory limit an address-space rlimit
  (``RLIMIT_AS``) set ``memory_mb`` above the process's current size, so an allocation past
  it raises ``MemoryError`` inside the model;
* on any other thread (Dask workers run tasks in threads) a watchdog thread checks the clock
  and the process's resident size every ``POLL_S`` and raises ``LimitExceeded`` in the solving
  thread (``PyThreadState_SetAsyncExc``: delivered at the next Python bytecode, so a single
  long C call finishes first).  The resident size is the whole worker's: with several
  threads per Dask worker a pair may be charged for its neighbours' memory (run Dask workers
  with one thread each -- numpy-bound solves gain nothing from more under the GIL).

``LimitExceeded`` is a ``BaseException``: a model's ``except Exception`` cannot swallow it.
A ``MemoryError`` the model turned into a ``failed`` Solution is renamed by ``explain``.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import os
import signal
import threading
import time
from collections.abc import Iterator

try:
    import resource
except ImportError:  # not on Windows: no rlimit, the watchdog still bounds memory
    resource = None  # type: ignore[assignment]

DEFAULT_MEMORY_LIMIT_MB = 4096.0  # per pair; the FE at 1000 elements needs ~200 MB
POLL_S = 0.05  # watchdog period
_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


class LimitExceeded(BaseException):
    """A solve ran past its time or memory limit; ``str()`` is the record's message."""

    def __init__(self, kind: str = "time", limit: float = 0.0) -> None:
        unit = "s" if kind == "time" else "MB"
        super().__init__(f"{kind} limit of {limit:g} {unit} exceeded")
        self.kind, self.limit = kind, limit


def _statm(field: int) -> int | None:
    """Virtual (0) or resident (1) size of this process in bytes (Linux), else None."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[field]) * _PAGE
    except (OSError, ValueError, IndexError):
        return None


@contextlib.contextmanager
def guard(seconds: float | None, memory_mb: float | None = None) -> Iterator[None]:
    """Raise ``LimitExceeded`` (time) past ``seconds``; bound memory growth to ``memory_mb``.

    Parameters
    ----------
    seconds : wall-clock limit in s (None or 0: none).
    memory_mb : growth allowed beyond the current process size, MB (None or 0: none).
    """
    if threading.current_thread() is threading.main_thread():
        with _alarm(seconds), _rlimit(memory_mb):
            yield
    else:
        with _watchdog(seconds, memory_mb):
            yield


@contextlib.contextmanager
def _alarm(seconds: float | None) -> Iterator[None]:
    if not seconds or not hasattr(signal, "setitimer"):
        yield
        return

    def _raise(_signum: int, _frame: object) -> None:  # signal handler signature
        raise LimitExceeded("time", seconds)

    previous = signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, float(seconds))
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def _rlimit(memory_mb: float | None) -> Iterator[None]:
    size = _statm(0)
    if not memory_mb or resource is None or size is None:
        yield
        return
    old = resource.getrlimit(resource.RLIMIT_AS)
    cap = size + int(memory_mb * 2**20)
    if old[1] != resource.RLIM_INFINITY:
        cap = min(cap, old[1])
    resource.setrlimit(resource.RLIMIT_AS, (cap, old[1]))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, old)


@contextlib.contextmanager
def _watchdog(seconds: float | None, memory_mb: float | None) -> Iterator[None]:
    if not seconds and not memory_mb:
        yield
        return
    target = threading.get_ident()
    done = threading.Event()
    start, base = time.monotonic(), _statm(1) or 0

    def watch() -> None:
        while not done.wait(POLL_S):
            if seconds and time.monotonic() - start > seconds:
                exc = LimitExceeded("time", seconds)
            elif memory_mb and (_statm(1) or 0) - base > memory_mb * 2**20:
                exc = LimitExceeded("memory", memory_mb)
            else:
                continue
            _async_raise(target, exc)
            return

    dog = threading.Thread(target=watch, name="flexbench-limits", daemon=True)
    dog.start()
    try:
        yield
    finally:
        done.set()
        dog.join()
        _cancel_pending()  # an exception sent just before the block ended


_PENDING: dict[int, LimitExceeded] = {}


def _set_async_exc(thread_id: int, cls: type[BaseException]) -> None:
    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread_id), ctypes.py_object(cls))


def _async_raise(thread_id: int, exc: LimitExceeded) -> None:
    """Raise ``exc``'s class in another thread."""
    _PENDING[thread_id] = exc
    _set_async_exc(thread_id, _Timeout if exc.kind == "time" else _Memory)


class _Cancelled(BaseException):
    """What a thread sends itself to take the place of a pending limit exception."""


def _cancel_pending() -> None:
    """Drop a limit exception the watchdog sent this thread just before its block ended.

    ``PyThreadState_SetAsyncExc(id, NULL)`` would clear it but leaves the interpreter's eval
    breaker set (CPython 3.11/3.12 unset it only when they deliver an exception): under any
    tracer (``pytest --cov``, a debugger) the next Python call then re-enters the breaker
    forever.  So the thread sends itself ``_Cancelled``, which replaces a pending exception,
    and catches it: that delivery clears the breaker.
    """
    _PENDING.pop(threading.get_ident(), None)
    try:
        _set_async_exc(threading.get_ident(), _Cancelled)
        for _ in range(2):  # delivered when the call returns, at the latest at this jump back
            pass
    except _Cancelled:
        pass


class _Timeout(LimitExceeded):
    """Async-raised (no arguments): the message comes from the pending record."""

    def __init__(self) -> None:
        pending = _PENDING.pop(threading.get_ident(), None)
        super().__init__("time", pending.limit if pending else 0.0)


class _Memory(LimitExceeded):
    def __init__(self) -> None:
        pending = _PENDING.pop(threading.get_ident(), None)
        super().__init__("memory", pending.limit if pending else 0.0)


def explain(sol: object, memory_mb: float | None) -> object:
    """A ``failed`` Solution whose model caught ``MemoryError``: say it was the memory limit."""
    message = getattr(sol, "message", "")
    if memory_mb and getattr(sol, "status", "") == "failed" and message.startswith("MemoryError"):
        note = f"memory limit of {memory_mb:g} MB exceeded ({message})"
        return dataclasses.replace(sol, message=note)
    return sol


def trim_heap() -> None:
    """Hand the C heap's free pages back to the system (glibc ``malloc_trim``; elsewhere a
    no-op).  A pool worker keeps the high-water mark of its largest solve or figure (a
    pyvista render left ~+85 MB, ~55 MB of it free) for the rest of the run otherwise."""
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):
        pass
