"""Render a run (the ``results.json`` payload) as report.html + report.md + PNG figures.

``build_document`` (``reports.render.document``) turns the payload into a list of
format-neutral blocks; ``html.py`` and ``md.py`` only format those blocks, so both reports
always say the same thing.  This module draws the figures (per case in parallel) and writes
the files.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from reports.render.document import build_document


# -- formatting ---------------------------------------------------------------------------------
def slug(name: str) -> str:
    """File-name-safe version of a case name."""
    return re.sub(r"^\.", "_", re.sub(r"[^A-Za-z0-9_.-]+", "_", name))  # never "." or ".."


# -- points for the speed-vs-error plots ----------------------------------------------------------
def case_points(records: Sequence[Mapping], uncertainty: float | None = None) -> list[dict]:
    """Speed-vs-error points of one case: every model with a time and an error, the
    reference (at its own error estimate ``uncertainty``, else 0 = exact) and the exact model
    marked (``kind``)."""
    from reports.render.frontpage import EXACT_MODELS

    pts = []
    for r in records:
        t = r.get("timing") or {}
        if t.get("median_s") is None:
            continue
        if r.get("is_reference"):
            if r["status"] != "converged":
                continue
            err, kind = (uncertainty if uncertainty is not None else 0.0), "reference"
        elif r.get("error_rel") is None:
            continue
        else:
            err = r["error_rel"]
            kind = "exact" if r["model"] in EXACT_MODELS else "model"
        pts.append(
            {
                "model": r["model"],
                "time": t["median_s"],
                "error": err,
                "tmin": t.get("min_s"),
                "tmax": t.get("max_s"),
                "ok": r["status"] == "converged",
                "kind": kind,
                "exact": r["model"] in EXACT_MODELS,
            }
        )
    return pts


# -- orchestration --------------------------------------------------------------------------------
def _case_figures(job: tuple) -> dict[str, Any]:
    """All figures of one case (a picklable job, so cases can render in parallel)."""
    import time

    from reports.render import figures as F
    from reports.render import mechfig as M
    from reports.render import paths as P

    cpu0 = time.process_time()  # "Where the time goes" (render/timebudget.py)
    name, case, recs, cmap, out_dir, backend, hist_db = job
    figdir = out_dir / "figures"
    ref = case.get("reference")
    ref_rec = next((r for r in recs if r["model"] == ref), None)
    s = slug(name)
    t_ref = (ref_rec.get("timing") or {}).get("median_s") if ref_rec else None

    def rel(p: Path | None) -> str | None:
        return None if p is None else p.relative_to(out_dir).as_posix()

    render, render_error, trend = None, None, None
    if backend:
        try:
            render = F.render_figure(case, ref_rec, figdir / f"{s}-render.png", backend)
        except Exception as exc:  # the rest of the report must still appear
            render_error = f"{type(exc).__name__}: {exc}"
    if hist_db is not None:
        trend, trend_error = _trend(name, cmap, figdir, hist_db)
        render_error = trend_error or render_error
    pts = case_points(recs, case.get("uncertainty"))
    title = f"{name}: speed against error (reference {ref or 'none'})"
    return {
        "pareto": rel(
            F.pareto_figure(
                pts, figdir / f"{s}-pareto.png", title, cmap, t_ref, case.get("uncertainty")
            )
        ),
        "path": rel(P.path_figure(case, recs, ref, cmap, figdir / f"{s}-path.png")),
        "driver": rel(M.driver_figure(case, recs, ref, cmap, figdir / f"{s}-driver.png")),
        "shapes": rel(M.shapes_figure(case, recs, ref, cmap, figdir / f"{s}-shapes.png")),
        "errfactor": rel(P.error_factor_figure(case, recs, ref, cmap, figdir / f"{s}-error.png")),
        "history": rel(P.history_figure(case, recs, figdir / f"{s}-time-history.png")),
        "trend": rel(trend),
        "render": rel(render),
        "render_error": render_error,
        "animation": _existing(out_dir, [(r.get("exports") or {}).get("animation") for r in recs]),
        "links": export_links(recs, out_dir),
        "cpu_s": time.process_time() - cpu0,
    }


def _trend(name: str, cmap: Mapping, figdir: Path, hist_db: Any) -> tuple[Path | None, str | None]:
    """The case's trend over the stored runs (None with fewer than two) and why it is missing."""
    from reports.run import history as H

    if not Path(hist_db).is_file():
        return None, None
    try:
        return H.trend_figure(
            name, H.trends(hist_db, name), cmap, figdir / f"{slug(name)}-trend.png"
        ), None
    except (ValueError, OSError) as exc:
        return None, f"history not read: {exc}"


