"""The report's content as format-neutral blocks (``html.py`` and ``md.py`` format them).

Order: the front page (which model to pick: one row per case, grouped by family; the
accuracy map; speed against error per family of cases; where the run's CPU time went), then
one section per case (verdict, the figures people read, everything else folded in
``<details>``), model cards, failures, environment.

Block kinds: ``("h1"|"h3"|"p", text)``, ``("h2", text[, anchor])``, ``("table", headers,
rows[, {"cls": css class}])`` (cells: str or ``Cell``), ``("img", relative_path, alt[,
width_px])``, ``("ul", items)``, ``("links", label, [(text, relative_path), ...])``,
``("toc", [(text, anchor), ...])``, ``("details", summary)`` ... ``("/details",)``,
``("grid",)`` ... ``("/grid",)`` (figures side by side in HTML; nothing in Markdown).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from reports.render import families as FA
from reports.render import frontpage as FP
from reports.render import sweep_section as SW
from reports.render import synthnote, timebudget
from reports.render.cells import Cell
from reports.verdicts import grading

Block = tuple
FIGURE_ORDER = ("pareto", "errfactor", "path", "driver", "shapes", "render")
WIDE_FIGURES = ("path", "driver", "shapes")  # rows of panels: the grid's full width
FOLDED_FIGURES = ("history", "trend", "animation")
DEFINITIONS = (
    "error_rel (the yardstick of every grade and pick): the largest deviation from the "
    "case's reference path over every load factor both reached, over the outputs a designer "
    "judges (the case's [[tolerances]], else every point's ux, uy and rot), each divided by "
    "that output's own excursion along the reference path (a point: its largest displacement; "
    "a rotation: its largest rotation), against a floor of 1e-3 of the scene's motion where "
    "the excursion is smaller (a parasitic output). error_L: the same deviations with "
    "translations divided by the length scale L (longest member) and rotations in rad. "
    "Cases without a reference path use the largest relative error against their published "
    "references on both. Wall time: median of "
    "repeated solves in one worker (first call excluded; a first call slower than the "
    "policy cap is used alone); brackets give [min, max] and the number of repeats. "
    "'vs ref' = reference wall time / model wall time. Errors below 1e-12 are round-off and "
    "shown as 0 (< 1e-12)."
)
PARAVIEW_NOTE = (
    "ParaView files (reference model and replay): the .pvd lists one .vtu of deformed "
    "centre lines per step; the .xdmf holds the first step's mesh with a 'displacement' "
    "field per step (apply Warp By Vector); 'curvature' and 'load_factor' are point fields. "
    "'frames' series are the replay's time history, the others its settled states."
)
SOURCES = (  # internal file names in model cards -> what a reader can look up
    (re.compile(r"(DAS-2D )?seed 000_265bc60728766176\.txt"), "DAS-2D design-tool slides"),
    (re.compile(r"seed 001_427a1482c4f4c482\.txt"), "six-bar deployable-mechanism thesis"),
    (re.compile(r"\b[\w/]+\.py\b"), "the FlexBench source"),
)


def readable(text: str) -> str:
    """A card line with internal file names replaced by what they are."""
    for pat, name in SOURCES:
        text = pat.sub(name, text)
    return text


def fmt_ratio(x: float | None) -> str:
    """Speed ratio like ``12.3x``."""
    return "–" if x is None else f"{x:.3g}x"


def ref_label(r: Mapping) -> str:
    """Column header of a published-reference check: ``tip.uy at factor 1``."""
    at = r.get("at_factor")
    return f"{r['output']} at {'end' if at is None else f'factor {at:g}'}"


def _reference_line(case: Mapping, recs: Sequence[Mapping]) -> str:
    ref = case.get("reference")
    if not ref:
        return "No converged reference path: errors only against published values."
    ref_rec = next((r for r in recs if r["model"] == ref), {})
    what = "exact closed form" if ref in FP.EXACT_MODELS else "finite elements"
    if ref == "kinetostatic":
        what = "exact: rigid links and springs, no compliant member"
    if case.get("uncertainty") is not None:
        what += f", own error estimate {FP.fmt_err(case['uncertainty'])}"
    t = FP.fmt_time((ref_rec.get("timing") or {}).get("median_s"))
    note = f" ({case['note']})" if case.get("note") else ""
    return f"Reference: {ref} ({what}; {t}){note}."


def verdict(case: Mapping, recs: Sequence[Mapping], tol: float = FP.TOLERANCE) -> list[Block]:
    """The case's answer in two or three lines: reference, pick, declines."""
    out: list[Block] = [("p", _reference_line(case, recs))]
    p = FP.pick(case, recs, tol)
    groups = FP.declines(recs)
    if p is None:
        n_na = sum(len(v) for v in groups.values())
        if len(groups) == 1:
            ((reason, models),) = groups.items()
            return out + [
                (
                    "p",
                    f"No reduced model solved this scene: every other model "
                    f"({n_na}) declines it: {reason}.",
                )
            ]
        out.append(("p", "No reduced model solved this scene."))
    if p is not None:
        speed = "" if p["ratio"] is None else f", {FP.fmt_speed(p['ratio'])} than the reference"
        speed = ", the reference itself" if p["ratio"] == 1.0 else speed
        if p["within"]:
            text = (
                f"Pick: {p['model']} (error {FP.fmt_err(p['error'])}, "
                f"{FP.fmt_time(p['time'])} CPU{speed}; decided by {p['decided_by']}); "
                f"{p['n_good']} of {p['n_solved']} models that solved the case are within "
                f"{tol:g}."
            )
        else:
            text = (
                f"No model is within {tol:g}; the most accurate is {p['model']} "
                f"(error {FP.fmt_err(p['error'])}, {FP.fmt_time(p['time'])}{speed})."
            )
        out.append(("p", text))
    if groups:  # one line; the reasons one click away
        names = [m for models in groups.values() for m in models]
        out.append(("details", f"Not applicable ({len(names)}): {', '.join(names)}"))
        out.append(("ul", [f"{', '.join(models)}: {reason}" for reason, models in groups.items()]))
        out.append(("/details",))
    return out


