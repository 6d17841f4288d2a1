"""The final deformed-scene renders of a run's cases, drawn together in one child process.

A pyvista render loads VTK and its EGL/Mesa libraries into the process that draws it: about
240 MB of PSS that stays for the process's life (measured: a process at 61 MB PSS is at
300 MB after one off-screen render).  Drawn inside the per-case figure jobs
(``reports.run.overlap``), every solving pool worker that ever drew a case carried it, and the
run's summed PSS with it.  So the pool's figure jobs draw every figure but this one, and the
renders of those cases are drawn here at the end of the run, all in one short-lived forked
child (VTK loaded once, ~0.2 s per render warm) while the parent draws the history trends and
the sweep maps, then the child exits and its memory is returned.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any


def jobs(payload: Mapping, names: Sequence[str], out_dir: Path, backend: str) -> list[tuple]:
    """(case, meta, reference record, PNG path, backend) of each case in ``names`` whose
    reference record has shapes to render."""
    from reports.render import slug

    by_case: dict[str, dict[str, Mapping]] = {}
    for r in payload["results"]:
        if r["case"] in names:
            by_case.setdefault(r["case"], {})[r["model"]] = r
    out = []
    for name in names:
        meta = payload["cases"][name]
        ref = by_case.get(name, {}).get(meta.get("reference") or "")
        if ref is not None and ref.get("shapes"):
            path = out_dir / "figures" / f"{slug(name)}-render.png"
            out.append((name, meta, ref, path, backend))
    return out


def draw(batch: Sequence[tuple]) -> dict[str, tuple[str | None, str | None]]:
    """case -> (PNG path or None, error or None) for every job of ``batch``; never raises."""
    from reports.render import figures as F

    made = {}
    for name, meta, ref, path, backend in batch:
        try:
            p = F.render_figure(meta, ref, path, backend)
            made[name] = (None if p is None else str(p), None)
        except Exception as exc:  # the rest of the report must still appear
            made[name] = (None, f"{type(exc).__name__}: {exc}")
    return made


_READY: list[cf.ProcessPoolExecutor] = []  # a child forked early by ``prefork``


def _executor() -> cf.ProcessPoolExecutor | None:
    """A one-process fork pool (None when forking is unsafe: VTK loaded here, or no fork)."""
    if "fork" not in multiprocessing.get_all_start_methods() or "vtkmodules" in sys.modules:
        return None
    return cf.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))


def prefork() -> None:
    """Fork the render child now, while this process is small (the start of a run): forked
    at the end, it shared a heap of the run's records whose pages it then copied (measured:
    a 439 MB PSS child beside a 206 MB parent).  The next ``Renders`` uses it."""
    ex = _executor()
    if ex is not None:
        ex.submit(int).result()  # the pool forks its worker at the first submit
        _READY[:] = [ex]


class Renders:
    """``draw(batch)`` started in a forked child (the ``prefork`` one if any; in this process
    when forking is unsafe); ``result()`` waits for it."""

    def __init__(self, batch: Sequence[tuple]):
        self.batch, self.future = list(batch), None
        self.ex = _READY.pop() if _READY else (_executor() if self.batch else None)
        if self.batch and self.ex is not None:
            try:
                self.future = self.ex.submit(draw, self.batch)
            except Exception:
                self.future = None  # drawn here in result()

    def result(self) -> dict[str, tuple[str | None, str | None]]:
        """case -> (PNG path or None, error or None)."""
        made: Any = None
        if self.future is not None:
            try:
                made = self.future.result()
            except Exception:
                made = None  # the child died: draw here
        if self.ex is not None:
            self.ex.shutdown(wait=True)
        return made if made is not None else draw(self.batch)
