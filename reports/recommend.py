"""``flexbench recommend``: the cheapest model whose error stays within a user's tolerance.

``recommend(scene, tol)`` solves the case's reference once, then walks *ladders* of candidate
models (a parametrised family is one ladder of rising N: ``linear-1, linear-2, linear-4, ...``;
a fixed model such as ``prb-3r`` is a ladder of one), cheapest first:

* the next model run is always the one with the lowest *cost bound* -- the measured CPU time of
  the member before it on its ladder (0 for a ladder's first member, ties broken by the number
  of unknowns the model has a priori);
* a ladder ends at its first qualifying member (a larger N costs more) or when a model
  declines the scene;
* once a model qualifies at cost c, every ladder whose bound is at least c is dropped: none of
  its members can be cheaper (early exit);
* a self-refining ``family-auto`` (target: the smallest tolerance) joins once its family's
  N0, 2 N0, 4 N0 members are measured, with their summed cost as its bound
  (``auto_candidates``).

*Qualifies* means: the model converged over the whole path (it reaches the reference's last
load factor) and, for every judged output, the largest error along the path (the path error of
``reports.errors``: translations divided by the case's length L, rotations in rad, path-analysis
load factors divided by the largest reference factor) is within that output's tolerance.
Judged outputs: displacements and rotations of the case's named outputs (``.ux``, ``.uy``,
``.rot``), the load factor of path analyses and any non-node output, unless per-output
tolerances name the outputs explicitly.

Cost is measured on this scene: the median ``time.process_time`` of repeated solves (BLAS
pinned to one thread).  Costs within ``TIE`` of the cheapest are a tie (the resolution of a
timing on a shared machine), broken by the a-priori number of unknowns.  The reference model
itself (the elastica for single beams, ``fem-auto`` otherwise) is not a candidate: it is what
the others are measured against.
"""

from __future__ import annotations

import contextlib
import gc
import heapq
import math
import re
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from cases.schema import Scene
from reduced_models.base import Solution
from reports import api, errors
from reports.tolerance import Tolerance, ToleranceError, parse_tolerance, pct

# member N of each parametrised ladder (the FE starts at 2 elements per member)
LADDER_N: dict[str, tuple[int, ...]] = {
    "linear-N": (1, 2, 4, 8, 16, 32, 64),
    "cbcm-N": (2, 4, 8, 16, 32, 64),
    "prb-fsm-N": (2, 4, 8, 16, 32, 64),
    "fem-N": (2, 4, 8, 16, 32, 64, 128),
}
DEFAULT_N = (1, 2, 4, 8, 16, 32)  # a parametrised family registered by another package
# never candidates: baselines and the dynamic reference (``*-auto`` join through
# ``auto_candidates``, not as ladders of their own)
EXCLUDED = ("elastica-bvp", "replay")
# a-priori unknowns of fixed models (tie-break only; measured cost decides)
RANK = {"prb-short": 1, "prb-1r": 1, "bcm": 3, "prb-2r": 2, "prb-3r": 3, "prb-2rpr": 3}
TIE = 0.10
JUDGED = ("ux", "uy", "rot")


@dataclass
class Candidate:
    """One model tried: status, worst judged error (relative to its tolerance) and cost."""

    model: str
    status: str
    message: str = ""
    worst_error: float | None = None
    worst_output: str | None = None
    at_factor: float | None = None
    tolerance: float | None = None
    cpu_s: float | None = None
    ratio_to_reference: float | None = None
    qualifies: bool = False
    warning: str = ""
    rank: int = 0
    errors: dict[str, float] = field(default_factory=dict)
    profile: list[tuple[float, float]] = field(default_factory=list)  # (factor, error / tol)

    def as_json(self) -> dict[str, Any]:
        """The contract's candidate object (plus ``worst_output``, ``qualifies``, ...)."""
        out = {
            "model": self.model,
            "status": self.status,
            "worst_error": _finite(self.worst_error),
            "at_factor": _finite(self.at_factor),
            "cpu_s": _finite(self.cpu_s),
            "ratio_to_reference": _finite(self.ratio_to_reference),
        }
        out.update(
            worst_output=self.worst_output,
            tolerance=_finite(self.tolerance),
            qualifies=self.qualifies,
            message=self.message,
            validity_warning=self.warning or None,
        )
        return out