def _existing(out_dir: Path, paths: Sequence[Any]) -> str | None:
    """The first of ``paths`` (relative to ``out_dir``) that exists on disk."""
    return next((p for p in paths if isinstance(p, str) and (out_dir / p).is_file()), None)


def export_links(recs: Sequence[Mapping], out_dir: Path) -> list[tuple[str, str]]:
    """(text, relative path) of the ParaView files the workers wrote and that still exist."""
    links = []
    for r in recs:
        ex = r.get("exports") or {}
        for kind, label in (("paraview", "steps"), ("paraview_frames", "frames")):
            info = ex.get(kind)
            if not isinstance(info, Mapping):
                continue
            for ext in ("pvd", "xdmf"):
                p = info.get(ext)
                if isinstance(p, str) and (out_dir / p).is_file():
                    n = info.get("n_vtu")
                    more = f", {n} vtu" if ext == "pvd" and n else ""
                    links.append((f"{r['model']} {label} .{ext}{more}", p))
    return links


def render_figures(
    payload: Mapping,
    out_dir: Path,
    render: str | None = "auto",
    early: Mapping[str, dict] | None = None,
) -> dict[str, dict]:
    """Every PNG of the report under ``out_dir/figures``; returns case -> kind -> rel. path
    (plus ``links``: ParaView files, ``animation``: the replay GIF, when the run wrote them).

    ``render``: backend of the final-shape render (``auto``: pyvista when
    ``fem_reference.export.pyvista_available()``, else matplotlib; ``matplotlib``,
    ``pyvista``; None: no render).  Cases render in parallel on a small fork pool when there
    are several (matplotlib is single-threaded; ~0.1-0.3 s per figure) and this process has
    not loaded VTK itself (the probe runs in a child process, so normally it has not); any
    pool problem falls back to serial.  ``early``: case -> figures already drawn while the
    run was solving (``reports.run.overlap``); only their history trend is added here.
    """
    import multiprocessing
    import os
    import sys
    from concurrent.futures import ProcessPoolExecutor

    from reports.render import figures as F

    (out_dir / "figures").mkdir(parents=True, exist_ok=True)
    cmap = F.colours(sorted({r["model"] for r in payload["results"]}))
    hist = (payload.get("config") or {}).get("history") or out_dir / "history.sqlite"
    jobs = [
        (
            name,
            case,
            [r for r in payload["results"] if r["case"] == name],
            cmap,
            out_dir,
            render,
            hist,
        )
        for name, case in payload["cases"].items()
        if not case.get("sweep")  # sweep points: drawn together as stability maps
        and name not in (early or {})
    ]
    if render in ("auto", "pyvista"):
        from fem_reference.export import pyvista_available

        pyvista_available()  # probe once here (cached), not once per forked worker
    procs = min(os.cpu_count() or 1, len(jobs))
    results = None
    if (
        procs > 1
        and len(jobs) >= 4
        and "vtkmodules" not in sys.modules  # a forked copy of a live VTK is not safe
        and "fork" in multiprocessing.get_all_start_methods()
    ):
        try:
            ctx = multiprocessing.get_context("fork")
            with ProcessPoolExecutor(procs, mp_context=ctx) as ex:
                results = list(ex.map(_case_figures, jobs))
        except Exception:
            results = None  # serial below
    if results is None:
        results = [_case_figures(job) for job in jobs]
    made: dict[str, dict] = {job[0]: res for job, res in zip(jobs, results)}
    from reports.render import scenes  # early cases' final scenes: one child, beside the trends

    drawn = scenes.Renders(
        scenes.jobs(payload, list(early or {}), out_dir, render) if render else []
    )
    for name, figs in (early or {}).items():  # the trend needs this run's history row
        trend, error = _trend(name, cmap, out_dir / "figures", hist)
        rel = trend.relative_to(out_dir).as_posix() if trend else None
        made[name] = {**figs, "trend": rel, "render_error": error or figs.get("render_error")}
    for name, (png, error) in drawn.result().items():
        made[name]["render"] = Path(png).relative_to(out_dir).as_posix() if png else None
        made[name]["render_error"] = made[name]["render_error"] or error
    made["_families"] = overall_charts(payload, out_dir, cmap)
    made["_sweeps"] = sweep_thumbnails(payload, out_dir)
    return made


