"""``flexbench recommend``: the cheapest model whose error stays within a user's tolerance.

``recommend(scene, tol)`` solves the case's reference once, then walks *ladders* of candidate
models (a parametrised family is one ladder of rising N: ``linear-1, linear-2, linear-4, ...``;
a fixed model such as ``prb-3r`` is a ladder of one), cheapest first:

* the next model run is always the one with the lowest *cost bound* -- the measured CPU time of
  the member before it on its ladder (0 for a ladder's first member, ties broken by the number
  of unknowns the model has a priori);
* a ladder ends at its first qualifying member (a larger N costs more) or when a model
  declines the scene;
* once a model qualifies at cost c, every ladder whose bound cannot tie with c
  (``pick.cannot_tie``) is dropped: none of its members can be cheaper or tied (early exit);
* a self-refining ``family-auto`` (target: the smallest tolerance) joins once its family's
  N0, 2 N0, 4 N0 members are measured, with their summed cost as its bound
  (``auto_candidates``).

*Qualifies* means: the model converged over the whole path (it reaches the reference's last
load factor) and, for every judged output, the largest error along the path on the default
yardstick (``error_rel`` of ``reports.verdicts.errors``: the output's error over its own excursion
along the reference path, against a floor where that excursion is ~0) is within that output's
tolerance.  Judged outputs: the case's ``[[tolerances]]`` when it names them (merged with the
user's ``--tol``), else displacements and rotations of the case's named outputs (``.ux``,
``.uy``, ``.rot``), the load factor of path analyses and any non-node output.

Cost is the model's own solve on this scene, estimated by ``reports.verdicts.cost`` (CPU time, BLAS
pinned, sampled until the median is stable, cached per code version: the runner reads the same
numbers).  The pick among the qualifying models is ``reports.verdicts.pick.choose``: the cheapest,
where costs within their measured noise or ``pick.TIE`` of each other are a tie broken by fewer
a-priori unknowns (``pick.unknowns``), then name; ``decided_by`` names the rule that decided.
The reference model is what the others are measured against and no candidate, except where it
is exact (``pick.EXACT``: the elastica on a single beam, kinetostatic on rigid links and
springs): it then joins with error 0 at its own cost.  ``reports.verdicts.advice.from_records``
applies the same judgement and pick to the records of a ``flexbench run`` (the report's front page
and the teaching page).  The records (``Candidate``, ``Recommendation``), the verdict and its
words are in ``reports.verdicts.recommendation``.
"""

from __future__ import annotations

import functools
import heapq
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

from cases.schema import Scene
from reduced_models.base import Solution
from reports import api
from reports.verdicts import cost as costing
from reports.verdicts import errors, pick
from reports.verdicts.pick import EXACT, EXCLUDED
from reports.verdicts.recommendation import Candidate, Recommendation, as_option, verdict
from reports.verdicts.tolerance import (
    Tolerance,
    ToleranceError,
    for_case,
    judged_errors,
    parse_tolerance,
    pct,
)

# member N of each parametrised ladder (the FE starts at 2 elements per member)
LADDER_N: dict[str, tuple[int, ...]] = {
    "linear-N": (1, 2, 4, 8, 16, 32, 64),
    "cbcm-N": (2, 4, 8, 16, 32, 64),
    "prb-fsm-N": (2, 4, 8, 16, 32, 64),
    "fem-N": (2, 4, 8, 16, 32, 64, 128),
}
DEFAULT_N = (1, 2, 4, 8, 16, 32)  # a parametrised family registered by another package


# -- cost --------------------------------------------------------------------------------------
def measured(
    model: Any, scene: Scene, name: str, options: Mapping, sample: bool = True
) -> tuple[Solution, costing.Estimate | None]:
    """(the model's solution, its cost estimate: cached or sampled; None when it declined).
    ``sample=False``: the one solve's CPU time, noise 0 (a caller ranking by its own cost)."""
    with costing.quiet_process():
        t0 = time.process_time()
        sol = api.run_model(model, scene, post=False)
        first = time.process_time() - t0
    if sol.status == "not-applicable":
        return sol, None
    if not sample:
        return sol, costing.Estimate(first, 0.0, 1)
    again = lambda: api.run_model(model, scene, post=False)  # noqa: E731
    return sol, costing.estimate(scene, name, options, again, first)