def stability(rec: Mapping) -> str:
    """``18 / 2`` stable / unstable reported equilibria (``–`` when not assessed)."""
    flags = [s.get("stable") for s in rec.get("steps") or ()]
    if all(f is None for f in flags):
        return "–"
    n_none = sum(f is None for f in flags)
    text = f"{sum(f is True for f in flags)} / {sum(f is False for f in flags)}"
    return text + (f" ({n_none} not assessed)" if n_none else "")


def _model_rows(case: Mapping, recs: Sequence[Mapping]) -> tuple[list[str], list[list]]:
    out = case.get("primary_output")
    keys = [f"{out}.{q}" for q in ("ux", "uy", "rot")] if out else []
    head = [
        "model",
        "role",
        "status",
        "wall (median)",
        "[min, max] ×n",
        "vs ref",
        "error_rel",
        "error_L",
        "predicted (eff.)",
        "grade",
        *(f"error_rel {k}" for k in keys),
        "equilibria stable / unstable",
        "note",
    ]
    rows = []
    for r in recs:
        if r["status"] == "not-applicable":
            continue  # one line per reason above, not a row each
        t = r.get("timing") or {}
        err = r.get("errors") or {}
        per = err.get("per_output") or {}
        notes = [] if r["status"] == "converged" else [r.get("message") or ""]
        notes += r.get("warnings") or []
        fid = (r.get("extras") or {}).get("fidelity")
        if isinstance(fid, Mapping):  # *-auto models: the N they chose for their target
            n = fid.get("n")
            if isinstance(n, Mapping):  # fem-auto: elements per flexible member
                n = ", ".join(f"{k} {v}" for k, v in n.items())
            notes.append(
                f"chose N = {n} (tried {fid.get('sequence')}; estimate "
                f"{FP.fmt_err(fid.get('estimate'))}, target {FP.fmt_err(fid.get('target'))})"
            )
        notes += synthnote.notes(r.get("extras") or {})  # synthesis: EI, fem-auto check
        if (r.get("grade") or {}).get("validity_warning"):
            notes.append("⚠ " + r["grade"]["validity_warning"])
        if err.get("coverage") is not None and err["coverage"] < 0.999:
            notes.append(f"reached {err['coverage']:.0%} of the reference path")
        if err.get("interpolated"):
            notes.append("reference interpolated")
        role = "reference" if r.get("is_reference") else r.get("role", "model")
        span = (
            f"[{FP.fmt_time(t.get('min_s'))}, {FP.fmt_time(t.get('max_s'))}] ×{t.get('n_repeats')}"
        )
        e = r.get("error_rel")
        rows.append(
            [
                r["model"],
                role,
                r["status"],
                FP.fmt_time(t.get("median_s")),
                span if t else "–",
                fmt_ratio(r.get("speedup_vs_reference")),
                Cell(
                    FP.fmt_err(e) + (" (refs)" if r.get("summary_basis") == "references" else ""),
                    FP.error_class(e) if e is not None else None,
                ),
                FP.fmt_err(r.get("error_L")),
                predicted_cell(r),
                grading.label(r.get("grade")),
                *(FP.fmt_err(per.get(k)) for k in keys),
                stability(r),
                "; ".join(n for n in notes if n),
            ]
        )
    return head, rows


