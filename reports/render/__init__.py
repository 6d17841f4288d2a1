"""Render a run (the ``results.json`` payload) as report.html + report.md + PNG figures.

``build_document`` turns the payload into a list of format-neutral blocks; ``html.py`` and
``md.py`` only format those blocks, so both reports always say the same thing.

Block kinds: ``("h1"|"h2"|"h3"|"p", text)``, ``("table", headers, rows)``,
``("img", relative_path, alt[, width_px])``, ``("ul", items)``,
``("links", label, [(text, relative_path), ...])``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

Block = tuple

RENDER_WIDTH_PX = 600  # the render is 1200 x 900 px; shown at half size
PARAVIEW_NOTE = (
    "ParaView files (reference model and replay): the .pvd lists one .vtu of deformed "
    "centre lines per step; the .xdmf holds the first step's mesh with a 'displacement' "
    "field per step (apply Warp By Vector); 'curvature' and 'load_factor' are point fields. "
    "'frames' series are the replay's time history, the others its settled states."
)
DEFINITIONS = (
    "Summary error: the largest deviation from the case's reference path over every load "
    "factor both reached, over the displacement (ux, uy; divided by the length scale L = "
    "longest member) and rotation (rad) outputs. Cases without a reference path use the "
    "largest relative error against their published references. Wall time: median of "
    "repeated solves in one worker (first call excluded; a first call slower than the "
    "policy cap is used alone); brackets give [min, max] and the number of repeats. "
    "'vs ref' = reference wall time / model wall time."
)


# -- formatting ---------------------------------------------------------------------------------
def fmt_time(s: float | None) -> str:
    """Seconds as a short human string (µs, ms, s)."""
    if s is None or not math.isfinite(s):
        return "–"
    if s < 1e-3:
        return f"{s * 1e6:.0f} µs"
    if s < 1.0:
        return f"{s * 1e3:.3g} ms"
    return f"{s:.3g} s"


def fmt_num(x: float | None, digits: int = 2) -> str:
    """Compact scientific notation, ``–`` for missing."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{digits}e}"


def fmt_ratio(x: float | None) -> str:
    """Speed ratio like ``12.3x``."""
    return "–" if x is None else f"{x:.3g}x"


def slug(name: str) -> str:
    """File-name-safe version of a case name."""
    return re.sub(r"^\.", "_", re.sub(r"[^A-Za-z0-9_.-]+", "_", name))  # never "." or ".."


# -- points for the Pareto plots -------------------------------------------------------------------
def case_points(records: Sequence[Mapping]) -> list[dict]:
    """Pareto points of one case (the reference itself is a line, not a point)."""
    pts = []
    for r in records:
        t = (r.get("timing") or {}).get("median_s")
        if r.get("is_reference") or t is None or r.get("summary_error") is None:
            continue
        pts.append(
            {
                "model": r["model"],
                "time": t,
                "error": r["summary_error"],
                "tmin": r["timing"]["min_s"],
                "tmax": r["timing"]["max_s"],
                "ok": r["status"] == "converged",
            }
        )
    return pts


def overall_rows(payload: Mapping) -> list[dict]:
    """Per model: geometric-mean wall time and worst summary error over the cases it solved."""
    per: dict[str, list[tuple[float, float, str]]] = {}
    for r in payload["results"]:
        t = (r.get("timing") or {}).get("median_s")
        if r.get("is_reference") or r["status"] != "converged" or not t:
            continue
        if r.get("summary_error") is None:
            continue
        per.setdefault(r["model"], []).append((t, r["summary_error"], r["case"]))
    rows = []
    for model, vals in sorted(per.items()):
        worst = max(vals, key=lambda v: v[1])
        gmean = math.exp(sum(math.log(v[0]) for v in vals) / len(vals))
        rows.append(
            {
                "model": model,
                "n": len(vals),
                "time": gmean,
                "error": worst[1],
                "worst_case": worst[2],
                "ok": True,
            }
        )
    return rows


