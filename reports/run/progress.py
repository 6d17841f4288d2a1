"""What a run tells the person waiting for it: what is about to run, a progress bar on a
terminal, a plain log otherwise, and one line per later stage (writing results, rendering).

The ETA is built from measured pair times, not from the average so far: the runner starts
the heavy pairs (FE references, replays) first and the sweep points last, so "elapsed / done *
remaining" is wrong by an order of magnitude.  Pairs fall in three classes: heavy, light and
sweep point (a case named ``parent/p000``).  A remaining pair is estimated by the running
mean of finished pairs of its model, shrunk towards its model family's (``fem-auto`` and
``fem-8`` are ``fem``) and that towards its class's typical model (the median of the class's
model means) while it has few measurements.  A pair whose model family has no measurement
yet counts with the median model mean (a quarter of it for a sweep point, solved once where
a pair is solved about ``POINT_RUNS`` times); the line says how many pairs are guessed so.
The sum is divided by the measured throughput: pair seconds finished per wall second over
the last ``RATE_WINDOW_S`` (other pool jobs such as the teaching page's atlases, and other
processes on the machine, take the rest of the workers' time), at most the number of
workers still busy.  The ETA is "?" while jobs queued before the pairs (the teaching page's
atlases) hold workers, and for ``MIN_SPAN_S`` after the first finished pair.  The estimated
finish time is smoothed over ``ETA_SMOOTHING_S`` of wall time, so one slow pair does not
swing the ETA by 2x.
"""

from __future__ import annotations

import collections
import contextlib
import math
import re
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TextIO

LOG_EVERY_FRACTION = 0.1  # plain log: one line per ~10 % of the pairs ...
LOG_EVERY_S = 30.0  # ... or after this many seconds, whichever comes first
ETA_SMOOTHING_S = 45.0  # time constant of the finish-time smoothing
SHRINK = 3.0  # pseudo-count of the family mean in a model's estimate
POINT_RUNS = 4.0  # solves of a timed pair (first + TimingPolicy.min_runs) per sweep point's one
RATE_WINDOW_S = 60.0  # throughput measured over the pairs finished this recently ...
MIN_SPAN_S = 10.0  # ... once this long has passed since the first (no ETA before)


def clock(s: float) -> str:
    """Seconds as ``m:ss``."""
    s = int(round(max(s, 0.0)))
    return f"{s // 60}:{s % 60:02d}"