def predicted_cell(rec: Mapping) -> str:
    """A reduced model's predicted error_rel (``reports.verdicts.predict``) and its effectivity
    (predicted / measured) in brackets, as fem-auto's estimate is shown in its note."""
    pred = (rec.get("extras") or {}).get("predicted_error")
    if pred is None:
        return "–"
    meas = rec.get("error_rel")
    eff = f" ({pred / meas:.2g}x)" if meas else ""
    return FP.fmt_err(pred) + eff


def _reference_blocks(case: Mapping, recs: Sequence[Mapping]) -> list[Block]:
    refs = case.get("references") or []
    if not refs:
        return []
    rows = [
        [
            ref_label(r),
            f"{r['value']:.6g}",
            r["kind"],
            f"{r['tolerance']:g}" + (" abs" if r.get("abs_tolerance") else " rel"),
            r["source"],
            r["rationale"],
        ]
        for r in refs
    ]
    head = ["output", "value", "kind", "tolerance", "source", "tolerance rationale"]
    blocks: list[Block] = [("h3", "Published and closed-form references"), ("table", head, rows)]
    crows = []
    for r in recs:
        if r["status"] == "not-applicable":
            continue
        cells: list = [r["model"]]
        for c in r.get("refchecks") or []:
            if c["passed"] is None:
                cells.append(Cell(f"– ({c['note']})", "na"))
            else:
                ok = "pass" if c["passed"] else "FAIL"
                cells.append(
                    Cell(f"{ok} {FP.fmt_err(c['error'])}", "good" if c["passed"] else "bad")
                )
        crows.append(cells)
    blocks.append(("table", ["model", *(ref_label(r) for r in refs)], crows))
    return blocks


def case_blocks(
    name: str, case: Mapping, recs: Sequence[Mapping], figs: Mapping, tol: float = FP.TOLERANCE
) -> list:
    """One case's section."""
    blocks: list[Block] = [("h2", f"{case.get('title') or name} ({name})", FP.anchor(name))]
    blocks += verdict(case, recs, tol)
    blocks.append(("grid",))  # two figures a row; each opens full size on a click
    for kind in FIGURE_ORDER:
        if figs.get(kind):
            wide = "wide" if kind in WIDE_FIGURES else None
            blocks.append(("img", figs[kind], f"{name}: {kind}", None, wide))
    blocks.append(("/grid",))
    blocks.append(("details", "Every model's numbers, published checks, description, files"))
    line = f"Tags: {', '.join(case.get('tags', [])) or '–'}. Units: {case.get('units', '')}. "
    line += f"Length scale L = {case.get('length_scale', 1.0):g}."
    blocks.append(("p", line))
    if case.get("description"):
        blocks.append(("p", case["description"]))
    blocks.append(("table", *_model_rows(case, recs)))
    blocks += _reference_blocks(case, recs)
    for kind in FOLDED_FIGURES:
        if figs.get(kind):
            blocks.append(("img", figs[kind], f"{name}: {kind}"))
    if figs.get("render_error"):
        blocks.append(("p", f"Render not drawn: {figs['render_error']}."))
    if figs.get("links"):
        blocks.append(("links", "ParaView files", figs["links"]))
    blocks.append(("/details",))
    return blocks


