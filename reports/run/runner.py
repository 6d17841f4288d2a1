"""The benchmark matrix: every (case, model) pair solved, timed, compared and stored.

Flow: ``plan`` (which pairs) -> ``pool.execute`` (serial, local process pool or Dask; every
finished pair appended to ``DIR/partial.jsonl`` at once) -> ``errors.attach_errors`` per case
-> ``results.json`` / ``results.csv`` / SQLite history -> ``render.render_report`` (on the
local pool each case's figures are drawn by the pool as soon as its pairs are in:
``reports.run.overlap``).

A pair record (JSON-level dict built by ``pair.solve_task`` with ``store.record``)::

    {"key", "case", "model", "role": "model" | "reference" | "baseline",
     "status", "message", "steps": [{"factor", "outputs", "energy", "iterations", "stable",
     "max_stress"}], "shapes": {member: [[x, y], ...]} (last step), "extras", "card",
     "timing": {"median_s", "min_s", "max_s", "spread_s", "cpu_median_s", "cpu_min_s",
                "cpu_max_s", "cpu_spread_s", "n_repeats", "first_s", "first_cpu_s", "total_s",
                "post_s", "post_cpu_s"},
     "warnings", "traceback", "exports"}

plus, after ``attach_errors``: ``errors``, ``refchecks``, ``error_rel``,
``summary_basis``, ``is_reference``, ``speedup_vs_reference``.

Timing (``reports.run.timing``): CPU time (``process_time``, the ratios' basis) and wall time of
the solve alone, median/min/max/spread over repeats; the model's ``postprocess`` (shapes,
stress) runs once afterwards and is timed apart (``post_s``, ``post_cpu_s``); BLAS is pinned
to one thread in the workers.

Limits: ``time_limit`` seconds and ``memory_limit`` MB per pair (``reports.run.limits``: SIGALRM
and an rlimit in pool workers, a watchdog thread on Dask; a pool worker still running
``pool.KILL_GRACE_S`` after its time limit is killed); timed-out pairs are ``failed`` and retried on
resume.

Exports: ParaView series and the replay GIF are written by the worker right after the
timed solves (``reports.run.exports``); the record's ``exports`` holds their relative paths.
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cases.schema import Scene
from reports import api
from reports.run import journal, limits, overlap, refcache, schedule, store, sweep, teach_run
from reports.run.exports import (
    DEFAULT_EXPORT,
    QUICK_EXPORT,
    ExportPolicy,
    start_render_probe,
)
from reports.run.pool import execute
from reports.run.progress import Progress, stage
from reports.run.tables import (
    case_meta,
    code_hash,
    previous_records,
    write_errors_csv,
)
from reports.run.timing import DEFAULT_TIME_LIMIT, QUICK_TIME_LIMIT
from reports.verdicts import errors


@dataclasses.dataclass(frozen=True)
class TimingPolicy:
    """How often a pair is re-solved for its wall time (see module docstring)."""

    min_total_s: float = 0.2
    max_runs: int = 5
    # a first solve of 20 ms or more is timed by itself: in the default run such pairs'
    # first CPU time was within 1-2 % of their repeats' median (median spread of repeats
    # 2-5 %), and their repeats were 23 s of the run's ~85 s of solve CPU; below 20 ms the
    # first call reads 4-33 % slow (cold caches, timer resolution) and repeats matter
    cold_cap_s: float = 0.02
    min_runs: int = 3


DEFAULT_TIMING = TimingPolicy()
QUICK_TIMING = TimingPolicy(min_total_s=0.02, max_runs=3, cold_cap_s=0.02, min_runs=2)


@dataclasses.dataclass
class RunResult:
    """What ``run_matrix`` produced."""

    payload: dict[str, Any]
    out_dir: Path
    paths: dict[str, Path]
    solved: int
    resumed: int
    elapsed_s: float
    report_error: str | None = None


# -- planning ----------------------------------------------------------------------------------
def quick_scene(scene: Scene, divisor: int = 4, min_steps: int = 4) -> Scene:
    """``scene`` with about ``steps / divisor`` load steps (every reference factor kept on the
    grid); path and sweep analyses are left alone (their length is part of the answer)."""
    a = scene.analysis
    if a.kind not in ("load", "distance", "energy") or a.steps <= min_steps:
        return scene
    ats = [r.at_factor for r in scene.references if r.at_factor is not None]
    if ats and a.kind != "load":
        return scene
    for n in range(max(min_steps, math.ceil(a.steps / divisor)), a.steps):
        grid = [at / a.factor_end * n for at in ats] if a.factor_end else []
        if all(abs(g - round(g)) < 1e-9 for g in grid):
            return dataclasses.replace(scene, analysis=dataclasses.replace(a, steps=n))
    return scene


def model_list(scene: Scene, models: Sequence[str] | None, table: dict[str, str]) -> list:
    """(name, role) pairs for one case: the asked models (else the case's list + defaults),
    the reference model (or a registered fallback) and speed baselines."""
    defaults = list(api.default_names()) if sweep.uses_defaults(scene) else []
    names = list(models) if models else [s.name for s in scene.models] + defaults
    pairs = {n: "model" for n in names}
    refs = [scene.reference_model] if scene.reference_model else []
    for cand in refs + [c for c in errors.FALLBACK_REFERENCES if c not in refs]:
        try:
            api.resolve(cand, table)
        except api.UnknownModelError:
            continue
        pairs[cand] = "reference"
        break
    for name in list(pairs):
        base = api.SPEED_BASELINES.get(name)
        if base and base not in pairs and base in table:
            pairs[base] = "baseline"
    return list(pairs.items())


def plan(
    scenes: Sequence[Scene],
    models: Sequence[str] | None = None,
    quick: bool = False,
    timing: TimingPolicy | None = None,
) -> tuple[list[dict], list[dict], dict[str, dict]]:
    """Tasks to run, records decided without solving (unregistered names) and case metas.

    Raises
    ------
    UnknownModelError
        When a name in ``models`` (the user's list) is unknown.
    """
    table = api.registry_table()
    for name in models or ():
        api.resolve(name, table)
    timing = timing or (QUICK_TIMING if quick else DEFAULT_TIMING)
    code = code_hash()
    tasks, fixed, metas = [], [], {}
    for scene0 in sweep.expand_all(scenes, thin=quick):
        scene = quick_scene(scene0) if quick else scene0
        meta = case_meta(scene) | sweep.point_meta(scene)
        metas[scene.name] = meta
        ptiming = sweep.single_shot(scene, timing)
        for name, role in model_list(scene, models, table):
            options = scene.model_options(name)
            fp = json.dumps(
                [meta["scene_hash"], name, store.jsonable(options), quick, ptiming.__dict__, code],
                sort_keys=True,
            )
            key = f"{scene.name}|{name}|{hashlib.sha1(fp.encode()).hexdigest()[:12]}"
            base = {"key": key, "case": scene.name, "model": name, "role": role}
            try:
                _, n, target = api.resolve(name, table)
                api.check_options(scene, name, target, options)  # bad options: exit 2
            except api.UnknownModelError:
                fixed.append(
                    store.record(base, "not-applicable", f"model {name!r} is not in the registry")
                )
                continue
            heavy = role != "model" or name.startswith(("fem", "replay"))
            tasks.append(
                {
                    **base,
                    "scene": scene,
                    "target": target,
                    "n": n,
                    "options": options,
                    "timing": ptiming,
                    "heavy": heavy,
                }
            )
    # long jobs first (shorter tail): heavy pairs, among them replays, then longer paths;
    # sweep points (short) last, so the other cases complete and their figures are drawn
    # while the points solve (overlap.py)
    tasks.sort(
        key=lambda t: (
            t["scene"].sweep_parent is not None,
            not t["heavy"],
            t["model"] != "replay",
            -t["scene"].analysis.steps,
        )
    )
    return tasks, fixed, metas


# -- the whole run ---------------------------------------------------------------------------
def run_matrix(
    scenes: Sequence[Scene],
    models: Sequence[str] | None = None,
    out_dir: str | Path = "flexbench-out",
    *,
    quick: bool = False,
    workers: int | None = None,
    dask: str | None = None,
    history: str | Path | None = None,
    fresh: bool = False,
    render: bool = True,
    progress: bool | None = None,
    timing: TimingPolicy | None = None,
    time_limit: float | None | str = "auto",
    memory_limit: float | None = limits.DEFAULT_MEMORY_LIMIT_MB,
    export: ExportPolicy | None | str = "auto",
    render_shapes: bool | None = None,
    tolerance: float | None = None,
    teaching: tuple[int, int] | None | str = "auto",
) -> RunResult:
    """Solve the matrix, store everything under ``out_dir`` and render the report.

    Finished pairs are appended to ``out_dir/partial.jsonl`` as they complete; a rerun with
    the same ``out_dir`` (same scenes, models, code and ``quick``) skips them (``fresh``
    starts over); pairs lost to a killed worker or to ``time_limit`` (seconds per pair;
    "auto": ``QUICK_TIME_LIMIT`` / ``DEFAULT_TIME_LIMIT``; None: none) are retried;
    ``memory_limit`` (MB of growth per pair; None: none) fails a pair that needs more.
    ``history`` defaults to ``out_dir/history.sqlite``.
    ``export``: "auto" (``QUICK_EXPORT`` / ``DEFAULT_EXPORT``),
    an ``ExportPolicy`` or None (no ParaView files or GIFs).  ``render_shapes``: add the
    rendered final deformed scene per case to the report (None: unless ``quick``); then the
    pyvista probe (a child process, ~1.5 s) runs in a thread while the pairs solve, so the
    report does not wait for it.  ``teaching``: (magnitudes, directions) of the teaching
    page's validity atlases ("auto": ``teach_run.GRID``, ``QUICK_GRID`` with ``quick``, none
    when ``models`` is given: the page's atlases and advice are of the default models; None:
    no page); they are pool jobs beside the pairs, cached in ``out_dir``
    (``reports.run.teach_run``).
    """
    t_start, cpu_start = time.perf_counter(), _cpu_all()
    out = Path(out_dir)
    journal.prepare(out)
    partial = out / "partial.jsonl"
    if fresh:
        partial.unlink(missing_ok=True)
    if time_limit == "auto":
        time_limit = QUICK_TIME_LIMIT if quick else DEFAULT_TIME_LIMIT
    if export == "auto":
        export = QUICK_EXPORT if quick else DEFAULT_EXPORT
    tasks, fixed, metas = plan(scenes, models, quick, timing)
    for t in tasks:
        t["time_limit"], t["memory_limit"] = time_limit, memory_limit
        t["export"], t["out_dir"] = sweep.export_for(t["scene"], export), str(out.resolve())
    if render_shapes is None:
        render_shapes = not quick
    if render and render_shapes:  # the final scenes' render child, forked while we are small
        from reports.render import scenes

        scenes.prefork()  # before the probe's thread starts: no fork beside a live thread
    probe = start_render_probe() if render and render_shapes else None
    done, token = _resumed(out, partial, tasks, fresh)
    todo = [t for t in tasks if t["key"] not in done]
    records = list(done.values()) + fixed
    n_all = len(todo)
    todo = schedule.order(_from_cache(todo, records, out, partial), schedule.read())
    if teaching == "auto":  # the page is about the default models: not for a --models run
        teaching = None if models else teach_run.QUICK_GRID if quick else teach_run.GRID
    teach = teach_run.TeachingJobs(out, teaching, code_hash()) if render and teaching else None
    early, bar_mode = _solve(todo, records, metas, out, partial, probe, teach, render, workers,
                             dask, time_limit, progress)  # fmt: skip
    config = {
        "tolerance": tolerance,  # grading.py: user tolerance (None: per-family defaults)
        "quick": quick,
        "models": list(models) if models else None,
        "cases": list(metas),
        "workers": None if dask else (workers or os.cpu_count()),
        "dask": dask,
        "time_limit_s": time_limit,
        "timing": dataclasses.asdict(timing or (QUICK_TIMING if quick else DEFAULT_TIMING)),
        "export": dataclasses.asdict(export) if export else None,
        "render_shapes": render_shapes,
        "history": str(Path(history) if history else out / "history.sqlite"),
    }
    payload = store.assemble(records, metas, config)
    elapsed = time.perf_counter() - t_start
    payload["elapsed_s"] = elapsed
    payload["stats"] = {"solved": len(todo), "resumed": len(done), "pairs": len(records)}
    payload["stats"]["cpu"] = _stage_cpu(_cpu_all() - cpu_start, teach, early)
    payload["stats"]["cached"] = n_all - len(todo)  # reference pairs of an earlier run
    paths = _write(payload, out, Path(history) if history else out / "history.sqlite", token)
    schedule.write(records)  # the next run starts its longest pairs first
    partial.unlink(missing_ok=True)  # every pair is in results.json now (resume reads it)
    result = RunResult(payload, out, paths, len(todo), len(done), elapsed)
    if render:
        if probe is not None:
            probe.join()
        try:
            from reports.render import render_report

            with stage("rendering report", enabled=bar_mode != ""):
                if teach is not None:  # never raises; a page that failed is not linked
                    cpu_page = _cpu_all()
                    paths["teaching.html"] = teach.write(payload, out)
                    payload["stats"]["cpu"]["teaching_page_s"] = _cpu_all() - cpu_page
                figs = early.figures if early is not None else None
                paths.update(render_report(payload, out, render=render_shapes, early=figs))
        except Exception as exc:  # results are safe on disk; say what broke
            result.report_error = f"{type(exc).__name__}: {exc}"
    result.elapsed_s = time.perf_counter() - t_start
    return result


def _cpu_all() -> float:
    """CPU s of this process and its finished children (the pool's workers, once joined)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def _stage_cpu(stage_s: float, teach: Any, early: Any) -> dict:
    """The solving stage's CPU (all local processes), the atlases computed in it and the
    figures drawn in it: the report's "Where the time goes" (render/timebudget.py)."""
    done = {} if teach is None else teach.results
    atlases = {k: v.get("cpu_s", 0.0) for k, v in done.items() if k not in teach.cached}
    figs = [] if early is None else early.figures.values()
    return {
        "solve_stage_s": stage_s,
        "atlases_s": atlases,
        "atlases_reused": [] if teach is None else teach.cached,
        "figures_s": sum(f.get("cpu_s") or 0.0 for f in figs),
    }


def _resumed(out: Path, partial: Path, tasks: list[dict], fresh: bool) -> tuple[dict, str]:
    """(records of the pairs an earlier run of this ``out`` finished, this run's history
    token): from ``partial.jsonl`` and, unless ``fresh``, ``results.json``; pairs killed or
    timed out are tried again."""
    wanted = {t["key"] for t in tasks}
    previous = journal.read(partial)  # a torn last line is cut off
    earlier = [] if fresh else previous_records(out / "results.json")
    token = journal.run_token(out, new=not (previous or earlier))  # this run's history rows
    done = {
        r["key"]: r
        for r in [*earlier, *previous]
        if r.get("key") in wanted and not r.get("retry")  # killed/timed out: try again
    }
    return done, token


def _from_cache(todo: list[dict], records: list[dict], out: Path, partial: Path) -> list[dict]:
    """``todo`` without the reference pairs an earlier run of the same code solved
    (``reports.run.refcache``); their records join ``records`` and the journal."""
    left = []
    for t in todo:
        rec = refcache.lookup(t, out)
        if rec is None:
            left.append(t)
            continue
        journal.append(partial, rec)
        records.append(rec)
    return left


def _solve(
    todo: list[dict],
    records: list[dict],
    metas: dict,
    out: Path,
    partial: Path,
    probe: Any,
    teach: Any,
    render: bool,
    workers: int | None,
    dask: str | None,
    time_limit: float | None,
    progress: bool | None,
) -> tuple[Any, str]:
    """Solve the ``todo`` pairs (with the early figure and teaching-page jobs in the same
    pool), journal and append each record; (the early figures, the progress bar's mode)."""
    queue = collections.deque(todo)  # figure jobs join it as cases complete (overlap.py)
    keys = {t["key"]: t for t in todo if refcache.cacheable(t)}  # kept for later runs
    pooled = not dask and (workers or os.cpu_count() or 1) > 1 and len(todo) > 1
    early = None
    if render and pooled:
        early = overlap.EarlyFigures(todo, records, metas, out.resolve(), probe)
    if teach is not None and pooled:
        queue.extendleft(reversed(teach.jobs))  # long jobs: first, beside the pairs
    others = len(teach.jobs) if teach is not None and pooled else 0  # queued before the pairs
    n_workers = workers or os.cpu_count() or 1
    bar = Progress(len(todo), enabled=progress, tasks=todo, workers=n_workers, others=others)
    try:
        for rec in execute(queue if pooled else todo, workers, dask, time_limit):
            if early is not None and early.take(rec):
                continue
            if teach is not None and teach.take(rec):
                bar.other_done()
                continue
            journal.append(partial, rec)
            records.append(rec)
            if rec["key"] in keys:
                refcache.store(keys[rec["key"]], rec, out)
            bar.update(f"{rec['case']} / {rec['model']}", rec)
            if early is not None:
                early.pair_done(rec, queue)
    finally:
        bar.close()
    return early, bar.mode


def _write(payload: dict, out: Path, hist: Path, token: str) -> dict[str, Path]:
    """results.json, results.csv, the history rows and errors.csv of a run."""
    paths = {
        "results.json": store.write_results(out / "results.json", payload),
        "results.csv": store.write_csv(out / "results.csv", payload["results"], payload["cases"]),
    }
    journal.record_history(hist, payload, str(out), payload["elapsed_s"], token)
    paths["history"] = hist
    paths["errors.csv"] = write_errors_csv(out / "errors.csv", payload)
    return paths
