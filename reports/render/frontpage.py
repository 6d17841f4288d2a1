"""The front page: which model to pick per case, which models are accurate where, how fast.

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
REFERENCE_PREFIXES = ("fem-", "replay")  # references, not candidates for the pick


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


def case_anchor(name: str, case: Mapping) -> str:
    """Where a case's row links: its section, or its sweep's (points have no section)."""
    return anchor((case.get("sweep") or {}).get("parent") or name)


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


def judged(recs: Sequence[Mapping]) -> list[Mapping]:
    """Records with an error and a time that are not the case's reference."""
    return [r for r in recs if not r.get("is_reference") and r.get(ERROR) is not None and _time(r)]


def is_reduced(model: str, role: str | None = "model") -> bool:
    """A model a designer would pick (not an FE/replay reference, not a timing baseline)."""
    exact = model in EXACT_MODELS  # the exact model is a choice even where it is the reference
    return (role == "model" or exact) and not model.startswith(REFERENCE_PREFIXES)


def candidates(recs: Sequence[Mapping]) -> list[dict]:
    """Complete reduced-model pairs with (error, time); the exact model counts with error 0
    where it is the case's reference (the "most accurate" column and the overall plot)."""
    out = []
    for r in recs:
        t = _time(r)
        if not t or not _complete(r) or not is_reduced(r["model"], r.get("role")):
            continue
        if r.get("is_reference") and r["model"] in EXACT_MODELS:
            out.append({**r, ERROR: 0.0, "speedup_vs_reference": 1.0})
        elif not r.get("is_reference") and r.get(ERROR) is not None:
            out.append(r)
    return out


def pick(case: Mapping, recs: Sequence[Mapping], tol: float = TOLERANCE) -> dict[str, Any] | None:
    """The pick of one case (``reports.verdicts.advice.from_records``): ``{"model", "error", "time"
    (CPU s), "ratio" (reference / model CPU), "within" (good enough?), "n_good", "n_solved",
    "decided_by"}``; None when no model could be judged."""
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


def pick_table(payload: Mapping) -> tuple[list[str], list[list]]:
    """Headers and rows of the front page's "which model to pick" table."""
    head = [
        "case",
        "reference",
        "pick",
        "its error",
        "its CPU time",
        "vs reference",
        "good enough / solved",
        "most accurate approximate model",
        "decided by",
    ]
    rows = []
    tol = tolerance(payload)
    for name, case in payload["cases"].items():
        recs = [r for r in payload["results"] if r["case"] == name]
        p = pick(case, recs, tol)
        ref = case.get("reference") or "–"
        link = Cell(name, href="#" + case_anchor(name, case), title=case.get("title"))
        if p is None:
            text = _no_pick(recs, case)
            rows.append([link, ref, Cell(text, "na")] + [""] * 6)
            continue
        approx = [r for r in candidates(recs) if r["model"] not in EXACT_MODELS]
        acc = min(approx, key=lambda r: (r[ERROR], _time(r))) if approx else None
        label = p["model"] if p["within"] else f"none within {tol:g}"
        rows.append(
            [
                link,
                ref,
                Cell(label, error_class(p["error"], tol) if p["within"] else "bad"),
                Cell(fmt_err(p["error"]), error_class(p["error"], tol)),
                fmt_time(p["time"]),
                fmt_speed(p["ratio"]),
                f"{p['n_good']} / {p['n_solved']}",
                "–" if acc is None else f"{acc['model']} ({fmt_err(acc[ERROR])})",
                p["decided_by"] or "–",
            ]
        )
    return head, rows


def accuracy_map(payload: Mapping) -> tuple[list[str], list[list]]:
    """Case x model matrix of summary errors (coloured cells; hover: wall time)."""
    models = sorted({r["model"] for r in payload["results"]})
    head = ["case", *models]
    tol = tolerance(payload)
    rows = []
    for name in payload["cases"]:
        by = {r["model"]: r for r in payload["results"] if r["case"] == name}
        row: list = [Cell(name, href="#" + case_anchor(name, payload["cases"][name]))]
        for m in models:
            r = by.get(m)
            if r is None:
                row.append(Cell("", "na"))
            elif r.get("is_reference"):
                row.append(Cell("ref", "ref", title=f"reference, {fmt_time(_time(r))}"))
            elif r["status"] == "not-applicable":
                row.append(Cell("n/a", "na", title=r.get("message")))
            elif r["status"] == "failed":
                row.append(Cell("fail", "fail", title=r.get("message")))
            else:
                e = r.get(ERROR)
                tip = f"{fmt_time(_time(r))}; {r['status']}"
                row.append(
                    Cell(fmt_err(e).replace(" (< 1e-12)", ""), error_class(e, tol), title=tip)
                )
        rows.append(row)
    return head, rows


def solved_by_model(payload: Mapping) -> dict[str, dict[str, tuple[float, float]]]:
    """model -> case -> (median time, summary error) over converged, complete pairs; the
    exact model where it is the reference counts with error 0."""
    out: dict[str, dict[str, tuple[float, float]]] = {}
    for r in payload["results"]:
        t = _time(r)
        if not t or not _complete(r):
            continue
        if r.get("is_reference") and r["model"] in EXACT_MODELS:
            out.setdefault(r["model"], {})[r["case"]] = (t, 0.0)
        elif not r.get("is_reference") and r.get(ERROR) is not None:
            out.setdefault(r["model"], {})[r["case"]] = (t, r[ERROR])
    return out


def common_set(payload: Mapping, min_cases: int = 2) -> tuple[list[str], list[str], list[str]]:
    """(models, cases, left-out models): models added in order of how many cases they solved
    while the cases every chosen model solved stay at least ``min_cases``; the choice with the
    most (model, case) pairs wins."""
    solved = solved_by_model(payload)
    order = sorted(solved, key=lambda m: (-len(solved[m]), m))
    best: tuple[int, list[str], list[str]] = (0, [], [])
    common: set[str] | None = None
    for k, m in enumerate(order, start=1):
        common = set(solved[m]) if common is None else common & set(solved[m])
        if len(common) < min_cases:
            break
        if k * len(common) > best[0]:
            best = (k * len(common), order[:k], sorted(common))
    models = best[1]
    return models, best[2], [m for m in order if m not in models]


def overall_points(payload: Mapping, models: Sequence[str], cases: Sequence[str]) -> list[dict]:
    """Per model over ``cases``: geometric-mean time, worst error (the overall plot's points)."""
    solved = solved_by_model(payload)
    pts = []
    for m in models:
        vals = [solved[m][c] for c in cases]
        gmean = math.exp(sum(math.log(t) for t, _ in vals) / len(vals))
        pts.append(
            {
                "model": m,
                "time": gmean,
                "error": max(e for _, e in vals),
                "tmin": min(t for t, _ in vals),
                "tmax": max(t for t, _ in vals),
                "ok": True,
                "kind": "exact" if m in EXACT_MODELS else "model",
            }
        )
    return pts
