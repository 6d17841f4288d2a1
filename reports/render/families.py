"""Families of cases on the front page: single beams, mechanisms, deployable six-bars.

The pick table is grouped by family and the overall speed-against-error charts are drawn per
family, each model over the cases of the family it solved (its own set, counted in the
table beside the chart), so every model appears where it runs.  One chart over the cases
*every* plotted model solved (the old headline) kept three models and no beam model: the
beam models decline mechanisms and the mechanism models decline single beams.

A case's family comes from its tags (``single-beam``, ``arch``, ``frame``; ``deploy``,
``six-bar``; ``mechanism``), else from its scene: a ``deploy`` analysis is a deployable, one
member a single beam, more a mechanism (scenes written elsewhere need no tags).
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence

from reports.render import frontpage as FP
from reports.render.cells import Cell

FAMILIES = {
    "beams": "Single beams, arches and frames",
    "mechanisms": "Mechanisms",
    "deployables": "Deployable six-bars",
}
BEAM_TAGS = {"single-beam", "arch", "frame"}
DEPLOY_TAGS = {"deploy", "six-bar"}


def family(case: Mapping) -> str:
    """``beams`` | ``mechanisms`` | ``deployables`` (module docstring)."""
    tags = set(case.get("tags") or ())
    if tags & DEPLOY_TAGS or (case.get("analysis") or {}).get("kind") == "deploy":
        return "deployables"
    if tags & BEAM_TAGS:
        return "beams"
    if "mechanism" in tags:
        return "mechanisms"
    return "beams" if len(case.get("undeformed") or {}) <= 1 else "mechanisms"


def grouped(cases: Mapping[str, Mapping]) -> dict[str, list[str]]:
    """Family -> its case names (run order; sweep points included), families in
    ``FAMILIES`` order, empty ones left out."""
    out: dict[str, list[str]] = {f: [] for f in FAMILIES}
    for name, case in cases.items():
        out[family(case)].append(name)
    return {f: names for f, names in out.items() if names}


def cpu(rec: Mapping) -> float | None:
    """CPU s of one solve (median of the repeats), else its wall median."""
    t = rec.get("timing") or {}
    return t.get("cpu_median_s") or t.get("median_s")


def solved(results: Sequence[Mapping], names: Sequence[str]) -> dict[str, dict[str, tuple]]:
    """model -> case -> (CPU s, error_rel) over the converged, complete pairs of ``names``
    that have an error (the exact model where it is the reference: error 0)."""
    wanted = set(names)
    out: dict[str, dict[str, tuple]] = {}
    for r in results:
        t = cpu(r)
        if r["case"] not in wanted or not t or not FP._complete(r):
            continue
        if r.get("is_reference"):
            if r["model"] in FP.EXACT_MODELS:
                out.setdefault(r["model"], {})[r["case"]] = (t, 0.0)
        elif r.get(FP.ERROR) is not None:
            out.setdefault(r["model"], {})[r["case"]] = (t, r[FP.ERROR])
    return out


def points(results: Sequence[Mapping], names: Sequence[str]) -> list[dict]:
    """One point per model over the cases of ``names`` it solved: geometric-mean CPU time,
    worst and median error, the number of cases (``n``); the exact model's ``kind`` marked."""
    pts = []
    for m, by_case in sorted(solved(results, names).items()):
        vals = list(by_case.values())
        errs = [e for _, e in vals]
        pts.append(
            {
                "model": m,
                "time": math.exp(statistics.fmean(math.log(t) for t, _ in vals)),
                "error": max(errs),
                "median_error": statistics.median(errs),
                "n": len(vals),
                "tmin": None,
                "tmax": None,
                "ok": True,
                "kind": "exact" if m in FP.EXACT_MODELS else "model",
            }
        )
    return pts


def blocks(payload: Mapping, figures: Mapping) -> list[tuple]:
    """The report section: a chart per family (drawn by ``reports.render.overall_charts``,
    ``figures["_families"]``), every model over the cases of the family it solved; the
    numbers folded below."""
    groups = grouped(payload["cases"])
    out: list[tuple] = [("h2", "Speed against error, by family of cases", "overall")]
    out.append(
        (
            "p",
            "Per family, one point per model: geometric-mean CPU time per solve and worst "
            "error_rel over the cases of the family that model solved (the exact model counts "
            "with error 0 where it is the reference); models that decline a family are not "
            "on its chart. The number of cases behind each point is in the table below.",
        )
    )
    charts = figures.get("_families") or {}
    out.append(("grid",))
    for fam in groups:
        if charts.get(fam):
            out.append(("img", charts[fam], f"speed against error: {FAMILIES[fam]}"))
    out.append(("/grid",))
    out.append(("details", "Each family's points: cases solved, CPU time, errors"))
    for fam, names in groups.items():
        pts = points(payload["results"], names)
        out.append(("h3", f"{FAMILIES[fam]} ({len(names)} cases)"))
        if not pts:
            out.append(("p", "No model solved a case of this family with a path error."))
            continue
        rows = [
            [
                p["model"],
                f"{p['n']} / {len(names)}",
                FP.fmt_time(p["time"]),
                Cell(FP.fmt_err(p["error"]), FP.error_class(p["error"])),
                Cell(FP.fmt_err(p["median_error"]), FP.error_class(p["median_error"])),
            ]
            for p in sorted(pts, key=lambda p: p["time"])
        ]
        head = ["model", "cases solved", "CPU time (geo-mean)", "worst error_rel", "median"]
        out.append(("table", head, rows))
    out.append(("/details",))
    return out
