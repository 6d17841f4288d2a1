"""Sweep points in the report: one section per sweep, a row per point, not a section each.

A 5 x 5 x 5 sweep is 125 point scenes; a section per point (verdict, model table, folded
details) made the report 250 sections longer without saying more than one table does.  The
point rows keep every model's status, summary error and wall time; the stability maps and
verdict counts are in the deploy part (``stability_maps.py``).
"""

from __future__ import annotations

import collections
import statistics
from collections.abc import Mapping, Sequence

from reports.render import frontpage as FP
from reports.render.cells import Cell


def parents(cases: Mapping[str, Mapping]) -> dict[str, list[str]]:
    """Sweep parent -> its point cases (run order)."""
    out: dict[str, list[str]] = {}
    for name, case in cases.items():
        if case.get("sweep"):
            out.setdefault(case["sweep"]["parent"], []).append(name)
    return out


def pick_row(
    parent: str,
    names: Sequence[str],
    cases: Mapping,
    by_case: Mapping[str, Sequence[Mapping]],
    tol: float,
    thumb: tuple[str, str] | None = None,
) -> list:
    """The sweep's one row of the front page's pick table (``FP.PICK_HEAD``): the model
    picked at most points (``FP.pick`` per point), its worst error and median CPU time over
    those points; the stability-map thumbnail (``thumb``: relative path, hover text) and a
    link to the section listing the points."""
    link = Cell(parent, href="#" + FP.anchor(parent), title=f"{parent}: {len(names)} points")
    picks = [FP.pick(cases[n], by_case.get(n, ()), tol) for n in names]
    good = collections.Counter(p["model"] for p in picks if p and p["within"])
    img, tip = thumb or (None, None)
    if not good:
        text = f"no model within {tol:g} at any of the {len(names)} points"
        return [link, Cell("none", "bad"), "", "", "", Cell(text, "why", title=tip, img=img)]
    model, k = good.most_common(1)[0]
    mine = [p for p in picks if p and p["model"] == model]
    worst = max(p["error"] for p in mine)
    ratios = [p["ratio"] for p in mine if p["ratio"]]
    speed = FP.vs_reference({**mine[0], "ratio": statistics.median(ratios) if ratios else None})
    others = ", ".join(f"{m} at {c}" for m, c in good.most_common()[1:])
    none = sum(1 for p in picks if not (p and p["within"]))
    text = f"picked at {k}/{len(names)} points" + (f"; {others}" if others else "")
    tip = f"{tip}; {text}" if tip else text
    text += f"; none within {tol:g} at {none}" if none else ""
    if all(p["error"] == 0.0 for p in mine) and model in FP.EXACT_MODELS:
        text = "exact (rigid links and springs); " + text
    return [
        link,
        Cell(model, FP.error_class(worst, tol)),
        Cell(FP.fmt_err(worst), FP.error_class(worst, tol), title="worst over those points"),
        Cell(FP.fmt_time(statistics.median(p["time"] for p in mine)), title="median"),
        speed,
        Cell(text, "why", title=tip, img=img),
    ]


def _cell(rec: Mapping | None) -> str:
    if rec is None:
        return "–"
    t = FP.fmt_time((rec.get("timing") or {}).get("median_s"))
    if rec["status"] != "converged":
        return f"{rec['status']} ({t})"
    err = "ref" if rec.get("is_reference") else FP.fmt_err(rec.get("error_rel"))
    return f"{err} ({t})"


def blocks(parent: str, names: Sequence[str], cases: Mapping, results: Sequence[Mapping]) -> list:
    """The sweep's section: a row per point (coordinates, then each model's error and time)."""
    by: dict[str, dict[str, Mapping]] = {n: {} for n in names}
    for r in results:
        if r["case"] in by:
            by[r["case"]][r["model"]] = r
    models = sorted({m for recs in by.values() for m in recs})
    keys = list(cases[names[0]]["sweep"]["point"])
    head = ["point", *(".".join(k.split(".")[1:]) or k for k in keys), *models]
    rows = [
        [n.rsplit("/", 1)[-1], *(f"{cases[n]['sweep']['point'][k]:g}" for k in keys)]
        + [_cell(by[n].get(m)) for m in models]
        for n in names
    ]
    return [
        ("h2", f"Sweep {parent}: {len(names)} points", FP.anchor(parent)),
        (
            "p",
            "Each point is a scene of its own; cells give the summary error against the "
            "point's reference and the wall time of the solve (single shot per point). The "
            "stability maps and verdict counts are in the deployable six-bar section below.",
        ),
        ("details", f"All {len(names)} points"),
        ("table", head, rows),
        ("/details",),
    ]
