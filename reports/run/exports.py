"""Files a run writes beside its results: ParaView series and the replay animation.

Written by the worker right after the timed solves (the ``Solution`` lives there; never
timed, never fatal), as the task's ``ExportPolicy`` says.  Only the case's reference model
(role ``reference``: elastica, fem-auto, fem-N, ...) and ``replay`` export:

* ``OUT/paraview/<case>/<model>/<case>_<model>.{pvd,xdmf}`` + one ``.vtu`` per step: the
  deformed shapes of every step with per-node ``displacement`` (vector), ``rotation`` (rad),
  ``bending_moment`` and ``bending_stress`` (where the member has a thickness),
  ``curvature`` and ``load_factor``; the PVD time value of a step is its load factor (the
  step index on a path whose factor falls) (``fem_reference.export.write_series``);
* for ``replay`` also ``<case>_replay-frames.{pvd,xdmf}`` + ``.vtu``: its time-history frames,
  the same fields, time in seconds (``fem_reference.replay.model.write_vtu_series``);
* ``OUT/figures/<case>-replay.gif``: the replay's members on ``gif_frames`` evenly spaced
  frames at ``gif_dpi`` without tick labels, drawn as
  ``fem_reference.replay.model.write_animation`` draws them (``reports.run.gifs``);
* a ``kinematics`` analysis (DAS-2D's kinematic driver analysis: rigid links, no FE
  reference, no replay) exports its own solver's steps: the series and
  ``OUT/figures/<case>-kinematics.gif``.

The record's ``exports`` holds the paths relative to ``OUT``::

    {"paraview": {"dir", "pvd", "xdmf", "n_vtu"}, "paraview_frames": {...},
     "animation": "figures/<case>-replay.gif", "export_s": float}

A problem becomes a record warning (``export <kind> failed: ...``), never a lost pair.
"""

from __future__ import annotations

import dataclasses
import re
import shutil
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cases.schema import Scene
from reduced_models.base import Solution
from reports.run.gifs import shapes_gif


@dataclasses.dataclass(frozen=True)
class ExportPolicy:
    """Which files the workers write for ParaView and the report (see module docstring).

    paraview : reference model and replay, every step as VTU + PVD + XDMF (~0.02-0.1 s/case).
    replay_frames : the replay's time-history frames as a second series, at most
        ``max_frames`` of them evenly spaced (~0.05 s/case for 60 frames).
    animation : the replay GIF; ``gif_frames`` evenly spaced frames of the stored ones at
        ``gif_dpi`` without tick labels (~0.3 s/case warm; all 120 frames with tick labels at
        the default dpi take ~6 s and 0.6 MB).
    """

    paraview: bool = True
    replay_frames: bool = True
    animation: bool = True
    max_frames: int = 60
    gif_frames: int = 16
    gif_dpi: int = 60
    gif_fps: int = 4


DEFAULT_EXPORT = ExportPolicy()
QUICK_EXPORT = ExportPolicy(replay_frames=False, animation=False)


def _slug(name: str) -> str:
    """File-name-safe version of a case or model name (same rule as the report's)."""
    return re.sub(r"^\.", "_", re.sub(r"[^A-Za-z0-9_.-]+", "_", name))  # never "." or ".."


def _decimated(sol: Solution, n: int) -> Solution:
    """``sol`` with at most ``n`` of its replay frames (evenly spaced, first and last kept)."""
    fr = sol.extras["frames"]
    m = len(fr["t"])
    if m <= n:
        return sol
    idx = np.unique(np.linspace(0, m - 1, n).round().astype(int))
    small = {k: (np.asarray(v)[idx] if k in ("t", "factor", "q") else v) for k, v in fr.items()}
    return dataclasses.replace(sol, extras={**sol.extras, "frames": small})


def _series_info(directory: Path, xdmf: str | Path, out: Path) -> dict[str, Any]:
    xdmf = Path(xdmf)
    return {
        "dir": directory.relative_to(out).as_posix(),
        "xdmf": xdmf.relative_to(out).as_posix(),
        "pvd": xdmf.with_suffix(".pvd").relative_to(out).as_posix(),
        "n_vtu": len(list(directory.glob(f"{xdmf.stem}_*.vtu"))),
    }