def plural(n: int, noun: str) -> str:
    """``1 case``, ``3 cases``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def pair_seconds(rec: Mapping) -> float | None:
    """Measured worker time of a finished pair record (solve + timing repeats + exports)."""
    t = rec.get("timing") or {}
    total = t.get("total_s")
    if total is None:
        return None
    return float(total) + float((rec.get("exports") or {}).get("export_s") or 0.0)


def family(model: str | None) -> str:
    """``fem-auto``, ``fem-64`` -> ``fem``; ``prb-fsm-8`` -> ``prb-fsm``; ``bcm`` -> ``bcm``."""
    return re.sub(r"-(\d+|auto)$", "", model or "")


def pair_class(task: Mapping) -> str:
    """``"point"`` (a sweep point: one solve, run last), ``"heavy"`` or ``"light"``."""
    if "/" in str(task.get("case", "")):
        return "point"
    return "heavy" if task.get("heavy") else "light"


class _Means:
    """Running sums and counts per key."""

    def __init__(self) -> None:
        self.sum: dict[object, float] = {}
        self.n: dict[object, int] = {}

    def add(self, key: object, t: float) -> None:
        self.sum[key] = self.sum.get(key, 0.0) + t
        self.n[key] = self.n.get(key, 0) + 1

    def mean(self, key: object) -> float:
        return self.sum[key] / self.n[key]

    def shrunk(self, key: object, prior: float) -> float:
        """Mean of ``key`` pulled towards ``prior`` by ``SHRINK`` pseudo-measurements."""
        n = self.n.get(key, 0)
        return (self.sum.get(key, 0.0) + SHRINK * prior) / (n + SHRINK)


class Progress:
    """``[#####.....] 12/40  0:05 elapsed  ETA 0:07  case / model`` on a TTY; on any other
    stream (a log file, CI) a first line saying what runs, then one plain line per ~10 % of
    the pairs or ``LOG_EVERY_S``; silent when disabled.

    Parameters
    ----------
    total : number of pairs to solve.
    stream : where to write (default stderr).
    enabled : True/False forces the bar on/off; None: the bar on a TTY, the plain log
        otherwise.
    tasks : the pending tasks (dicts with ``case``, ``model`` and ``heavy``), for the first
        line and the ETA.
    workers : how many pairs run at once.
    now : the clock (seconds; tests pass a fake one).
    others : pool jobs queued before the pairs (the teaching page's atlases); the runner
        calls ``other_done`` as each finishes.
    """

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        tasks: Sequence[Mapping] = (),
        workers: int = 1,
        now: Callable[[], float] = time.monotonic,
        others: int = 0,
    ):
        self.now, self.others, self.others_done = now, others, 0
        self.total, self.done, self.t0 = total, 0, now()
        self.stream = stream or sys.stderr
        tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.mode = ("bar" if tty else "log") if enabled is None else ("bar" if enabled else "")
        self.workers = max(1, int(workers))
        self.pending = {
            t.get("key", i): (t.get("model"), pair_class(t)) for i, t in enumerate(tasks)
        }
        self.models, self.families = _Means(), _Means()
        self.recent: collections.deque[tuple[float, float]] = collections.deque()  # (t, s)
        self.finish: tuple[float, float] | None = None  # (smoothed finish time, when)
        self.every = max(1, round(total * LOG_EVERY_FRACTION))
        self.last_line = -math.inf
        if self.mode and total:
            self._say(self._header(tasks))

    def _header(self, tasks: Sequence[Mapping]) -> str:
        cases = len({t.get("case") for t in tasks})
        models = len({t.get("model") for t in tasks})
        heavy = sum(bool(t.get("heavy")) for t in tasks)
        what = f" ({plural(cases, 'case')} x {plural(models, 'model')})" if tasks else ""
        first = [plural(self.others, "teaching-page atlas job")] if self.others else []
        first += [f"{heavy} heavy (FE references, replays)"] if heavy else []
        order = f"; {', then '.join(first)} first" if first else ""
        pairs, workers = plural(self.total, "pair"), plural(self.workers, "worker")
        return f"flexbench: solving {pairs}{what} on {workers}{order}"

    def _say(self, line: str) -> None:
        self.stream.write(line + "\n")
        self.stream.flush()

    def _estimates(self) -> tuple[dict[tuple, float], float]:
        """(estimate (s) per pending (model, class) whose model family has a measurement,
        the prior of a pair of an untimed family: the median model mean)."""
        means = {k: self.models.mean(k) for k in self.models.n}
        typical = {}
        for cls in {c for _, c in means}:
            typical[cls] = statistics.median(v for (_, c), v in means.items() if c == cls)
        est = {}
        for model, cls in set(self.pending.values()):
            if (family(model), cls) in self.families.n:
                fam = self.families.shrunk((family(model), cls), typical[cls])
                est[model, cls] = self.models.shrunk((model, cls), fam)
        return est, statistics.median(means.values())

    def other_done(self) -> None:
        """One of the ``others`` jobs (the teaching page's atlases, queued before the pairs)
        finished: the throughput is measured from the last of them on."""
        self.others -= 1
        self.others_done += 1
        if self.mode:  # the pool's first minutes may be these jobs only: say so
            el = clock(self.now() - self.t0)
            line = f"flexbench: teaching-page atlas job {self.others_done} done, {el} elapsed"
            self._say(("\r" if self.mode == "bar" else "") + line)
        if self.others <= 0:
            # the window opens now, with nothing finished in it
            self.recent = collections.deque([(self.now(), 0.0)])

    def rate(self) -> float | None:
        """Pair seconds finished per wall second over the last ``RATE_WINDOW_S``, at most
        the number of workers; None for ``MIN_SPAN_S`` after the first finished pair, or
        for ``RATE_WINDOW_S`` while an ``others`` job still holds a worker."""
        now = self.now()
        if not self.recent:
            return None
        # an others job still running after a whole window (a lost one sends no record) no
        # longer holds the ETA back: it reads as a slower machine
        wait = RATE_WINDOW_S if self.others > 0 else MIN_SPAN_S
        if now - self.recent[0][0] < wait:
            return None
        while len(self.recent) > 2 and self.recent[1][0] < now - RATE_WINDOW_S:
            self.recent.popleft()
        span = now - self.recent[0][0]
        done = sum(s for _, s in list(self.recent)[1:])  # the first entry opens the window
        return min(float(self.workers), max(done / span, 1e-9))

    def raw_eta(self) -> tuple[float, int] | None:
        """(seconds left before smoothing, pending pairs of untimed model families); None
        while the throughput is not measured (``rate``)."""
        rate = self.rate()
        if rate is None:
            return None
        est, prior = self._estimates()
        untimed = [p for p in self.pending.values() if p not in est]
        left = sum(est[p] for p in self.pending.values() if p in est)
        # a sweep point is solved once, a pair ~POINT_RUNS times (first solve + repeats)
        left += prior * sum(1.0 / POINT_RUNS if c == "point" else 1.0 for _, c in untimed)
        return left / min(rate, self.workers, max(1, len(self.pending))), len(untimed)

    def eta(self) -> tuple[float, int] | None:
        """(seconds left, pending pairs of models not yet timed): ``raw_eta`` with its finish
        time smoothed over ``ETA_SMOOTHING_S``; None while the throughput is not measured."""
        raw = self.raw_eta()
        if raw is None:
            return None
        now = self.now()
        target = now + raw[0]
        if self.finish is None or not self.pending:
            finish = target
        else:
            prev, when = self.finish
            weight = 1.0 - math.exp(-(now - when) / ETA_SMOOTHING_S)
            finish = prev + weight * (target - prev)
        self.finish = (finish, now)
        return max(finish - now, 0.0), raw[1]

    def _finish(self, rec: Mapping | None) -> None:
        if rec is None:
            return
        key = rec.get("key")
        if key not in self.pending:  # a record without its task's key: the first of its model
            key = next((k for k, (m, _) in self.pending.items() if m == rec.get("model")), None)
        if key is None:
            return
        model, cls = self.pending.pop(key)
        t = pair_seconds(rec)
        if t is not None:
            self.models.add((model, cls), t)
            self.families.add((family(model), cls), t)
            self.recent.append((self.now(), t))

    def update(self, label: str = "", rec: Mapping | None = None) -> None:
        """One more pair finished (``rec``: its record, for the measured time)."""
        self.done += 1
        self._finish(rec)
        if not self.mode or self.total == 0:
            return
        now = self.now()
        shown = (
            self.mode == "bar"
            or self.done % self.every == 0
            or self.done == self.total
            or now - self.last_line >= LOG_EVERY_S
        )
        if not shown:  # the ETA walks every pending pair: only for a line that is printed
            return
        self.last_line = now
        el = now - self.t0
        eta = self.eta()
        eta_txt = "ETA ? (measuring)" if eta is None else f"ETA {clock(eta[0])}"
        if eta is not None and eta[1]:
            eta_txt += f" ({plural(eta[1], 'pair')} of models not yet timed guessed)"
        if self.mode == "bar":
            fill = int(30 * self.done / self.total)
            bar = "#" * fill + "." * (30 - fill)
            text = f"[{bar}] {self.done}/{self.total}  {clock(el)} elapsed  {eta_txt}  {label}"
            self.stream.write("\r" + text[:110].ljust(110))
            self.stream.flush()
        else:
            self._say(f"flexbench: {self.done}/{self.total} pairs, {clock(el)} elapsed, {eta_txt}")

    def close(self) -> None:
        """End the bar's line."""
        if self.mode == "bar" and self.total:
            self.stream.write("\n")
            self.stream.flush()


@contextlib.contextmanager
def stage(label: str, stream: TextIO | None = None, enabled: bool | None = True) -> Iterator:
    """``flexbench: rendering report ... done (3.2 s)`` around a later stage of a run."""
    stream = stream or sys.stderr
    if not enabled:
        yield
        return
    stream.write(f"flexbench: {label} ...")
    stream.flush()
    t0 = time.monotonic()
    try:
        yield
    finally:
        stream.write(f" done ({time.monotonic() - t0:.1f} s)\n")
        stream.flush()
