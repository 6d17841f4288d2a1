"""What a run tells the person waiting for it: a progress bar on a terminal, a plain log
otherwise, and one line per later stage (writing results, rendering the report).

The ETA is built from measured pair times, not from the average so far: the runner starts
the heavy pairs (FE references, replays) first, so "elapsed / done * remaining" overestimates
the tail by an order of magnitude.  A remaining pair is estimated by the median measured time of
finished pairs of the same model, else of the same weight class (heavy / light), else of all
finished pairs; the sum is divided by the number of workers that can still be busy.
"""

from __future__ import annotations

import contextlib
import statistics
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from typing import TextIO

LOG_EVERY_FRACTION = 0.1  # plain log: one line per ~10 % of the pairs ...
LOG_EVERY_S = 15.0  # ... or after this many seconds without a line (heavy pairs come first)


def clock(s: float) -> str:
    """Seconds as ``m:ss``."""
    s = int(round(max(s, 0.0)))
    return f"{s // 60}:{s % 60:02d}"


def pair_seconds(rec: Mapping) -> float | None:
    """Measured worker time of a finished pair record (solve + timing repeats + exports)."""
    t = rec.get("timing") or {}
    total = t.get("total_s")
    if total is None:
        return None
    return float(total) + float((rec.get("exports") or {}).get("export_s") or 0.0)


class Progress:
    """``[#####.....] 12/40  0:05 elapsed  ETA 0:07  case / model`` on a TTY; on any other
    stream (a log file, CI) one plain line per ~10 % of the pairs; silent when disabled.

    Parameters
    ----------
    total : number of pairs to solve.
    stream : where to write (default stderr).
    enabled : True/False forces the bar on/off; None: the bar on a TTY, the plain log
        otherwise.
    tasks : the pending tasks (dicts with ``model`` and ``heavy``), for the ETA.
    workers : how many pairs run at once.
    """

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        tasks: Sequence[Mapping] = (),
        workers: int = 1,
    ):
        self.total, self.done, self.t0 = total, 0, time.monotonic()
        self.stream = stream or sys.stderr
        tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.mode = ("bar" if tty else "log") if enabled is None else ("bar" if enabled else "")
        self.workers = max(1, int(workers))
        self.pending = [(t.get("model"), bool(t.get("heavy"))) for t in tasks]
        self.measured: dict[tuple[str | None, bool], list[float]] = {}
        self.every = max(1, round(total * LOG_EVERY_FRACTION))
        self.last_line = self.t0

    def note(self, text: str) -> None:
        """One line now (before the bar or the plain log starts), unless disabled."""
        if self.mode:
            self.stream.write(f"flexbench: {text}\n")
            self.stream.flush()

    def eta(self) -> tuple[float, bool] | None:
        """(seconds left, is it only a lower bound?) from measured pair times; None before
        anything was measured.  A pending pair of a class (heavy/light) with no measurement
        yet counts with the shortest measured time, which makes the ETA a lower bound."""
        all_t = [t for ts in self.measured.values() for t in ts]
        if not all_t:
            return None
        by_class: dict[bool, list[float]] = {}
        for (_, heavy), ts in self.measured.items():
            by_class.setdefault(heavy, []).extend(ts)
        left, bound = 0.0, False
        for model, heavy in self.pending:
            same = self.measured.get((model, heavy)) or by_class.get(heavy)
            bound = bound or not same
            left += statistics.median(same) if same else min(all_t)
        return left / min(self.workers, max(1, len(self.pending))), bound

    def _finish(self, rec: Mapping | None) -> None:
        if rec is None:
            return
        key = (rec.get("model"), None)
        for i, (model, heavy) in enumerate(self.pending):
            if model == key[0]:
                key = (model, heavy)
                del self.pending[i]
                break
        t = pair_seconds(rec)
        if t is not None and key[1] is not None:
            self.measured.setdefault(key, []).append(t)

    def update(self, label: str = "", rec: Mapping | None = None) -> None:
        """One more pair finished (``rec``: its record, for the measured time)."""
        self.done += 1
        self._finish(rec)
        if not self.mode or self.total == 0:
            return
        now = time.monotonic()
        shown = self.mode == "bar" or self.done % self.every == 0 or self.done == self.total
        shown = shown or now - self.last_line >= LOG_EVERY_S
        if not shown:  # the ETA walks every pending pair: only for a line that is printed
            return
        el, self.last_line = now - self.t0, now
        eta = self.eta()
        eta_txt = "ETA ?" if eta is None else f"ETA {'>= ' if eta[1] else ''}{clock(eta[0])}"
        if self.mode == "bar":
            fill = int(30 * self.done / self.total)
            bar = "#" * fill + "." * (30 - fill)
            text = f"[{bar}] {self.done}/{self.total}  {clock(el)} elapsed  {eta_txt}  {label}"
            self.stream.write("\r" + text[:110].ljust(110))
        else:
            self.stream.write(
                f"flexbench: {self.done}/{self.total} pairs, {clock(el)} elapsed, {eta_txt}\n"
            )
        self.stream.flush()

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