def overall_charts(payload: Mapping, out_dir: Path, cmap: Mapping) -> dict[str, str]:
    """Family -> relative path of its speed-against-error chart (``reports.render.families``:
    each model over the cases of the family it solved)."""
    from reports.render import families as FA
    from reports.render import figures as F

    out = {}
    for fam, names in FA.grouped(payload["cases"]).items():
        pts = FA.points(payload["results"], names)
        title = f"{FA.FAMILIES[fam]}: each model over the cases of the family it solved"
        png = F.pareto_figure(
            pts,
            out_dir / "figures" / f"overall-{fam}-pareto.png",
            title,
            cmap,
            xlabel="CPU time per solve, geometric mean over the cases it solved [s]",
        )
        if png is not None:
            out[fam] = png.relative_to(out_dir).as_posix()
    return out


def sweep_thumbnails(payload: Mapping, out_dir: Path) -> dict[str, tuple[str, str]]:
    """Sweep parent -> (relative path of its stability-map thumbnail, hover text)."""
    from reports.render import stability_maps, sweep_map
    from reports.render.sweep_section import parents

    by_case = stability_maps.deploy_cases(payload)
    out = {}
    for parent, names in parents(payload["cases"]).items():
        if all(n in by_case for n in names):  # deploy sweeps have a stability verdict
            png = out_dir / "figures" / f"sweep-{slug(parent)}-map.png"
            sweep_map.thumbnail(names, payload["cases"], by_case, png)
            out[parent] = (png.relative_to(out_dir).as_posix(), sweep_map.summary(names, by_case))
    return out


def render_report(
    payload: Mapping,
    out_dir: str | Path,
    *,
    pyvista: bool | None = None,
    render: bool = True,
    early: Mapping[str, dict] | None = None,
) -> dict:
    """Write ``report.html``, ``report.md`` and ``figures/*.png``; returns their paths.

    The final deformed scene of each case is rendered unless ``render`` is False: ``pyvista``
    None (default) or True picks pyvista when it can render here, else matplotlib; False
    draws it with matplotlib.  ``early``: per-case figures drawn while solving (see
    ``render_figures``).
    """
    import os

    from reports.render.html import to_html
    from reports.render.md import to_markdown

    out = Path(out_dir)
    backend = None if not render else ("matplotlib" if pyvista is False else "auto")
    t0 = os.times()
    figs = render_figures(payload, out, backend, early)
    from reports.render import stability_maps  # deploy verdicts and sweep maps (issue 10)

    stability = stability_maps.blocks(payload, out)
    from reports.render import thesis_dynamics  # time histories, thesis tables (issue 25)

    stability += thesis_dynamics.blocks(payload, out)
    t1 = os.times()  # this process and the figure pool's / render child's workers
    figs["_render"] = {"cpu_s": sum(t1[:4]) - sum(t0[:4])}
    blocks = build_document(payload, figs) + stability
    from reports.render import effectivity  # predicted against measured error (issue 19)

    blocks += effectivity.blocks(payload, out)
    toc = next(b[1] for b in blocks if b[0] == "toc")  # the section is listed in the contents
    toc.insert(
        toc.index(("Model cards", "cards")), ("Predicted against measured error", "effectivity")
    )
    from reports.render import das2d_note  # DAS-2D's PRB indicator against the measured error

    note = das2d_note.blocks(payload)
    if note:
        blocks += note
        toc.insert(toc.index(("Model cards", "cards")), (das2d_note.TITLE, das2d_note.ANCHOR))
    from reports.render import mech_atlas  # mechanism atlases saved by the teaching page

    blocks = mech_atlas.insert_blocks(blocks, out)
    if (out / "teaching.html").is_file():  # written by `flexbench teach` (render/teaching.py)
        note = "Teaching page: model cards, validity atlases, which model to use per case"
        blocks.insert(2, ("links", note, [("teaching.html", "teaching.html")]))
    html_path, md_path = out / "report.html", out / "report.md"
    html_path.write_text(to_html(blocks, "FlexBench report"), encoding="utf-8")
    md_path.write_text(to_markdown(blocks), encoding="utf-8")
    pngs = sorted((out / "figures").glob("*.png"))
    return {"report.html": html_path, "report.md": md_path, "figures": pngs}


__all__: Sequence[Any] = ("render_report", "build_document", "render_figures")