# -- candidates --------------------------------------------------------------------------------
def ladders(scene: Scene, reference: str | None) -> list[list[str]]:
    """Candidate ladders for ``scene``: each a list of model names of rising cost."""
    out = []
    for key in api.model_names():
        if key in EXCLUDED or key == reference or key.endswith("-auto"):
            continue
        if key == "prb-custom" and not scene.model_options(key):
            continue
        if key.endswith("-N"):
            out.append([f"{key[:-2]}-{n}" for n in LADDER_N.get(key, DEFAULT_N)])
        else:
            out.append([key])
    return out


def _options(name: str, scene: Scene, tol: Tolerance) -> dict:
    """The case's options for ``name``; ``*-auto`` gets the smallest tolerance as its target."""
    opts = dict(scene.model_options(name))
    if name.endswith("-auto"):
        opts.setdefault("target", min(tol.values(), default=0.01))
    return opts


def judge(
    cand: Candidate,
    sol: Solution,
    ref_steps: list[dict],
    meta: Mapping[str, Any],
    tol: Tolerance,
    uncertainty: float = 0.0,
) -> None:
    """Fill ``cand``'s errors and verdict from its solution against the reference path.

    Errors are on the default yardstick (``error_rel``: each output over its own excursion
    along the reference path) unless ``tol`` gives an output an absolute value.
    ``uncertainty`` (``error_rel``) is the reference's own error estimate: a model qualifies
    only if its measured error plus that stays within the tolerance.
    """
    from reports.run import store  # lazy: ``import reports`` (the CLI) does not need sqlite

    steps, _, _ = store.steps_json(sol)
    stop = errors.abscissa_output(meta)
    pe = errors.path_errors(steps, ref_steps, meta["length_scale"], stop, meta)
    cand.errors = {k: v for k, v in pe["per_output"].items() if v is not None}
    judged = judged_errors(pe, tol)
    if sol.extras.get("validity_warning"):
        cand.warning = str(sol.extras.get("validity_message", "outside its validity range"))
    if not judged or pe["n_points"] < 2:
        cand.message = "path cannot be compared with the reference's: " + (
            pe["note"] or f"{pe['n_points']} common {pe['abscissa']} value(s)"
        )
        return
    _, key, e, t = max(judged)
    cand.profile = _profile(steps, ref_steps, judged, pe, tol)
    cand.worst_output, cand.worst_error, cand.tolerance = key, e, t
    cand.yardstick = "abs" if key in tol.absolute else "error_rel"
    cand.at_factor = pe["per_output_at"].get(key, pe["per_output_at"].get(f"{key}.uy"))
    coverage = pe["coverage"] or 0.0
    if sol.status != "converged":
        cand.message = sol.message
    elif coverage < 1.0 - 1e-6:
        cand.message = f"path covers {coverage:.0%} of the reference's"
    else:
        cand.uncertainty = uncertainty
        cand.qualifies = all(
            e + (0.0 if k in tol.absolute else uncertainty) <= t for _, k, e, t in judged
        )


def _profile(
    steps: list[dict],
    ref_steps: list[dict],
    judged: list[tuple[float, str, float, float]],
    pe: Mapping[str, Any],
    tol: Tolerance,
) -> list[tuple[float, float]]:
    """(factor, largest error / tolerance over the judged outputs) at every model step whose
    factor the reference also reports (load and driver analyses); [] otherwise."""
    ref = {round(float(s["factor"]), 9): s for s in ref_steps}
    out = []
    for s in steps:
        r = ref.get(round(float(s["factor"]), 9))
        if r is None:
            continue
        worst = 0.0
        for _, k, _, t in judged:
            comps = [f"{k}.ux", f"{k}.uy"] if k in pe["per_point"] else [k]
            d = [
                s["outputs"][c] - r["outputs"][c]
                for c in comps
                if s["outputs"].get(c) is not None and r["outputs"].get(c) is not None
            ]
            if k != "factor" and d:
                div = 1.0 if k in tol.absolute else pe["scale"].get(k, 1.0)
                worst = max(worst, math.hypot(*d) / div / t)
        out.append((float(s["factor"]), worst))
    return out if len(out) >= 2 else []


def reference_of(
    scene: Scene, sample: bool = True
) -> tuple[str | None, Solution | None, costing.Estimate | None, str]:
    """(name, solution, cost estimate, note) of the first converged reference for ``scene``."""
    names = [scene.reference_model] if scene.reference_model else []
    names += [n for n in errors.FALLBACK_REFERENCES if n not in names]
    notes = []
    for name in names:
        try:
            model = api.make_model(name, scene)
        except ValueError as exc:
            notes.append(str(exc))
            continue
        sol, est = measured(model, scene, name, scene.model_options(name), sample)
        if sol.ok and sol.steps:
            return name, sol, est, "; ".join(notes)
        notes.append(f"{name}: {sol.status} ({sol.message})")
    return None, None, None, "; ".join(notes)


