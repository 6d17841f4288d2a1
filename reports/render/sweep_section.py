"""Sweep points in the report: one section per sweep, a row per point, not a section each.

A 5 x 5 x 5 sweep is 125 point scenes; a section per point (verdict, model table, folded
details) made the report 250 sections longer without saying more than one table does.  The
point rows keep every model's status, summary error and wall time; the stability maps and
verdict counts are in the deploy part (``stability_maps.py``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from reports.render import frontpage as FP


def parents(cases: Mapping[str, Mapping]) -> dict[str, list[str]]:
    """Sweep parent -> its point cases (run order)."""
    out: dict[str, list[str]] = {}
    for name, case in cases.items():
        if case.get("sweep"):
            out.setdefault(case["sweep"]["parent"], []).append(name)
    return out


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
