"""The front page: which model to pick per case, which models are accurate where, how fast.

One row per case in the pick table (``pick_row``; a sweep's row is
``reports.render.sweep_section.pick_row``), grouped by family (``reports.render.families``);
the accuracy map has a row per case and one per sweep (its worst error per model).

The pick of a case is the one ``flexbench recommend`` makes among the models of the run
(``reports.verdicts.advice.from_records``: the recommender's judgement of every record, the shared
cost estimates of ``reports.verdicts.cost``, ``reports.verdicts.pick.choose``; ``pick_rule`` says it
in words); when no model is good enough the most accurate one is named instead.  The accuracy map
shows each record's ``ERROR`` field.  Errors below ``ROUNDOFF`` are round-off and shown as
``0 (< 1e-12)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from reports.render.cells import Cell
from reports.verdicts.pick import TIE

TOLERANCE = 1e-2
ROUNDOFF = 1e-12
# the records' error field shown in the map (yardstick: reports.verdicts.yardstick)
ERROR = "error_rel"
# exact where they apply: beam theory (closed form / BVP), and rigid-body kinematics with springs
# (kinetostatic declines any scene with a compliant member, so where it runs it is exact)
EXACT_MODELS = ("elastica", "elastica-bvp", "kinetostatic")


def pick_rule(tol: float = TOLERANCE) -> str:
    """The rule the front page applies, in words."""
    return (
        f"Pick = what flexbench recommend --tol {tol:g} names among this run's models: the "
        f"cheapest whose judged errors stay within {tol:g} over the whole reference path (the "
        "exact reference counts with error 0). Cost = the CPU time of the model's own solve "
        "(median of repeats until stable, cached per code version: the same numbers "
        f"flexbench recommend ranks by); costs within their measured noise or {TIE:.0%} of "
        "each other are a tie, which goes to the model with fewer a-priori unknowns, then to "
        "the first name ('decided by'). When no model meets the tolerance, the most accurate "
        f"one is named. Colours in the accuracy map: green <= {tol:g}, amber <= {10 * tol:g}, "
        "red above; grey = not applicable."
    )


def tolerance(payload: Mapping) -> float:
    """The run's tolerance (``flexbench run --tol``), else ``TOLERANCE``."""
    return (payload.get("config") or {}).get("tolerance") or TOLERANCE