def recommend(
    scene: Scene | str,
    tol: str | float | Tolerance | None = None,
    *,
    cost: Callable[[str, float], float] | None = None,
    brute_force: bool = False,
) -> Recommendation:
    """The cheapest model within ``tol`` on ``scene`` (see module docstring).

    Parameters
    ----------
    scene : Scene or catalog name / path.
    tol : ``"1%"``, ``1e-3``, ``"tip.uy=0.5%,tip.rot=abs:1e-3"`` or a Tolerance; None: the
        case's ``[[tolerances]]`` (1 % on every output when it names none).  Merged with the
        case's by ``reports.verdicts.tolerance.for_case``.
    cost : ``(model name, measured CPU s) -> cost`` to rank by (default: the CPU time
        estimate of ``reports.verdicts.cost``, cached); tests pass a deterministic cost (each model
        is then solved once and nothing is sampled or cached).
    brute_force : run every ladder member (no early exit), for verification.

    Raises
    ------
    ToleranceError
        Unreadable tolerance or an output name the scene does not report.
    """
    from reports.run.tables import case_meta

    t_start = time.perf_counter()
    if isinstance(scene, str):
        import cases

        scene = cases.load(scene)
    if scene.analysis.kind == "sweep":  # a sweep case is answered at its first grid point
        from cases.sweep import expand

        scene = expand(scene)[0]
    tol = for_case(scene.tolerances, tol)
    from cases.load import EXTRA_OUTPUTS

    known = set(scene.output_keys()) | set(EXTRA_OUTPUTS) | {o.name for o in scene.outputs}
    for key in tol.named():
        if key not in known:
            raise ToleranceError(
                f"--tol: {scene.name} has no output {key!r} (outputs: {', '.join(sorted(known))})"
            )
    sample = cost is None
    cost = cost or (lambda name, cpu: cpu)
    ref_name, ref_sol, ref_est, ref_note = reference_of(scene, sample)
    if ref_sol is None:
        reason = f"no reference path could be computed ({ref_note})"
        return Recommendation(scene.name, tol, None, reason, None, None, [])
    meta = case_meta(scene)
    from reports.run import store

    ref_steps, _, _ = store.steps_json(ref_sol)
    est = ref_sol.extras.get("error_estimate")
    stick = errors.reference_yardstick(meta, ref_steps)
    unc = errors.estimate_scale(est, stick) if isinstance(est, Mapping) else 0
    n_exact = pick.unknowns(ref_name, scene) if ref_name in EXACT else None
    exact = exact_candidate(ref_name, ref_sol.status, ref_est.cpu_s, ref_est.noise_s, n_exact)
    cands, skipped = _walk(
        scene,
        ladders(scene, ref_name),
        ref_steps,
        meta,
        tol,
        cost,
        brute_force,
        unc or 0.0,
        sample,
        exact,
    )
    for c in cands:
        c.ratio_to_reference = c.cpu_s / ref_est.cpu_s if c.cpu_s and ref_est.cpu_s else None
    best, reason, decided_by = verdict(cands, tol, cost)
    if unc:
        reason += f"; the reference's own error estimate {pct(unc)} is added to every error"
    if ref_note:
        reason += f" (reference note: {ref_note})"
    rec = Recommendation(scene.name, tol, best, reason, ref_name, ref_est.cpu_s, cands, skipped)
    rec.decided_by = decided_by
    rec.elapsed_s = time.perf_counter() - t_start
    return rec


def exact_candidate(
    ref: str, status: str, cpu_s: float | None, noise_s: float, unknowns: int | None
) -> Candidate | None:
    """The reference as a candidate with error 0 where it is exact (``pick.EXACT``), else
    None."""
    if ref not in EXACT:
        return None
    why = "exact: rigid links and springs" if ref == "kinetostatic" else "exact: beam theory"
    c = Candidate(ref, status, why, worst_error=0.0, cpu_s=cpu_s, noise_s=noise_s)
    c.qualifies, c.ratio_to_reference, c.unknowns = True, 1.0, unknowns
    return c


