"""Where the run's CPU time went: per model family, the references, the atlases, rendering.

From the run's own records: each pair's ``timing`` (the first solve, the timing repeats, post-
processing) and ``cost`` (the samples of the pick's cost estimate, when not taken from the
cache; a solve slower than ``cost.BUDGET_S`` is its own estimate, no sample); reference pairs an
earlier run solved (``"cached"``, ``reports.run.refcache``) cost this run nothing and are
counted apart; the runner's ``stats["cpu"]`` (``reports.run.runner``: CPU of every process of
the local pool over the solving stage, the teaching atlases computed in this run, the per-case
figures drawn while solving, and writing the teaching page, which only the run itself knows: a
re-render with ``flexbench report`` does not show that row); and the CPU of rendering this
report (``figures["_render"]``, measured by ``reports.render.render_report``). What the solving
stage spent outside the timed parts (exports, serialisation, the pool, imports) is shown as the
rest, so the rows add up to what was measured.
"""

from __future__ import annotations

from collections.abc import Mapping

from reports.render import frontpage as FP

GROUPS = (  # model-name prefix -> row of the panel (first match)
    ("fem-", "reference: finite elements (fem-N, fem-auto)"),
    ("replay", "reference: dynamics replay"),
    ("elastica", "elastica (exact, BVP)"),
    ("linear", "linear beams"),
    ("prb", "PRB models"),
    ("bcm", "BCM"),
    ("cbcm", "chained BCM"),
    ("kinetostatic", "mechanism assembler (kinetostatic, mixed)"),
    ("mixed", "mechanism assembler (kinetostatic, mixed)"),
    ("thesis", "thesis force method"),
)


def group(model: str) -> str:
    """The panel row of a model."""
    return next((label for pre, label in GROUPS if model.startswith(pre)), "other models")


def pair_cpu(rec: Mapping) -> tuple[float, float, float]:
    """(solve, post-processing, cost estimate) CPU s of one pair: the first solve plus its
    timing repeats (median x count), the post-processing, and the CPU the cost estimate's
    sampling spent (``spent_s``, ``cost.measure``: none when the estimate came from the cache
    or is the first solve itself; a run older than ``spent_s`` shows it in the rest)."""
    t = rec.get("timing") or {}
    first = t.get("first_cpu_s") or 0.0
    repeated = (t.get("total_s") or 0.0) > (t.get("first_s") or 0.0)
    solve = first + ((t.get("cpu_median_s") or 0.0) * (t.get("n_repeats") or 0) if repeated else 0)
    est = rec.get("cost") or {}
    sample = 0.0 if est.get("cached") else est.get("spent_s") or 0.0
    return solve, t.get("post_cpu_s") or 0.0, sample


def rows(payload: Mapping, figures: Mapping) -> tuple[list[list], float]:
    """Rows ``[what, pairs, CPU s, share]`` and the total CPU s they add up to."""
    by: dict[str, list[float]] = {}
    reused = 0
    for r in payload["results"]:
        if not r.get("timing"):
            continue
        if r.get("cached"):  # an earlier run's solve, copied from the cache
            reused += 1
            continue
        acc = by.setdefault(group(r["model"]), [0, 0.0, 0.0, 0.0])
        acc[0] += 1
        for i, v in enumerate(pair_cpu(r), start=1):
            acc[i] += v
    cpu = (payload.get("stats") or {}).get("cpu") or {}
    items: list[tuple[str, str, float, str]] = []
    order = list(dict.fromkeys(label for _, label in GROUPS)) + ["other models"]
    for label in sorted(by, key=order.index):
        n, solve, post, est = by[label]
        detail = f"solves {solve:.3g} s, post-processing {post:.3g} s, cost estimates {est:.3g} s"
        items.append((label, str(n), solve + post + est, detail))
    if reused:
        what = "solved by an earlier run of this code ($FLEXBENCH_CACHE)"
        items.append(("reference pairs reused from the cache", str(reused), 0.0, what))
    atlases = cpu.get("atlases_s") or {}
    if atlases:
        parts = ", ".join(f"{k} {v:.3g} s" for k, v in sorted(atlases.items()))
        items.append(("validity atlases (teaching page)", "", sum(atlases.values()), parts))
    elif cpu.get("atlases_reused"):
        items.append(("validity atlases (teaching page)", "", 0.0, "reused from the cache"))
    early = cpu.get("figures_s") or 0.0
    timed = sum(i[2] for i in items) + early
    if cpu.get("solve_stage_s"):
        rest = max(cpu["solve_stage_s"] - timed, 0.0)
        what = "exports, serialisation, the pool, imports, judging errors"
        items.append(("rest of the solving stage", "", rest, what))
    if early:
        items.append(("per-case figures drawn while solving", "", early, ""))
    if cpu.get("teaching_page_s") is not None:
        what = "atlases no pool worker ran included"
        items.append(("writing the teaching page", "", cpu["teaching_page_s"], what))
    render = (figures.get("_render") or {}).get("cpu_s")
    if render is not None:
        items.append(("rendering this report (figures, scenes, maps)", "", render, ""))
    total = sum(i[2] for i in items)
    out = [[label, n, f"{sec:.3g}", _share(sec, total), detail] for label, n, sec, detail in items]
    return out, total


def _share(sec: float, total: float) -> str:
    if not total:
        return "–"
    return "< 1%" if 0 < sec / total < 0.005 else f"{sec / total:.0%}"


def blocks(payload: Mapping, figures: Mapping) -> list[tuple]:
    """The "Where the time goes" section."""
    body, total = rows(payload, figures)
    cpu = (payload.get("stats") or {}).get("cpu") or {}
    stage = cpu.get("solve_stage_s")
    text = (
        f"CPU seconds of this run by what they bought: {total:.3g} s in all "
        f"(wall {FP.fmt_time(payload.get('elapsed_s'))})."
    )
    if stage:
        text += (
            f" The solving stage measured {stage:.3g} s over this process and its pool "
            "workers; the pairs' own timings are in the rows above the rest."
        )
    else:
        text += " The run did not record its solving stage's total (an older run or Dask)."
    head = ["what", "pairs", "CPU s", "share", "of which"]
    return [("h2", "Where the time goes", "time"), ("p", text), ("table", head, body)]
