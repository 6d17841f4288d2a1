"""The front page: which model to pick per case, which models are accurate where, how fast.

Rules the page states (``pick_rule``): a model is *good enough* on a case when it converged
over the whole reference path and its summary error (largest deviation over the path, as a
fraction of the length scale L or in rad) is at most ``TOLERANCE``; the *pick* is the fastest
good-enough model (median wall time); when none is good enough the most accurate one is named
instead.  Errors below ``ROUNDOFF`` are round-off and shown as ``0 (< 1e-12)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from reports.render.cells import Cell

TOLERANCE = 1e-2
ROUNDOFF = 1e-12
# exact where they apply: beam theory (closed form / BVP), and rigid-body kinematics with springs
# (kinetostatic declines any scene with a compliant member, so where it runs it is exact)
EXACT_MODELS = ("elastica", "elastica-bvp", "kinetostatic")
REFERENCE_PREFIXES = ("fem-", "replay")  # references, not candidates for the pick


def pick_rule(tol: float = TOLERANCE) -> str:
    """The rule the front page applies, in words."""
    return (
        f"Pick = the fastest model (median wall time) whose summary error is at most {tol:g} "
        f"({tol * 100:g} % of the length scale L, or {tol:g} rad) over the whole reference "
        "path; when no model meets it, the most accurate one is named. Colours in the accuracy "
        f"map: green <= {tol:g}, amber <= {10 * tol:g}, red above; grey = not applicable."
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
    return [
        r for r in recs if not r.get("is_reference") and r.get("error_rel") is not None and _time(r)
    ]


def is_reduced(model: str, role: str | None = "model") -> bool:
    """A model a designer would pick (not an FE/replay reference, not a timing baseline)."""
    exact = model in EXACT_MODELS  # the exact model is a choice even where it is the reference
    return (role == "model" or exact) and not model.startswith(REFERENCE_PREFIXES)


def candidates(recs: Sequence[Mapping]) -> list[dict]:
    """Pick candidates: complete reduced-model pairs with (error, time); the exact model
    counts with error 0 where it is the case's reference."""
    out = []
    for r in recs:
        t = _time(r)
        if not t or not _complete(r) or not is_reduced(r["model"], r.get("role")):
            continue
        if r.get("is_reference") and r["model"] in EXACT_MODELS:
            out.append({**r, "error_rel": 0.0, "speedup_vs_reference": 1.0})
        elif not r.get("is_reference") and r.get("error_rel") is not None:
            out.append(r)
    return out


def pick(recs: Sequence[Mapping], tol: float = TOLERANCE) -> dict[str, Any] | None:
    """The pick of one case (see ``pick_rule``): ``{"model", "error", "time", "ratio",
    "within"}`` (``within``: good enough?) or None when no model has an error."""
    cands = candidates(recs)
    if not cands:
        return None
    good = [r for r in cands if r["error_rel"] <= tol]
    best = min(good, key=_time) if good else min(cands, key=lambda r: r["error_rel"])
    return {
        "model": best["model"],
        "error": best["error_rel"],
        "time": _time(best),
        "ratio": best.get("speedup_vs_reference"),
        "within": bool(good),
        "n_good": len(good),
        "n_solved": len(cands),
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
        "its time",
        "vs reference",
        "good enough / solved",
        "most accurate approximate model",
    ]
    rows = []
    tol = tolerance(payload)
    for name, case in payload["cases"].items():
        recs = [r for r in payload["results"] if r["case"] == name]
        p = pick(recs, tol)
        ref = case.get("reference") or "–"
        link = Cell(name, href="#" + case_anchor(name, case), title=case.get("title"))
        if p is None:
            text = _no_pick(recs, case)
            rows.append([link, ref, Cell(text, "na")] + [""] * 5)
            continue
        approx = [r for r in candidates(recs) if r["model"] not in EXACT_MODELS]
        acc = min(approx, key=lambda r: (r["error_rel"], _time(r))) if approx else None
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
                "–" if acc is None else f"{acc['model']} ({fmt_err(acc['error_rel'])})",
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
                e = r.get("error_rel")
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
        elif not r.get("is_reference") and r.get("error_rel") is not None:
            out.setdefault(r["model"], {})[r["case"]] = (t, r["error_rel"])
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