# -- the document ---------------------------------------------------------------------------------
def _environment_blocks(payload: Mapping) -> list[Block]:
    env, cfg = payload.get("environment", {}), payload.get("config", {})
    commit = env.get("git_commit") or "(no commit)"
    if env.get("git_dirty"):
        commit += " + uncommitted changes"
    pk = ", ".join(f"{k} {v}" for k, v in (env.get("packages") or {}).items() if v)
    stats = payload.get("stats", {})
    backend = f"dask {cfg['dask']}" if cfg.get("dask") else f"{cfg.get('workers')} local workers"
    rows = [
        ["time (UTC)", env.get("time", "")],
        ["git commit", commit],
        ["python", f"{env.get('python', '')} ({env.get('implementation', '')})"],
        ["machine", f"{env.get('machine', '')}, {env.get('platform', '')}"],
        ["CPU", f"{env.get('cpu', '')} ({env.get('cpu_count', '')} logical)"],
        ["packages", pk],
        [
            "run",
            f"{'quick' if cfg.get('quick') else 'full'} matrix, {backend}, "
            f"{stats.get('pairs', len(payload['results']))} pairs "
            f"({stats.get('solved', '?')} solved, {stats.get('resumed', 0)} resumed), "
            f"{fmt_time(payload.get('elapsed_s'))}",
        ],
    ]
    return [("h2", "Environment"), ("table", ["", ""], rows), ("p", DEFINITIONS)]


def _case_blocks(name: str, case: Mapping, recs: Sequence[Mapping], figs: Mapping) -> list:
    blocks: list[Block] = [("h2", f"{case.get('title') or name} ({name})")]
    line = f"Tags: {', '.join(case.get('tags', [])) or '–'}. Units: {case.get('units', '')}. "
    line += f"Length scale L = {case.get('length_scale', 1.0):g}. "
    line += f"Reference path: {case.get('reference') or 'none'}"
    if case.get("uncertainty") is not None:
        line += f" (its own error estimate: {fmt_num(case['uncertainty'])})"
    blocks.append(("p", line + "."))
    if case.get("note"):
        blocks.append(("p", f"Note: {case['note']}."))
    if case.get("description"):
        blocks.append(("p", case["description"]))
    for kind in ("path", "shapes", "render", "pareto", "history", "animation"):
        if figs.get(kind):
            width = RENDER_WIDTH_PX if kind == "render" else None
            blocks.append(("img", figs[kind], f"{name}: {kind}", width))
    if figs.get("render_error"):
        blocks.append(("p", f"Render not drawn: {figs['render_error']}."))
    if figs.get("links"):
        blocks.append(("links", "ParaView files", figs["links"]))
    out = case.get("primary_output")
    keys = [f"{out}.{q}" for q in ("ux", "uy", "rot")] if out else []
    head = [
        "model",
        "role",
        "status",
        "wall (median)",
        "[min, max] ×n",
        "vs ref",
        "summary error",
        *(f"err {k}" for k in keys),
        "note",
    ]
    rows = []
    for r in recs:
        t = r.get("timing") or {}
        per = (r.get("errors") or {}).get("per_output") or {}
        notes = [] if r["status"] == "converged" else [r.get("message") or ""]
        notes += r.get("warnings") or []
        err = r.get("errors") or {}
        if err.get("coverage") is not None and err["coverage"] < 0.999:
            notes.append(f"reached {err['coverage']:.0%} of the reference path")
        if err.get("interpolated"):
            notes.append("reference interpolated")
        role = "reference" if r.get("is_reference") else r.get("role", "model")
        span = f"[{fmt_time(t.get('min_s'))}, {fmt_time(t.get('max_s'))}] ×{t.get('n_repeats')}"
        rows.append(
            [
                r["model"],
                role,
                r["status"],
                fmt_time(t.get("median_s")),
                span if t else "–",
                fmt_ratio(r.get("speedup_vs_reference")),
                fmt_num(r.get("summary_error"))
                + (" (refs)" if r.get("summary_basis") == "references" else ""),
                *(fmt_num(per.get(k)) for k in keys),
                "; ".join(n for n in notes if n),
            ]
        )
    blocks.append(("table", head, rows))
    refs = case.get("references") or []
    if refs:
        blocks.append(("h3", "Published and closed-form references"))
        rrows = [
            [
                f"R{i + 1}",
                r["output"],
                "end" if r.get("at_factor") is None else f"{r['at_factor']:g}",
                f"{r['value']:.6g}",
                r["kind"],
                f"{r['tolerance']:g}" + (" abs" if r.get("abs_tolerance") else " rel"),
                r["source"],
                r["rationale"],
            ]
            for i, r in enumerate(refs)
        ]
        blocks.append(
            (
                "table",
                [
                    "",
                    "output",
                    "at factor",
                    "value",
                    "kind",
                    "tolerance",
                    "source",
                    "tolerance rationale",
                ],
                rrows,
            )
        )
        crows = []
        for r in recs:
            if r["status"] == "not-applicable":
                continue
            cells = []
            for c in r.get("refchecks") or []:
                if c["passed"] is None:
                    cells.append(f"– ({c['note']})")
                else:
                    cells.append(f"{'pass' if c['passed'] else 'FAIL'} {fmt_num(c['error'])}")
            crows.append([r["model"], *cells])
        blocks.append(("table", ["model", *(f"R{i + 1}" for i in range(len(refs)))], crows))
    return blocks