def _walk(
    scene: Scene,
    ladder_list: list[list[str]],
    ref_steps: list[dict],
    meta: Mapping[str, Any],
    tol: Tolerance,
    cost: Callable[[str, float], float],
    brute_force: bool = False,
    uncertainty: float = 0.0,
    sample: bool = True,
    exact: Candidate | None = None,
) -> tuple[list[Candidate], list[str]]:
    """Run ladders cheapest-bound first (ties: fewer unknowns) with early exit once a bound
    cannot tie with the cheapest qualifying model (``pick.cannot_tie``); ``exact`` (the exact
    reference) starts as that model.  Returns (tried, never run)."""
    ladder_list = [list(lad) for lad in ladder_list]
    autos = auto_candidates(scene, ladder_list, tol)
    size = functools.cache(lambda name: _unknowns(name, scene))
    heap = [(0.0, size(lad[0]), i, 0) for i, lad in enumerate(ladder_list)]
    heapq.heapify(heap)
    tried: list[Candidate] = [exact] if exact else []
    best = as_option(exact, cost) if exact else None
    costs: dict[str, float | None] = {}  # measured cost of every model run (None: declined)
    while True:
        for name, needs in list(autos.items()):  # *-auto: bound = its first solves' costs
            if all(n in costs for n in needs):
                del autos[name]
                if all(costs[n] is not None for n in needs):
                    ladder_list.append([name])
                    bound = sum(costs[n] for n in needs)
                    heapq.heappush(heap, (bound, size(name), len(ladder_list) - 1, 0))
        if not heap:
            break
        bound, _, i, j = heapq.heappop(heap)
        if best is not None and pick.cannot_tie(bound, best) and not brute_force:
            heapq.heappush(heap, (bound, 0, i, j))
            break
        name = ladder_list[i][j]
        n = size(name)
        cand = Candidate(name, "failed", unknowns=None if math.isinf(n) else int(n))
        tried.append(cand)
        opts = _options(name, scene, tol)
        try:
            model = api.make_model(name, scene, opts)
        except ValueError as exc:
            cand.message = str(exc)
            continue
        why = model.applies_to(scene)
        if why:
            cand.status, cand.message = "not-applicable", str(why)
            costs[name] = None
            continue  # a larger N declines for the same reason
        sol, est = measured(model, scene, name, opts, sample)
        cand.status, cand.message = sol.status, sol.message
        if est is None:  # declined inside solve: no cost, no larger N
            costs[name] = None
            continue
        cand.cpu_s, cand.noise_s = est.cpu_s, est.noise_s
        if sol.steps:
            judge(cand, sol, ref_steps, meta, tol, uncertainty)
        costs[name] = cost(name, est.cpu_s)
        if cand.qualifies:
            option = as_option(cand, cost)
            best = option if best is None else min(best, option, key=pick.by_cost)
        elif j + 1 < len(ladder_list[i]):
            nxt = ladder_list[i][j + 1]
            heapq.heappush(heap, (costs[name], size(nxt), i, j + 1))
    skipped = [f"{ladder_list[i][j]}+" for _, _, i, j in sorted(heap)]
    return tried, skipped + sorted(autos)


def _unknowns(name: str, scene: Scene) -> float:
    """``pick.unknowns`` as a heap key (inf when not known)."""
    try:
        n = pick.unknowns(name, scene)
    except ValueError:  # options the model rejects: it fails when built, ranked last
        n = None
    return math.inf if n is None else n


def auto_candidates(
    scene: Scene, ladder_list: list[list[str]], tol: Tolerance | str | float
) -> dict[str, list[str]]:
    """``family-auto`` -> the ladder members it solves first (N0, 2 N0, 4 N0), for every
    parametrised family on the ladders with a registered ``-auto`` model.

    An auto model is run with its error target at the smallest tolerance (unless the case sets
    one) once those three are measured: its cost is at least theirs (it solves them), so that
    sum is its bound; when one of them qualified or declined first it cannot be cheaper (or
    declines too) and is never run.
    """
    out, tol = {}, parse_tolerance(tol)
    on_ladders = {m for lad in ladder_list for m in lad}
    for key in api.model_names():
        if not key.endswith("-auto") or f"{key[:-5]}-N" not in LADDER_N:
            continue
        try:
            model = api.make_model(key, scene, _options(key, scene, tol))
        except ValueError:
            continue
        start = int(getattr(model, "start", 1))
        needs = [f"{key[:-5]}-{start * k}" for k in (1, 2, 4)]
        if all(n in on_ladders for n in needs):
            out[key] = needs
    return out