def environment_blocks(payload: Mapping) -> list[Block]:
    """Where, with what and how the run happened."""
    env, cfg = payload.get("environment", {}), payload.get("config", {})
    commit = env.get("git_commit") or "(no commit)"
    if env.get("git_dirty"):
        commit += " + uncommitted changes"
    pk = ", ".join(f"{k} {v}" for k, v in (env.get("packages") or {}).items() if v)
    stats = payload.get("stats", {})
    backend = f"dask {cfg['dask']}" if cfg.get("dask") else f"{cfg.get('workers')} local workers"
    run = (
        f"{'quick' if cfg.get('quick') else 'full'} matrix, {backend}, "
        f"{stats.get('pairs', len(payload['results']))} pairs ({stats.get('solved', '?')} "
        f"solved, {stats.get('resumed', 0)} resumed), {FP.fmt_time(payload.get('elapsed_s'))}"
    )
    rows = [
        ["time (UTC)", env.get("time", "")],
        ["git commit", commit],
        ["python", f"{env.get('python', '')} ({env.get('implementation', '')})"],
        ["machine", f"{env.get('machine', '')}, {env.get('platform', '')}"],
        ["CPU", f"{env.get('cpu', '')} ({env.get('cpu_count', '')} logical)"],
        ["packages", pk],
        ["run", run],
    ]
    blocks = [("h2", "Run environment", "environment"), ("table", ["", ""], rows)]
    return blocks + [("p", DEFINITIONS), ("p", DATA_FILES)]


DATA_FILES = (
    "Data files beside this report: results.csv is the documented table, one row per case "
    "and model (sweep points with their parameters as columns): pandas.read_csv('results.csv')"
    "; errors.csv likewise, one row per compared output. results.json is nested: json.load, "
    "or reports.load_run('.') for DataFrames (pandas.read_json cannot flatten it). "
    "history.sqlite: pandas.read_sql_query('SELECT * FROM results', sqlite3.connect("
    "'history.sqlite')). ParaView: paraview/CASE/MODEL/*.pvd (displacement, rotation, bending "
    "stress per node; time = load factor)."
)


def card_blocks(cards: Mapping[str, Mapping]) -> list[Block]:
    """Model cards (assumptions, validity, literature), internal file names replaced."""
    blocks: list[Block] = [("h2", "Model cards", "cards")]
    blocks.append(("details", f"{len(cards)} models: assumptions, validity, literature"))
    for name, card in sorted(cards.items()):
        blocks.append(("h3", f"{name} ({card.get('family', '')})"))
        blocks.append(("p", readable(card.get("summary", ""))))
        items = [f"Assumes: {readable(a)}" for a in card.get("assumptions") or ()]
        if card.get("validity"):
            items.append(f"Valid: {readable(card['validity'])}")
        items += [f"Reference: {readable(r)}" for r in card.get("references") or ()]
        if items:
            blocks.append(("ul", items))
    blocks.append(("/details",))
    return blocks


def pick_blocks(payload: Mapping, figures: Mapping) -> list[Block]:
    """The answer: one row per case (a sweep one row with its stability map), grouped by
    family; how the pick is made folded below."""
    cases, tol = payload["cases"], FP.tolerance(payload)
    by_case: dict[str, list[Mapping]] = {}
    for r in payload["results"]:
        by_case.setdefault(r["case"], []).append(r)
    sweeps = SW.parents(cases)
    thumbs = figures.get("_sweeps") or {}
    blocks: list[Block] = [("h2", "Which model to pick", "pick")]
    blocks.append(
        (
            "p",
            f"The cheapest model whose error_rel stays within {tol:g} over the whole reference "
            "path, as flexbench recommend names it; its CPU time per solve; hover 'why' for "
            "the recommender's full reason. A sweep is one row: its stability map (blue "
            "stable, red unstable) and a link to its points.",
        )
    )
    for fam, names in FA.grouped(cases).items():
        rows = [
            FP.pick_row(n, cases[n], by_case.get(n, []), tol)
            for n in names
            if not cases[n].get("sweep")
        ]
        rows += [
            SW.pick_row(p, pts, cases, by_case, tol, thumbs.get(p))
            for p, pts in sweeps.items()
            if FA.family(cases[pts[0]]) == fam
        ]
        blocks += [("h3", FA.FAMILIES[fam]), ("table", FP.PICK_HEAD, rows, {"cls": "pick"})]
    blocks.append(("details", "How the pick is made, and the grades"))
    blocks.append(("p", FP.pick_rule(tol)))
    blocks.append(("p", grading.summary_text((payload.get("config") or {}).get("tolerance"))))
    blocks.append(("/details",))
    return blocks