def build_document(payload: Mapping, figures: Mapping[str, Mapping[str, str]]) -> list[Block]:
    """Format-neutral content of the report (``figures``: case or ``"_overall"`` -> kind ->
    relative PNG path)."""
    results = payload["results"]
    blocks: list[Block] = [("h1", "FlexBench report")]
    blocks += _environment_blocks(payload)
    if any(r.get("exports") for r in results):
        blocks.append(("p", PARAVIEW_NOTE))
    blocks.append(("h2", "Overview"))
    orows = []
    for name, case in payload["cases"].items():
        recs = [r for r in results if r["case"] == name]
        count = {s: sum(r["status"] == s for r in recs) for s in ("converged", "failed")}
        checks = [c for r in recs for c in (r.get("refchecks") or []) if c["passed"] is not None]
        ref_checks = [
            c
            for r in recs
            if r.get("is_reference")
            for c in (r.get("refchecks") or [])
            if c["passed"] is not None
        ]
        orows.append(
            [
                name,
                case.get("reference") or "–",
                str(len(recs)),
                str(count["converged"]),
                str(count["failed"]),
                str(len(recs) - count["converged"] - count["failed"]),
                f"{sum(c['passed'] for c in ref_checks)}/{len(ref_checks)}",
                f"{sum(c['passed'] for c in checks)}/{len(checks)}",
            ]
        )
    blocks.append(
        (
            "table",
            [
                "case",
                "reference",
                "pairs",
                "converged",
                "failed",
                "not applicable",
                "published checks passed by the reference",
                "published checks passed, all models",
            ],
            orows,
        )
    )
    blocks.append(("h2", "Speed against error, all cases"))
    if figures.get("_overall", {}).get("pareto"):
        blocks.append(("img", figures["_overall"]["pareto"], "overall Pareto"))
    blocks.append(
        (
            "p",
            "Per model: geometric-mean wall time and worst summary error over the cases it "
            "solved (models are not all applicable to the same cases: compare counts).",
        )
    )
    blocks.append(
        (
            "table",
            ["model", "cases", "wall time (geo-mean)", "worst summary error", "worst case"],
            [
                [r["model"], str(r["n"]), fmt_time(r["time"]), fmt_num(r["error"]), r["worst_case"]]
                for r in overall_rows(payload)
            ],
        )
    )
    ratios = payload.get("speed_ratios") or []
    if ratios:
        blocks.append(("h2", "Speed ratios against baselines (same run)"))
        blocks.append(
            (
                "table",
                ["case", "model", "baseline", "model time", "baseline time", "speed-up"],
                [
                    [
                        r["case"],
                        r["model"],
                        r["baseline"],
                        fmt_time(r["model_s"]),
                        fmt_time(r["baseline_s"]),
                        fmt_ratio(r["ratio"]),
                    ]
                    for r in ratios
                ],
            )
        )
    for name, case in payload["cases"].items():
        recs = [r for r in results if r["case"] == name]
        blocks += _case_blocks(name, case, recs, figures.get(name, {}))
    blocks += _card_blocks(payload.get("models") or {})
    bad = [r for r in results if r["status"] == "failed" or r.get("warnings")]
    if bad:
        blocks.append(("h2", "Failures and warnings"))
        blocks.append(
            (
                "ul",
                [
                    f"{r['case']} / {r['model']}: {r['status']}: {r.get('message', '')}"
                    + "".join(f"; {w}" for w in r.get("warnings") or [])
                    for r in bad
                ],
            )
        )
    return blocks


def _card_blocks(cards: Mapping[str, Mapping]) -> list[Block]:
    blocks: list[Block] = [("h2", "Model cards")]
    for name, card in sorted(cards.items()):
        blocks.append(("h3", f"{name} ({card.get('family', '')})"))
        blocks.append(("p", card.get("summary", "")))
        items = [f"Assumes: {a}" for a in card.get("assumptions") or ()]
        if card.get("validity"):
            items.append(f"Valid: {card['validity']}")
        items += [f"Reference: {r}" for r in card.get("references") or ()]
        if items:
            blocks.append(("ul", items))
    return blocks


