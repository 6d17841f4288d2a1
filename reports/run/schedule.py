"""Longest pairs first, from the times measured by earlier runs.

Two workers stay busy to the end only if the long pairs start early: a 16 s pair started
last makes a 16 s tail with one core idle.  Each run writes the worker time of every pair
(solve, repeats, post-processing, exports) to ``$FLEXBENCH_CACHE/durations.json`` keyed
``case|model`` (any code version: it only orders the queue); the next run starts the pairs
with the longest known times first.  Pairs never timed keep the planner's order
(``runner.plan``: heavy pairs, then longer paths) after the known ones of their group, and
sweep points stay last (their figures are drawn at the end anyway).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from reports.run.progress import pair_seconds
from reports.verdicts.cost import cache_dir

KEEP = 20_000  # entries kept (the default matrix has ~1750 pairs)


def _path() -> Path:
    return cache_dir() / "durations.json"


def read() -> dict[str, float]:
    """``case|model`` -> seconds measured by an earlier run ({} when none)."""
    try:
        data = json.loads(_path().read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return {str(k): float(v) for k, v in data.items()} if isinstance(data, dict) else {}


def order(tasks: list[dict], known: Mapping[str, float]) -> list[dict]:
    """``tasks`` with, inside each group (non-sweep pairs, then sweep points), the pairs of
    known duration first, longest first; the others after them in their planned order."""

    def rank(i_task: tuple[int, dict]) -> tuple:
        i, t = i_task
        s = known.get(f"{t['case']}|{t['model']}")
        return (t["scene"].sweep_parent is not None, s is None, -(s or 0.0), i)

    return [t for _, t in sorted(enumerate(tasks), key=rank)]


def write(records: Iterable[Mapping]) -> None:
    """Merge the measured worker time of every solved (not cached) pair into the file."""
    data = read()
    for r in records:
        t = pair_seconds(r)
        if t is not None and not r.get("cached"):
            data[f"{r['case']}|{r['model']}"] = round(t, 4)
    if len(data) > KEEP:
        data = dict(list(data.items())[-KEEP:])
    path = _path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text(json.dumps(data), encoding="utf-8")
        tmp.replace(path)
    except OSError:
        pass  # no hints next time: the planner's order
