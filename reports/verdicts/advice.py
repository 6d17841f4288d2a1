"""``recommend``'s judgement and pick over the records of a ``flexbench run``: the report's
front page and the teaching page name the model ``flexbench recommend`` would name among the
same models (same ``judge``, same costs: ``reports.verdicts.cost``'s shared estimates, same
``reports.verdicts.pick.choose``), without solving anything.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from reduced_models.base import Solution, Step
from reports.verdicts import errors
from reports.verdicts.pick import EXCLUDED
from reports.verdicts.recommend import exact_candidate, judge
from reports.verdicts.recommendation import Candidate, Recommendation, verdict
from reports.verdicts.tolerance import Tolerance, for_case


def from_records(
    case: Mapping[str, Any], recs: Sequence[Mapping], tol: str | float | Tolerance
) -> Recommendation | None:
    """The recommendation over the records of one case of a ``flexbench run`` (no solve):
    every ``model`` record judged against the reference record (``judge``), costs from the
    records' shared estimates (``rec["cost"]``, ``reports.verdicts.cost``; the run's CPU median with
    noise 0 where a pair has none), the exact reference with error 0, then ``verdict``.
    None without a converged reference."""
    tolerance = for_case(case.get("tolerances") or (), tol)  # the case's judged outputs
    ref_name = case.get("reference")
    ref = next((r for r in recs if r["model"] == ref_name), None)
    if ref is None or ref["status"] != "converged" or not ref.get("steps"):
        return None
    ref_cpu, ref_noise = record_cost(ref)
    exact = exact_candidate(ref_name, ref["status"], ref_cpu, ref_noise, ref.get("unknowns"))
    cands = [exact] if exact else []
    for r in recs:
        name = r["model"]
        if r["role"] != "model" or name == ref_name or name in EXCLUDED:
            continue
        cand = Candidate(name, r["status"], r.get("message") or "", unknowns=r.get("unknowns"))
        cand.cpu_s, cand.noise_s = record_cost(r)
        if r.get("steps"):
            sol = _solution(r)
            judge(cand, sol, ref["steps"], case, tolerance, case.get("uncertainty") or 0)
        cand.ratio_to_reference = cand.cpu_s / ref_cpu if cand.cpu_s and ref_cpu else None
        cands.append(cand)
    best, reason, decided_by = verdict(cands, tolerance, lambda name, cpu: cpu)
    rec = Recommendation(case["name"], tolerance, best, reason, ref_name, ref_cpu, cands)
    rec.decided_by = decided_by
    return rec


def record_cost(rec: Mapping) -> tuple[float | None, float]:
    """(CPU s, noise s) of a run record: its shared estimate, else its CPU median."""
    est = rec.get("cost")
    if est:
        return est["cpu_s"], est["noise_s"]
    return errors.cost_s(rec), 0.0


def _solution(rec: Mapping) -> Solution:
    """A record's steps as a ``Solution`` (what ``judge`` reads)."""

    def num(x: Any) -> float:  # JSON null (NaN or unknown) back to NaN
        return math.nan if x is None else float(x)

    steps = tuple(
        Step(
            num(s["factor"]),
            {k: num(v) for k, v in s["outputs"].items()},
            num(s.get("energy")),
            int(s.get("iterations") or 0),
        )
        for s in rec["steps"]
    )
    message, extras = rec.get("message") or "", rec.get("extras") or {}
    return Solution(rec["case"], rec["model"], rec["status"], message, steps, extras)