# -- orchestration --------------------------------------------------------------------------------
def _case_figures(job: tuple) -> dict[str, str | None]:
    """All figures of one case (a picklable job, so cases can render in parallel)."""
    from reports.render import figures as F

    name, case, recs, cmap, out_dir, backend = job
    figdir = out_dir / "figures"
    ref = case.get("reference")
    ref_rec = next((r for r in recs if r["model"] == ref), None)
    s = slug(name)
    t_ref = (ref_rec.get("timing") or {}).get("median_s") if ref_rec else None

    def rel(p: Path | None) -> str | None:
        return None if p is None else p.relative_to(out_dir).as_posix()

    title = f"{name}: speed vs error"
    render, render_error = None, None
    if backend:
        try:
            render = F.render_figure(case, ref_rec, figdir / f"{s}-render.png", backend)
        except Exception as exc:  # the rest of the report must still appear
            render_error = f"{type(exc).__name__}: {exc}"
    return {
        "path": rel(F.path_figure(case, recs, ref, cmap, figdir / f"{s}-path.png")),
        "shapes": rel(F.shapes_figure(case, recs, ref, cmap, figdir / f"{s}-shapes.png")),
        "pareto": rel(
            F.pareto_figure(
                case_points(recs),
                figdir / f"{s}-pareto.png",
                title,
                cmap,
                t_ref,
                case.get("uncertainty"),
            )
        ),  # fmt: skip
        "history": rel(F.history_figure(case, recs, figdir / f"{s}-history.png")),
        "render": rel(render),
        "render_error": render_error,
        "animation": _existing(out_dir, [(r.get("exports") or {}).get("animation") for r in recs]),
        "links": export_links(recs, out_dir),
    }


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


def render_figures(payload: Mapping, out_dir: Path, render: str | None = "auto") -> dict[str, dict]:
    """Every PNG of the report under ``out_dir/figures``; returns case -> kind -> rel. path
    (plus ``links``: ParaView files, ``animation``: the replay GIF, when the run wrote them).

    ``render``: backend of the final-shape render (``auto``: pyvista when
    ``fem_reference.export.pyvista_available()``, else matplotlib; ``matplotlib``,
    ``pyvista``; None: no render).  Cases render in parallel on a small fork pool when there
    are several (matplotlib is single-threaded; ~0.1-0.3 s per figure) and this process has
    not loaded VTK itself (the probe runs in a child process, so normally it has not); any
    pool problem falls back to serial.
    """
    import multiprocessing
    import os
    import sys
    from concurrent.futures import ProcessPoolExecutor

    from reports.render import figures as F

    (out_dir / "figures").mkdir(parents=True, exist_ok=True)
    cmap = F.colours(sorted({r["model"] for r in payload["results"]}))
    jobs = [
        (name, case, [r for r in payload["results"] if r["case"] == name], cmap, out_dir, render)
        for name, case in payload["cases"].items()
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
    overall = F.pareto_figure(
        overall_rows(payload),
        out_dir / "figures" / "overall-pareto.png",
        "all cases: per-model aggregate",
        cmap,
        xlabel="wall time per solve, geometric mean over cases [s]",
    )
    made["_overall"] = {"pareto": overall.relative_to(out_dir).as_posix() if overall else None}
    return made


def render_report(
    payload: Mapping, out_dir: str | Path, *, pyvista: bool | None = None, render: bool = True
) -> dict:
    """Write ``report.html``, ``report.md`` and ``figures/*.png``; returns their paths.

    The final deformed scene of each case is rendered unless ``render`` is False: ``pyvista``
    None (default) or True picks pyvista when it can render here, else matplotlib; False
    draws it with matplotlib.
    """
    from reports.render.html import to_html
    from reports.render.md import to_markdown

    out = Path(out_dir)
    backend = None if not render else ("matplotlib" if pyvista is False else "auto")
    figs = render_figures(payload, out, backend)
    blocks = build_document(payload, figs)
    html_path, md_path = out / "report.html", out / "report.md"
    html_path.write_text(to_html(blocks, "FlexBench report"), encoding="utf-8")
    md_path.write_text(to_markdown(blocks), encoding="utf-8")
    pngs = sorted((out / "figures").glob("*.png"))
    return {"report.html": html_path, "report.md": md_path, "figures": pngs}


__all__: Sequence[Any] = ("render_report", "build_document", "render_figures")