def _count_cases(cases: Mapping, sweeps: Mapping[str, Sequence[str]]) -> str:
    """``"34 cases and 7 sweeps (385 points)"``, or ``"4 cases"``."""
    points = sum(len(v) for v in sweeps.values())
    text = f"{len(cases) - points} cases"
    return text + (f" and {len(sweeps)} sweeps ({points} points)" if sweeps else "")


def build_document(payload: Mapping, figures: Mapping[str, Mapping[str, Any]]) -> list[Block]:
    """Format-neutral content of the report (``figures``: case -> kind -> relative PNG path;
    ``"_families"``: family -> its speed-against-error chart; ``"_sweeps"``: sweep -> (its
    stability-map thumbnail, hover text); ``"_render"``: ``{"cpu_s"}`` of drawing them)."""
    results = payload["results"]
    cases = payload["cases"]
    env = payload.get("environment", {})
    n_models = len({r["model"] for r in results})
    toc = [
        ("Which model to pick", "pick"),
        ("Accuracy map", "accuracy"),
        ("Speed against error", "overall"),
        ("Where the time goes", "time"),
    ]
    sweeps = SW.parents(cases)  # sweep points: one section per sweep (sweep_section.py)
    toc += [(name, FP.anchor(name)) for name in cases if not cases[name].get("sweep")]
    toc += [(f"{p} ({len(n)} sweep points)", FP.anchor(p)) for p, n in sweeps.items()]
    toc += [("Model cards", "cards"), ("Run environment", "environment")]
    bad = [r for r in results if r["status"] == "failed" or r.get("warnings")]
    if bad:
        toc.insert(-1, ("Failures and warnings", "failures"))
    blocks: list[Block] = [("h1", "FlexBench report"), ("toc", toc)]
    when = (env.get("time") or "")[:16].replace("T", " ")
    blocks.append(
        (
            "p",
            f"{_count_cases(cases, sweeps)} x {n_models} models, {len(results)} pairs; run "
            f"{when} UTC on {env.get('cpu', '?')}, commit "
            f"{(env.get('git_commit') or '?')[:10]}, {FP.fmt_time(payload.get('elapsed_s'))}.",
        )
    )
    blocks += pick_blocks(payload, figures)
    blocks += [("h2", "Accuracy map", "accuracy")]
    blocks.append(
        (
            "p",
            "Summary error_rel per case and model (hover a cell for its wall time or the "
            "reason it declined; a sweep's row gives each model's worst point); ref = the "
            "case's reference. The table scrolls inside its frame; the case names and model "
            "names stay in view.",
        )
    )
    blocks.append(("table", *FP.accuracy_map(payload, sweeps), {"cls": "map"}))
    blocks += FA.blocks(payload, figures)
    blocks += timebudget.blocks(payload, figures)
    ratios = payload.get("speed_ratios") or []
    if ratios:
        blocks.append(("details", "Speed ratios against baselines (same run)"))
        rows = [
            [
                r["case"],
                r["model"],
                r["baseline"],
                FP.fmt_time(r["model_s"]),
                FP.fmt_time(r["baseline_s"]),
                fmt_ratio(r["ratio"]),
            ]
            for r in ratios
        ]
        head = ["case", "model", "baseline", "model time", "baseline time", "speed-up"]
        blocks += [("table", head, rows), ("/details",)]
    if any(r.get("exports") for r in results):
        blocks.append(("p", PARAVIEW_NOTE))
    for name, case in cases.items():
        if case.get("sweep"):
            continue
        recs = [r for r in results if r["case"] == name]
        blocks += case_blocks(name, case, recs, figures.get(name, {}), FP.tolerance(payload))
    for parent, names in sweeps.items():
        blocks += SW.blocks(parent, names, cases, results)
    blocks += card_blocks(payload.get("models") or {})
    if bad:
        items = [
            f"{r['case']} / {r['model']}: {r['status']}: {r.get('message', '')}"
            + "".join(f"; {w}" for w in r.get("warnings") or [])
            for r in bad
        ]
        blocks += [("h2", "Failures and warnings", "failures"), ("ul", items)]
    blocks += environment_blocks(payload)
    return blocks
