"""Per-case report figures drawn in the solving pool while the run is still solving.

Rendering after the last pair made the report a serial tail of the run (about a fifth of the
default run's wall time on 2 cores).  When the local process pool solves, each case's
figures become a job of that same pool as soon as the case's last pair is in: the job goes to
the front of the pool's queue, so it never runs beside two solves (no third process on two
cores inflating the solves' wall times) and the pool's workers, forked before the records
piled up, stay small.  The case's errors are attached exactly as ``store.assemble`` does it,
and the colour map is the run's (every planned model), so the figures equal those the final
render would draw.  What needs the whole run (stability maps of sweeps, the overall plot, the
history trend with this run's row, the document) is still done at the end, and so is the
final deformed-scene render (all cases in one child process, ``reports.render.scenes``, so
no pool worker loads VTK).
"""

from __future__ import annotations

import collections
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from reports.run import limits
from reports.verdicts import errors

ROLE = "render"  # the ``role`` of a figure job and of what it returns
PROBE_ENV = "_FLEXBENCH_PYVISTA_OK"  # fem_reference.export.pyvista_available's cache


def figure_job(job: dict) -> dict:
    """Draw one case's figures (runs in a pool worker); never raises."""
    from reports.render import _case_figures

    out = {k: job[k] for k in ("key", "case", "model", "role")}
    if job.get("pyvista") is not None:  # the run's probe verdict: no probe per worker
        os.environ.setdefault(PROBE_ENV, job["pyvista"])
    try:
        return out | {"figures": _case_figures(job["args"])}
    except Exception as exc:  # the final render draws the case again
        return out | {"error": f"{type(exc).__name__}: {exc}"}
    finally:
        limits.trim_heap()  # a render's scratch memory back to the system


class EarlyFigures:
    """Counts each case's finished pairs and queues its figure job when the last one is in.

    Parameters
    ----------
    todo : the pairs still to solve (task dicts).
    records : records already known (resumed, decided without solving); a case whose pairs
        are all among them is left to the final render.
    metas : case -> case meta (``runner.plan``).
    out_dir : the run's output folder.
    probe : the run's pyvista probe thread (``exports.start_render_probe``), joined before
        the first job so the workers (forked before it ended) inherit its verdict.
    """

    def __init__(
        self,
        todo: Sequence[dict],
        records: Sequence[dict],
        metas: Mapping[str, dict],
        out_dir: Path,
        probe: Any = None,
    ):
        from reports.render import figures as F

        self.left = collections.Counter(t["case"] for t in todo)
        self.recs: dict[str, list[dict]] = collections.defaultdict(list)
        for r in records:
            if r["case"] in self.left:
                self.recs[r["case"]].append(r)
        self.metas, self.out_dir, self.probe = metas, out_dir, probe
        (out_dir / "figures").mkdir(parents=True, exist_ok=True)
        self.cmap = F.colours(sorted({t["model"] for t in todo} | {r["model"] for r in records}))
        self.figures: dict[str, dict] = {}

    def take(self, rec: Mapping) -> bool:
        """Keep a figure job's result; False when ``rec`` is a pair record."""
        if rec.get("role") != ROLE:
            return False
        if "figures" in rec:
            self.figures[rec["case"]] = rec["figures"]
        return True

    def pair_done(self, rec: dict, queue: collections.deque) -> None:
        """Count ``rec``; when its case is complete, put its figure job first in ``queue``."""
        name = rec["case"]
        if name not in self.left:
            return
        self.recs[name].append(rec)
        self.left[name] -= 1
        meta = self.metas.get(name)
        if self.left[name] > 0 or meta is None or meta.get("sweep"):
            return
        mine = sorted(self.recs.pop(name), key=lambda r: r["model"])  # as store.assemble
        case = {**meta, **errors.attach_errors(meta, mine)}
        # no final-scene render here: pyvista would keep VTK (~240 MB) in every worker that
        # draws a case; the final render draws them in one child (render/scenes.py)
        args = (name, case, mine, self.cmap, self.out_dir, None, None)
        if self.probe is not None:
            self.probe.join()
        job = {"key": f"{name}|{ROLE}", "case": name, "model": ROLE, "role": ROLE}
        job |= {"args": args, "call": figure_job, "pyvista": os.environ.get(PROBE_ENV)}
        queue.appendleft(job)