def _finite(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


@dataclass
class Recommendation:
    """What ``recommend`` found (``as_json`` is the CLI contract object)."""

    case: str
    tolerance: Tolerance
    recommended: str | None
    reason: str
    reference: str | None
    reference_cpu_s: float | None
    candidates: list[Candidate]
    skipped: list[str] = field(default_factory=list)
    elapsed_s: float = 0.0

    def as_json(self) -> dict[str, Any]:
        """``{"case", "tolerance", "recommended", "reason", "candidates": [...]}`` + extras."""
        return {
            "case": self.case,
            "tolerance": self.tolerance.as_json(),
            "recommended": self.recommended,
            "reason": self.reason,
            "candidates": [c.as_json() for c in self.candidates],
            "reference": self.reference,
            "reference_cpu_s": _finite(self.reference_cpu_s),
            "not_run": self.skipped,
        }


# -- cost --------------------------------------------------------------------------------------
def _one_thread() -> contextlib.AbstractContextManager:
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(1)


def timed(
    run: Callable[[], Solution], min_total: float = 0.03, max_runs: int = 5
) -> tuple[Solution, float]:
    """(first Solution, median CPU seconds of the repeats): at least 3 runs unless the
    first took longer than ``10 * min_total`` or ``max_runs`` is 0 (then its own time)."""
    t0 = time.process_time()
    sol = run()
    first = time.process_time() - t0
    if first > 10 * min_total or max_runs == 0:
        return sol, first
    times, enabled = [], gc.isenabled()
    gc.disable()  # as timeit: a collection belongs to no particular solve
    try:
        while len(times) < max_runs and (len(times) < 3 or sum(times) < min_total):
            t0 = time.process_time()
            run()
            times.append(time.process_time() - t0)
    finally:
        if enabled:
            gc.enable()
    return sol, statistics.median(times)


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
        vals = [t for t in (tol.default, *tol.per_output.values()) if t is not None]
        opts.setdefault("target", min(vals))
    return opts


def _rank(name: str) -> int:
    m = re.fullmatch(r"(.+)-(\d+)", name)
    if name in RANK:
        return RANK[name]
    return 3 * int(m[2]) if m else 10


def judge(
    cand: Candidate,
    sol: Solution,
    ref_steps: list[dict],
    meta: Mapping[str, Any],
    tol: Tolerance,
    uncertainty: float = 0.0,
) -> None:
    """Fill ``cand``'s errors and verdict from its solution against the reference path.

    ``uncertainty`` (normalised like the errors) is the reference's own error estimate: a
    model qualifies only if its measured error plus that stays within the tolerance.
    """
    from reports import store  # lazy: ``import reports`` (the CLI) does not need sqlite

    steps, _, _ = store.steps_json(sol)
    stop = errors.abscissa_output(meta)
    pe = errors.path_errors(steps, ref_steps, meta["length_scale"], stop)
    cand.errors = {k: v for k, v in pe["per_output"].items() if v is not None}
    judged = []
    for key, err in pe["per_output"].items():
        quantity = key.rsplit(".", 1)[-1]
        node_key = quantity in errors.TRANSLATIONS or quantity == "rot"
        if key not in tol.per_output and node_key and quantity not in JUDGED:
            continue  # .x/.y repeat .ux/.uy
        t = tol.of(key)
        if t is None or (key == "factor" and pe["abscissa"] == "factor"):
            continue
        e = math.inf if err is None else err
        judged.append((e / t, key, e, t))
    if sol.extras.get("validity_warning"):
        cand.warning = str(sol.extras.get("validity_message", "outside its validity range"))
    if not judged or pe["n_points"] < 2:
        cand.message = "path cannot be compared with the reference's: " + (
            pe["note"] or f"{pe['n_points']} common {pe['abscissa']} value(s)"
        )
        return
    _, key, e, t = max(judged)
    cand.profile = _profile(steps, ref_steps, [(k, tk) for _, k, _, tk in judged], meta)
    cand.worst_output, cand.worst_error, cand.tolerance = key, e, t
    cand.at_factor = pe["per_output_at"].get(key)
    coverage = pe["coverage"] or 0.0
    if sol.status != "converged":
        cand.message = sol.message
    elif coverage < 1.0 - 1e-6:
        cand.message = f"path covers {coverage:.0%} of the reference's"
    else:
        cand.qualifies = all(e + uncertainty <= t for _, _, e, t in judged)


def _profile(
    steps: list[dict], ref_steps: list[dict], keys: list[tuple[str, float]], meta: Mapping
) -> list[tuple[float, float]]:
    """(factor, largest error / tolerance over the judged outputs) at every model step whose
    factor the reference also reports (load and driver analyses); [] otherwise."""
    ref = {round(float(s["factor"]), 9): s for s in ref_steps}
    length = float(meta["length_scale"])
    scale = {k: errors._scale(k, errors.values(ref_steps, k), length) for k, _ in keys}
    out = []
    for s in steps:
        r = ref.get(round(float(s["factor"]), 9))
        if r is None:
            continue
        worst = 0.0
        for k, t in keys:
            a, b = s["outputs"].get(k), r["outputs"].get(k)
            if k != "factor" and a is not None and b is not None:
                worst = max(worst, abs(a - b) / scale[k] / t)
        out.append((float(s["factor"]), worst))
    return out if len(out) >= 2 else []


def reference_of(scene: Scene) -> tuple[str | None, Solution | None, float | None, str]:
    """(name, solution, CPU s, note) of the first converged reference for ``scene``."""
    names = [scene.reference_model] if scene.reference_model else []
    names += [n for n in errors.FALLBACK_REFERENCES if n not in names]
    notes = []
    for name in names:
        try:
            model = api.make_model(name, scene)
        except ValueError as exc:
            notes.append(str(exc))
            continue
        sol, cpu = timed(lambda m=model: api.run_model(m, scene, post=False), max_runs=3)
        if sol.ok and sol.steps:
            return name, sol, cpu, "; ".join(notes)
        notes.append(f"{name}: {sol.status} ({sol.message})")
    return None, None, None, "; ".join(notes)


def recommend(
    scene: Scene | str,
    tol: str | float | Tolerance = 0.01,
    *,
    cost: Callable[[str, float], float] | None = None,
    brute_force: bool = False,
) -> Recommendation:
    """The cheapest model within ``tol`` on ``scene`` (see module docstring).

    Parameters
    ----------
    scene : Scene or catalog name / path.
    tol : ``"1%"``, ``1e-3``, ``"tip.uy=0.5%,tip.rot=1e-3"`` or a Tolerance.
    cost : ``(model name, measured CPU s) -> cost`` to rank by (default: the CPU time, the
        median of repeats); tests pass a deterministic cost (each model is then solved once).
    brute_force : run every ladder member (no early exit), for verification.

    Raises
    ------
    ToleranceError
        Unreadable tolerance or an output name the scene does not report.
    """
    from reports.tables import case_meta

    t_start = time.perf_counter()
    if isinstance(scene, str):
        import cases

        scene = cases.load(scene)
    if scene.analysis.kind == "sweep":  # a sweep case is answered at its first grid point
        from cases.sweep import expand

        scene = expand(scene)[0]
    tol = parse_tolerance(tol)
    known = set(scene.output_keys()) | {"factor"}
    for key in tol.per_output:
        if key not in known:
            raise ToleranceError(
                f"--tol: {scene.name} has no output {key!r} (outputs: {', '.join(sorted(known))})"
            )
    repeats = 5 if cost is None else 0
    cost = cost or (lambda name, cpu: cpu)
    with _one_thread():
        ref_name, ref_sol, ref_cpu, ref_note = reference_of(scene)
        if ref_sol is None:
            reason = f"no reference path could be computed ({ref_note})"
            return Recommendation(scene.name, tol, None, reason, None, None, [])
        meta = case_meta(scene)
        from reports import store

        ref_steps, _, _ = store.steps_json(ref_sol)
        est = ref_sol.extras.get("error_estimate")
        unc = errors.estimate_scale(est, meta["length_scale"]) if isinstance(est, Mapping) else 0
        lad = ladders(scene, ref_name)
        cands, skipped = _walk(
            scene, lad, ref_steps, meta, tol, cost, brute_force, unc or 0.0, repeats
        )
    for c in cands:
        c.ratio_to_reference = c.cpu_s / ref_cpu if c.cpu_s and ref_cpu else None
    best, reason = _verdict(cands, tol, cost)
    rigid_only = not any(m.kind == "flexible" for m in scene.members)
    best_cpu = next((c.cpu_s for c in cands if c.model == best), None)
    if (
        ref_name == "kinetostatic"
        and rigid_only
        and (best is None or best_cpu is None or cost(ref_name, ref_cpu) <= cost(best, best_cpu))
    ):
        # no compliant member: rigid-body kinematics with springs is exact, not an approximation,
        # so it is the pick unless another exact-within-tolerance model is measured cheaper
        best = ref_name
        reason = (
            "no compliant member: kinetostatic (rigid links, springs) is exact here and no "
            "measured model is cheaper; runner-up: " + reason
        )
        exact = Candidate(ref_name, ref_sol.status, "exact for rigid links and springs")
        exact.worst_error, exact.cpu_s, exact.ratio_to_reference = 0.0, ref_cpu, 1.0
        exact.qualifies = True
        cands.insert(0, exact)
    if unc:
        reason += f"; the reference's own error estimate {pct(unc)} is added to every error"
    if ref_note:
        reason += f" (reference note: {ref_note})"
    rec = Recommendation(scene.name, tol, best, reason, ref_name, ref_cpu, cands, skipped)
    rec.elapsed_s = time.perf_counter() - t_start
    return rec


def _walk(
    scene: Scene,
    ladder_list: list[list[str]],
    ref_steps: list[dict],
    meta: Mapping[str, Any],
    tol: Tolerance,
    cost: Callable[[str, float], float],
    brute_force: bool = False,
    uncertainty: float = 0.0,
    repeats: int = 5,
) -> tuple[list[Candidate], list[str]]:
    """Run ladders cheapest-bound first with early exit; returns (tried, never run)."""
    ladder_list = [list(lad) for lad in ladder_list]
    autos = auto_candidates(scene, ladder_list, tol)
    heap = [(0.0, _rank(lad[0]), i, 0) for i, lad in enumerate(ladder_list)]
    heapq.heapify(heap)
    best = math.inf
    tried: list[Candidate] = []
    costs: dict[str, float | None] = {}  # measured cost of every model run (None: declined)
    while True:
        for name, needs in list(autos.items()):  # *-auto: bound = its first solves' costs
            if all(n in costs for n in needs):
                del autos[name]
                if all(costs[n] is not None for n in needs):
                    ladder_list.append([name])
                    bound = sum(costs[n] for n in needs)
                    heapq.heappush(heap, (bound, _rank(name), len(ladder_list) - 1, 0))
        if not heap:
            break
        bound, _, i, j = heapq.heappop(heap)
        if bound >= best * (1.0 + TIE) and not brute_force:
            heapq.heappush(heap, (bound, 0, i, j))
            break
        name = ladder_list[i][j]
        cand = Candidate(name, "failed", rank=_rank(name))
        tried.append(cand)
        try:
            model = api.make_model(name, scene, _options(name, scene, tol))
        except ValueError as exc:
            cand.message = str(exc)
            continue
        why = model.applies_to(scene)
        if why:
            cand.status, cand.message = "not-applicable", str(why)
            costs[name] = None
            continue  # a larger N declines for the same reason
        sol, cpu = timed(lambda m=model: api.run_model(m, scene, post=False), max_runs=repeats)
        cand.status, cand.message = sol.status, sol.message
        if sol.status == "not-applicable":  # declined inside solve: no cost, no larger N
            costs[name] = None
            continue
        cand.cpu_s = cpu
        if sol.steps:
            judge(cand, sol, ref_steps, meta, tol, uncertainty)
        c = costs[name] = cost(name, cpu)
        if cand.qualifies:
            best = min(best, c)
        elif j + 1 < len(ladder_list[i]):
            heapq.heappush(heap, (c, _rank(ladder_list[i][j + 1]), i, j + 1))
    skipped = [f"{ladder_list[i][j]}+" for _, _, i, j in sorted(heap)]
    return tried, skipped + sorted(autos)


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


def _verdict(
    cands: list[Candidate], tol: Tolerance, cost: Callable[[str, float], float]
) -> tuple[str | None, str]:
    """(recommended model or None, one-paragraph reason)."""
    ok = [c for c in cands if c.qualifies]
    ran = [c for c in cands if c.status != "not-applicable"]
    reduced = [c for c in ran if not c.model.startswith("fem-")]
    if not ran:
        return None, (
            f"every candidate model declines this scene ({_declines(cands)}); "
            "no reduced model can represent it"
        )
    if not ok:
        worst = min(ran, key=_closeness)
        return None, f"no model qualifies at {tol.text()}; closest: {_miss(worst)}"
    low = min(cost(c.model, c.cpu_s) for c in ok)
    tied = [c for c in ok if cost(c.model, c.cpu_s) <= low * (1.0 + TIE)]
    pick = min(tied, key=lambda c: (c.rank, cost(c.model, c.cpu_s)))
    reason = (
        f"{pick.model} is the cheapest model within {tol.text()}: worst error "
        f"{pct(pick.worst_error)} ({pick.worst_output} at factor {pick.at_factor:.3g}), "
        f"{pick.cpu_s * 1e3:.3g} ms CPU"
    )
    if len(tied) > 1:
        others = ", ".join(c.model for c in tied if c is not pick)
        reason += f" (tied within {TIE:.0%} with {others}; fewer unknowns wins)"
    if pick.model.startswith("fem-"):
        miss = [c for c in reduced if not c.qualifies]
        dearer = [c for c in reduced if c.qualifies]
        if dearer:  # a reduced model is within tolerance but measured dearer than the FE
            c = min(dearer, key=lambda c: cost(c.model, c.cpu_s))
            reason += (
                f"; the cheapest reduced model within {tol.text()}, {c.model} "
                f"({pct(c.worst_error)}), costs more here ({c.cpu_s * 1e3:.3g} ms CPU)"
            )
        elif miss:
            reason += f"; no reduced model qualifies: closest {_miss(min(miss, key=_closeness))}"
        elif not reduced:
            reason += f"; every reduced model declines this scene ({_declines(cands)})"
    return pick.model, reason


def _closeness(c: Candidate) -> float:
    if c.worst_error is None or c.tolerance is None:
        return math.inf
    return c.worst_error / c.tolerance + (0.0 if c.status == "converged" else 1e6)


def _miss(c: Candidate) -> str:
    if c.worst_error is None:
        return f"{c.model} ({c.status}: {c.message})"
    why = f"{c.worst_output} error {pct(c.worst_error)} at factor {c.at_factor:.3g}"
    if c.status != "converged":
        why += f", {c.status}: {c.message}"
    elif c.worst_error <= (c.tolerance or 0.0):
        why += f", {c.message}"
    return f"{c.model} ({why} > {pct(c.tolerance)})"


def _declines(cands: list[Candidate]) -> str:
    reasons: dict[str, list[str]] = {}
    for c in (c for c in cands if c.status == "not-applicable"):
        reasons.setdefault(c.message, []).append(c.model.rsplit("-", 1)[0] + "*")
    return "; ".join(f"{', '.join(dict.fromkeys(m))}: {r}" for r, m in reasons.items())


def format_text(rec: Recommendation) -> str:
    """The evidence table and verdict printed by ``flexbench recommend``."""
    lines = [
        f"{rec.case}: tolerance {rec.tolerance.text()} (path error: translations / L, "
        f"rotations in rad); reference {rec.reference} "
        f"({(rec.reference_cpu_s or math.nan) * 1e3:.3g} ms CPU)",
        f"recommended: {rec.recommended or 'none'}",
        f"  {rec.reason}",
        "",
        f"{'model':<14} {'status':<15} {'worst error':>11} {'output':<12} {'at factor':>9} "
        f"{'CPU ms':>8} {'x ref':>7}  verdict",
    ]
    order = sorted(rec.candidates, key=lambda c: (not c.qualifies, c.cpu_s or math.inf))
    for c in order:
        err = "-" if c.worst_error is None else pct(c.worst_error)
        at = "-" if c.at_factor is None else f"{c.at_factor:.3g}"
        ms = "-" if c.cpu_s is None else f"{c.cpu_s * 1e3:.3g}"
        ratio = "-" if c.ratio_to_reference is None else f"{c.ratio_to_reference:.3g}"
        verdict = "within" if c.qualifies else ("declines" if c.status == "not-applicable" else "")
        if c.model == rec.recommended:
            verdict = "RECOMMENDED"
        elif not verdict:
            verdict = "exceeds" if c.status == "converged" else c.status
        if c.warning:
            verdict += " (validity warning)"
        lines.append(
            f"{c.model:<14} {c.status:<15} {err:>11} {c.worst_output or '-':<12} {at:>9} "
            f"{ms:>8} {ratio:>7}  {verdict}"
        )
    if rec.skipped:
        lines.append(f"not run (cannot be cheaper): {', '.join(rec.skipped)}")
    lines.append(f"({rec.elapsed_s:.2f} s)")
    return "\n".join(lines)