def fmt_err(x: float | None) -> str:
    """An error for a reader: ``3.1e-03``, ``0 (< 1e-12)`` at round-off, ``–`` when missing."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if abs(x) < ROUNDOFF:
        return "0 (< 1e-12)"
    return f"{x:.1e}"


def fmt_short(x: float | None) -> str:
    """An error in four characters for the accuracy map: ``3e-3``, ``0`` at round-off (the
    cell's hover text has ``fmt_err``)."""
    if x is None or not math.isfinite(x):
        return "–"
    if abs(x) < ROUNDOFF:
        return "0"
    mant, exp = f"{x:.0e}".split("e")
    return f"{mant}e{int(exp)}"


def fmt_time(s: float | None) -> str:
    """Seconds as µs/ms/s."""
    if s is None or not math.isfinite(s):
        return "–"
    if s < 1e-3:
        return f"{s * 1e6:.0f} µs"
    return f"{s * 1e3:.3g} ms" if s < 1.0 else f"{s:.3g} s"


def fmt_speed(ratio: float | None) -> str:
    """Reference time / model time as ``3.2x faster`` or ``2.4x slower``."""
    if ratio is None or ratio <= 0:
        return "–"
    if ratio == 1.0:
        return "is the reference"
    return f"{ratio:.3g}x faster" if ratio >= 1 else f"{1 / ratio:.3g}x slower"


def anchor(case: str) -> str:
    """HTML id of a case's section."""
    return "case-" + "".join(c if c.isalnum() or c in "-_" else "-" for c in case)


def error_class(err: float | None, tol: float = TOLERANCE) -> str:
    """CSS class of an error cell."""
    if err is None:
        return "na"
    return "good" if err <= tol else ("warn" if err <= 10 * tol else "bad")


def _time(rec: Mapping) -> float | None:
    return (rec.get("timing") or {}).get("median_s")


def _complete(rec: Mapping) -> bool:
    cov = (rec.get("errors") or {}).get("coverage")
    return rec["status"] == "converged" and (cov is None or cov >= 0.999)


def pick(case: Mapping, recs: Sequence[Mapping], tol: float = TOLERANCE) -> dict[str, Any] | None:
    """The pick of one case (``reports.verdicts.advice.from_records``): ``{"model", "error", "time"
    (CPU s), "ratio" (reference / model CPU), "within" (good enough?), "n_good", "n_solved",
    "decided_by", "reason" (the recommender's paragraph), "reference"}``; None when no model
    could be judged."""
    from reports.verdicts.advice import from_records

    rec = from_records(case, recs, tol)
    judged = [c for c in rec.candidates if c.worst_error is not None] if rec else []
    if not judged:
        return None
    good = [c for c in judged if c.qualifies]
    if rec.recommended:
        best = next(c for c in judged if c.model == rec.recommended)
    else:
        best = min(judged, key=lambda c: (c.worst_error / (c.tolerance or tol), c.model))
    ratio = best.ratio_to_reference
    return {
        "model": best.model,
        "error": best.worst_error,
        "time": best.cpu_s,
        "ratio": 1.0 / ratio if ratio else None,
        "within": bool(good),
        "n_good": len(good),
        "n_solved": len(judged),
        "decided_by": rec.decided_by,
        "reason": rec.reason,
        "reference": rec.reference,
    }


def declines(recs: Sequence[Mapping]) -> dict[str, list[str]]:
    """Not-applicable models of a case grouped by their reason."""
    out: dict[str, list[str]] = {}
    for r in recs:
        if r["status"] == "not-applicable":
            out.setdefault(r.get("message") or "no reason given", []).append(r["model"])
    return out


def _no_pick(recs: Sequence[Mapping], case: Mapping) -> str:
    """Why a case has no pick, in words: declines, failures, or nothing to compare with."""
    if case.get("reference") == "kinetostatic":
        return "kinetostatic (exact: no compliant member)"
    n_na = sum(r["status"] == "not-applicable" for r in recs)
    n_failed = sum(r["status"] == "failed" for r in recs)
    solved = [r for r in recs if r["status"] == "converged" and not r.get("is_reference")]
    parts = [f"{n_na} decline"] if n_na else []
    parts += [f"{n_failed} fail"] if n_failed else []
    if solved:
        parts.append(f"{len(solved)} solved without a path error to rank (see the case)")
    return "none: " + ", ".join(parts) if parts else "none: no reduced model solved it"


PICK_HEAD = ["case", "pick", "its error_rel", "its CPU time", "vs reference", "why"]


RULES = {  # pick.choose's deciding rule, as the pick table says it
    "only qualifying": "the only one",
    "cost": "cheapest",
    "tie: fewer unknowns": "tie, fewer unknowns",
    "tie: name": "tie, first name",
}


def why(case: Mapping, p: Mapping, tol: float) -> str:
    """The pick's reason in one line (the recommender's paragraph is the cell's hover text)."""
    if not p["within"]:
        return p["reason"]
    share = f"{p['n_good']}/{p['n_solved']} within {tol:g}"
    if p["error"] == 0.0 and p["model"] in EXACT_MODELS:
        what = "rigid links and springs" if p["model"] == "kinetostatic" else "closed form"
        return f"exact ({what}); {share}"
    return f"{share}; {RULES.get(p['decided_by'], p['decided_by'] or '–')}"


def vs_reference(p: Mapping) -> Cell:
    """``31x faster`` (hover: than which reference), ``is the reference``."""
    ref = p.get("reference")
    return Cell(fmt_speed(p["ratio"]), title=f"CPU time against the reference {ref}")


def pick_row(name: str, case: Mapping, recs: Sequence[Mapping], tol: float) -> list:
    """One case's row of the pick table (``PICK_HEAD``)."""
    link = Cell(name, href="#" + anchor(name), title=case.get("title"))
    p = pick(case, recs, tol)
    if p is None:
        text = _no_pick(recs, case)
        return [link, Cell("none", "na"), "", "", "", Cell(text, "na", title=text)]
    label = p["model"] if p["within"] else f"none within {tol:g}"
    cls = error_class(p["error"], tol)
    return [
        link,
        Cell(label, cls if p["within"] else "bad", title=None if p["within"] else p["model"]),
        Cell(fmt_err(p["error"]) + ("" if p["within"] else f" ({p['model']})"), cls),
        fmt_time(p["time"]),
        vs_reference(p),
        Cell(why(case, p, tol), "why", title=p["reason"]),
    ]


def accuracy_map(
    payload: Mapping, sweeps: Mapping[str, Sequence[str]] | None = None
) -> tuple[list[str], list[list]]:
    """Case x model matrix of summary errors (coloured cells; hover: CPU time or the reason);
    a sweep (``sweeps``: parent -> its points) is one row of its worst errors."""
    models = sorted({r["model"] for r in payload["results"]})
    tol = tolerance(payload)
    by: dict[str, dict[str, Mapping]] = {}
    for r in payload["results"]:
        by.setdefault(r["case"], {})[r["model"]] = r
    rows = []
    points = {n for names in (sweeps or {}).values() for n in names}
    for name in payload["cases"]:
        if name not in points:
            link = Cell(name, href="#" + anchor(name), title=payload["cases"][name].get("title"))
            rows.append([link, *(_map_cell(by.get(name, {}).get(m), tol) for m in models)])
    for parent, names in (sweeps or {}).items():
        link = Cell(f"{parent} ({len(names)} points)", href="#" + anchor(parent), title=parent)
        recs = {m: [by.get(n, {}).get(m) for n in names] for m in models}
        rows.append([link, *(_sweep_cell(recs[m], tol) for m in models)])
    return ["case", *models], rows


def _map_cell(r: Mapping | None, tol: float) -> Cell:
    if r is None:
        return Cell("", "na")
    if r.get("is_reference"):
        return Cell("ref", "ref", title=f"reference, {fmt_time(_time(r))}")
    if r["status"] == "not-applicable":
        return Cell("n/a", "na", title=r.get("message"))
    if r["status"] == "failed":
        return Cell("fail", "fail", title=r.get("message"))
    e = r.get(ERROR)
    tip = f"{fmt_err(e)}; {fmt_time(_time(r))}; {r['status']}"
    return Cell(fmt_short(e), error_class(e, tol), title=tip)


def _sweep_cell(recs: Sequence[Mapping | None], tol: float) -> Cell:
    """A model over a sweep's points: ``ref`` when it is the reference at every point, its
    worst error, ``n/a`` when it declines every point; failures counted in the text."""
    there = [r for r in recs if r is not None]
    if not there:
        return Cell("", "na")
    if all(r.get("is_reference") for r in there):
        return Cell("ref", "ref", title=f"reference at all {len(there)} points")
    if all(r["status"] == "not-applicable" for r in there):
        return Cell("n/a", "na", title=there[0].get("message"))
    errs = [r[ERROR] for r in there if r["status"] == "converged" and r.get(ERROR) is not None]
    n_fail = sum(r["status"] == "failed" for r in there)
    worst = max(errs) if errs else None
    text = "fail" if worst is None else fmt_short(worst)
    tip = f"{fmt_err(worst)}: worst of {len(errs)} converged points of {len(there)}; "
    tip += f"{n_fail} failed"
    cls = "fail" if worst is None else ("bad" if n_fail else error_class(worst, tol))
    return Cell(text + (f" ({n_fail} fail)" if n_fail and errs else ""), cls, title=tip)