def export_outputs(task: dict, sol: Solution) -> tuple[dict[str, Any], list[str]]:
    """Write the ParaView series (and the replay GIF) of one solved pair, as the task's
    ``export`` policy says; returns (record ``exports``, warnings).  Only the case's
    reference model, ``replay`` and the solver of a kinematics analysis export; problems
    become warnings, never exceptions."""
    policy: ExportPolicy | None = task.get("export")
    out_dir = task.get("out_dir")
    is_replay = task["model"] == "replay"
    scene: Scene = task["scene"]
    # a kinematic (rigid-link) motion has no FE reference or replay: its solver exports it
    kinematic = scene.analysis.kind == "kinematics"
    if not policy or not out_dir or not (task["role"] == "reference" or is_replay or kinematic):
        return {}, []
    if not any(s.shapes for s in sol.steps):
        return {}, []
    t0 = time.perf_counter()
    out = Path(out_dir)
    target = out / "paraview" / _slug(task["case"]) / _slug(task["model"])
    exports: dict[str, Any] = {}
    warnings: list[str] = []
    has_frames = is_replay and isinstance(sol.extras.get("frames"), Mapping)
    jobs = []
    if policy.paraview:
        jobs.append(("paraview", lambda: _write_series(target, sol, scene, out)))
    if policy.paraview and policy.replay_frames and has_frames:
        frames = _decimated(sol, policy.max_frames)
        jobs.append(("paraview_frames", lambda: _write_frames(target, frames, scene, out)))
    if policy.animation and has_frames:
        gif = out / "figures" / f"{_slug(task['case'])}-replay.gif"
        jobs.append(("animation", lambda: _write_gif(gif, sol, scene, policy, out)))
    if policy.animation and kinematic:
        gif = out / "figures" / f"{_slug(task['case'])}-kinematics.gif"
        unit = " deg" if scene.analysis.driver.kind == "rotation" else ""
        jobs.append(("animation", lambda: _write_steps_gif(gif, sol, policy, out, unit)))
    if policy.paraview:
        shutil.rmtree(target, ignore_errors=True)  # no stale steps from an earlier run
    for kind, job in jobs:
        try:
            exports[kind] = job()
        except Exception as exc:  # an export problem must not lose the solved pair
            warnings.append(f"export {kind} failed: {type(exc).__name__}: {exc}")
    exports["export_s"] = time.perf_counter() - t0
    return exports, warnings


def _write_series(target: Path, sol: Solution, scene: Scene, out: Path) -> dict[str, Any]:
    from fem_reference.export import member_sections, write_series

    return _series_info(target, write_series(target, sol, sections=member_sections(scene)), out)


def _write_frames(target: Path, sol: Solution, scene: Scene, out: Path) -> dict[str, Any] | None:
    from fem_reference.replay.model import write_vtu_series

    xdmf = write_vtu_series(sol, scene, str(target))
    return None if xdmf is None else _series_info(target, xdmf, out)


def _write_gif(gif: Path, sol: Solution, scene: Scene, policy: ExportPolicy, out: Path) -> str:
    """The replay GIF: ``gif_frames`` evenly spaced stored frames, the members' shapes
    recovered on the replay's FE system, drawn as ``write_animation`` draws them but once
    per GIF and blitted (``reports.run.gifs``), without tick labels."""
    from fem_reference.replay.model import _frame_shapes

    frames = [
        (shapes, f"{sol.case}  t = {t:.4g}  factor = {f:.4g}")
        for t, f, shapes in _frame_shapes(_decimated(sol, policy.gif_frames), scene)
    ]
    gif.parent.mkdir(parents=True, exist_ok=True)
    shapes_gif(gif, frames, dpi=policy.gif_dpi, fps=policy.gif_fps)
    return gif.relative_to(out).as_posix()


def _write_steps_gif(
    gif: Path, sol: Solution, policy: ExportPolicy, out: Path, unit: str = ""
) -> str:
    """GIF of the steps' shapes (a kinematic driver analysis: the linkage moving), at most
    ``gif_frames`` evenly spaced steps, as the replay GIF is drawn; ``unit`` follows the
    driver value in the title."""
    steps = [s for s in sol.steps if s.shapes]
    idx = np.unique(np.linspace(0, len(steps) - 1, policy.gif_frames).round().astype(int))
    frames = [(steps[i].shapes, f"{sol.case}  driver = {steps[i].factor:.4g}{unit}") for i in idx]
    gif.parent.mkdir(parents=True, exist_ok=True)
    shapes_gif(gif, frames, dpi=policy.gif_dpi, fps=policy.gif_fps, marker="o")
    return gif.relative_to(out).as_posix()


def start_render_probe() -> threading.Thread | None:
    """Run ``fem_reference.export.pyvista_available()`` (cached, child process) in a thread."""
    try:
        from fem_reference.export import pyvista_available
    except ImportError:
        return None
    th = threading.Thread(target=pyvista_available, name="pyvista-probe", daemon=True)
    th.start()
    return th
