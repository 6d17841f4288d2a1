"""Errors of a model's path against the case's reference, and checks against published values.

Everything here works on the JSON-level pair records of ``reports.run.runner`` (steps are dicts
``{"factor", "outputs", "energy", ...}``; missing/non-finite numbers are ``None``), so errors
can be recomputed from a ``results.json`` alone.

Definitions (also printed in the report)
----------------------------------------
* **Path error** of output ``k``: the largest ``|model - reference|`` over the load factors
  both paths reached, on two yardsticks (``reports.verdicts.yardstick``): ``error_rel`` divides by
  the output's own excursion along the reference path (the default everywhere) and ``error_L``
  divides translations by the case's length scale L and leaves rotations in rad.  Factors are
  matched exactly when both paths report the same factors (load analyses), else the reference
  is interpolated linearly (flagged ``interpolated``).
* **Summary error** of a pair (``error_rel`` / ``error_L`` of the record, the y axis of the
  Pareto plots): the largest path error over the outputs a designer judges -- the case's
  ``[[tolerances]]`` when it names them, else every point's ``.ux``, ``.uy`` and ``.rot``.
  Without a reference path the largest relative error against the case's published
  references is used instead (``summary_basis = "references"``).
* **Reference check**: ``|v - value| / |value|`` (``abs_tolerance``: ``|v - value|``) at
  ``at_factor`` (None: the last step of a converged path) against the reference's tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from reports.verdicts import yardstick as Y
from reports.verdicts.yardstick import TRANSLATIONS

SUMMARY_QUANTITIES = ("ux", "uy", "rot")
FALLBACK_REFERENCES = ("fem-auto", "elastica", "kinetostatic")
# model -> the baseline it is timed against in the same run (speed ratio in the report)
SPEED_BASELINES: dict[str, str] = {"elastica": "elastica-bvp"}
_MATCH_RTOL = 1e-9


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def values(steps: Sequence[Mapping], key: str) -> np.ndarray:
    """One output (or ``factor`` / ``energy``) over JSON-level steps, shape (n,), NaN if absent."""
    if key in ("factor", "energy"):
        return np.array([_num(s.get(key)) for s in steps], dtype=float)
    return np.array([_num(s["outputs"].get(key)) for s in steps], dtype=float)


def _monotonic(a: np.ndarray) -> bool:
    return a.size >= 2 and bool(np.all(np.isfinite(a))) and bool(np.all(np.diff(a) > 0))


def _align(
    m_abs: np.ndarray, r_abs: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, bool]:
    """Pair model abscissae with the reference's.

    Returns (model indices, reference indices or None, interpolation abscissae or None,
    interpolated?).  Exact matches are used when at least two exist.
    """
    idx_m, idx_r, used = [], [], set()
    for i, a in enumerate(m_abs):
        if not math.isfinite(a):
            continue
        close = np.flatnonzero(np.abs(r_abs - a) <= _MATCH_RTOL * (1.0 + abs(a)))
        # each reference point pairs once: a model stuck at one abscissa value (a path that
        # does not move in the stop output) must not be compared with one reference point
        # over and over
        if close.size and int(close[0]) not in used:
            used.add(int(close[0]))
            idx_m.append(i)
            idx_r.append(int(close[0]))
    if len(idx_m) >= 2 or not _monotonic(r_abs):
        return np.array(idx_m, dtype=int), np.array(idx_r, dtype=int), None, False
    inside = np.flatnonzero((m_abs >= r_abs[0]) & (m_abs <= r_abs[-1]))
    return inside, None, m_abs[inside], True


def path_errors(
    model_steps: Sequence[Mapping],
    ref_steps: Sequence[Mapping],
    length: float,
    stop_output: str | None = None,
    meta: Mapping | None = None,
) -> dict[str, Any]:
    """Largest error of every common output along the path, on both yardsticks.

    Parameters
    ----------
    model_steps, ref_steps : JSON-level steps of the model and of the reference.
    length : the case's length scale L (case units).
    stop_output : the output a path analysis stops on (its abscissa when the load factor is
        not monotonic).
    meta : the case's meta (``reports.run.tables.case_meta``): its ``tolerances`` name the judged
        outputs and any floors.

    Returns
    -------
    dict with ``per_output`` (key -> ``error_rel``, the default yardstick, None if not
    comparable), ``per_output_L`` (key -> ``error_L``), ``per_output_abs`` (key -> largest
    ``|model - reference|``, case units), ``per_point`` (point -> its displacement-vector error
    over its excursion), ``scale`` (key -> the ``error_rel`` divisor, case units),
    ``floored`` (keys judged against a floor), ``summary`` / ``summary_L`` (largest judged
    error on each yardstick), ``judged`` (the keys the summary is over), ``yardstick``
    (``"error_rel"``), ``n_points``, ``abscissa``, ``interpolated``, ``coverage``, ``note``
    and ``per_output_at`` (key -> model load factor where that output's error is largest).
    """
    out: dict[str, Any] = {
        "yardstick": "error_rel",
        "per_output": {},
        "per_output_L": {},
        "per_output_abs": {},
        "per_point": {},
        "per_output_at": {},
        "scale": {},
        "floored": [],
        "judged": [],
        "summary": None,
        "summary_L": None,
        "n_points": 0,
        "abscissa": None,
        "interpolated": False,
        "coverage": None,
        "note": "",
    }
    if not model_steps or not ref_steps:
        out["note"] = "no steps to compare"
        return out
    abscissa = "factor"
    if not _monotonic(values(ref_steps, "factor")) and stop_output:
        so = values(ref_steps, stop_output)
        if _monotonic(so) or _monotonic(-so):
            abscissa = stop_output  # displacement-controlled / snap-back paths
    r_abs = values(ref_steps, abscissa)
    m_abs = values(model_steps, abscissa)
    # a decreasing abscissa (uy -> -80) is flipped so that interpolation sees it increasing
    sign = -1.0 if not _monotonic(r_abs) and _monotonic(-r_abs) else 1.0
    idx_m, idx_r, at, interp = _align(sign * m_abs, sign * r_abs)
    out["abscissa"], out["interpolated"] = abscissa, interp
    if idx_m.size == 0:
        out["note"] = f"no common {abscissa} values"
        return out
    last_ref = float(np.nanmax(np.abs(r_abs))) if np.any(np.isfinite(r_abs)) else 0.0
    reached = float(np.nanmax(np.abs(m_abs[idx_m])))
    out["coverage"] = reached / last_ref if last_ref > 0 else 1.0
    out["n_points"] = int(idx_m.size)
    keys = set(model_steps[0]["outputs"]) & set(ref_steps[0]["outputs"])
    if "energy" in {t["output"] for t in Y.judged_outputs(meta or {}) or ()}:
        keys.add("energy")  # judged only where a case names it (not an output of its own)
    if abscissa != "factor":
        keys = (keys - {abscissa}) | {"factor"}
    ref_all = Y.as_arrays(ref_steps, sorted(keys | {abscissa}))
    stick = Y.yardstick(ref_all, length, Y.case_floors(meta or {}))
    out["scale"] = dict(stick.scale)
    out["floored"] = sorted(stick.floored)
    diffs = {}
    for key in sorted(keys):
        ref = ref_all[key]
        mod = values(model_steps, key)[idx_m]
        if interp:
            order = np.argsort(sign * r_abs)
            refv = np.interp(at * sign, (sign * r_abs)[order], ref[order])
        else:
            refv = ref[idx_r]
        diff = diffs[key] = mod - refv
        if not np.any(np.isfinite(diff)):
            for k in ("per_output", "per_output_L", "per_output_abs"):
                out[k][key] = None
            continue
        worst = float(np.nanmax(np.abs(diff)))
        out["per_output_abs"][key] = worst
        out["per_output"][key] = worst / stick.rel(key)
        out["per_output_L"][key] = worst / Y.scale_L(key, ref, length)
        out["per_output_at"][key] = _num(
            model_steps[idx_m[int(np.nanargmax(np.abs(diff)))]]["factor"]
        )
    for p in sorted({Y.point(k) for k in keys} - {None}):
        du, dv = diffs.get(f"{p}.ux"), diffs.get(f"{p}.uy")
        if du is not None and dv is not None and np.any(np.isfinite(du + dv)):
            out["per_point"][p] = float(np.nanmax(np.hypot(du, dv))) / stick.rel(p)
    _summaries(out, meta, abscissa, last_ref, reached, stick)
    return out


def _summaries(
    out: dict[str, Any],
    meta: Mapping | None,
    abscissa: str,
    last_ref: float,
    reached: float,
    stick: Y.Yardstick,
) -> None:
    """Fill ``summary``, ``summary_L`` and ``judged``: the largest error over the case's
    judged outputs (its ``[[tolerances]]``) or, by default, over every point's ``.ux .uy
    .rot``; a displacement-traced path that stops short adds the part it never reached."""
    named = Y.judged_outputs(meta or {})
    if named is not None:
        judged = [t["output"] for t in named]
    else:
        judged = [k for k in out["per_output"] if Y.quantity(k) in SUMMARY_QUANTITIES]
    rel, per_L = [], []
    for key in judged:
        if key in out["per_point"]:  # a point: its displacement-vector error
            rel.append(out["per_point"][key])
            per_L.append(out["per_point"][key] * stick.rel(key) / stick.length)
        elif out["per_output"].get(key) is not None:
            rel.append(out["per_output"][key])
            per_L.append(out["per_output_L"][key])
    if abscissa != "factor" and out["coverage"] < 1.0 - 1e-6:
        # traced against a displacement: the part of the reference's range the model never
        # reached is an error of at least that displacement (a model that cannot move there
        # is not accurate there)
        short = last_ref - reached
        for name, div in (("per_output", stick.rel(abscissa)), ("per_output_L", stick.length)):
            out[name][abscissa] = short / div
        out["note"] = f"the model reaches {out['coverage']:.0%} of the reference's {abscissa}"
        rel.append(short / stick.rel(abscissa))
        per_L.append(short / stick.length)
        judged.append(abscissa)
    if not rel and out["per_output"]:
        rel = [v for v in out["per_output"].values() if v is not None]
        per_L = [v for v in out["per_output_L"].values() if v is not None]
    out["judged"] = judged
    out["summary"] = max(rel) if rel else None
    out["summary_L"] = max(per_L) if per_L else None


def abscissa_output(meta: Mapping) -> str | None:
    """The output a path is aligned on when its load factor is not monotonic: the
    ``stop_output`` of a path analysis, or for a ``distance`` analysis (the load factor is the
    answer, the driver the abscissa) the named output of the driven node along the driver."""
    a = meta.get("analysis") or {}
    if a.get("stop_output"):
        return a["stop_output"]
    drv = a.get("driver") or {}
    if a.get("kind") == "distance" and drv.get("kind") == "displacement":
        for o in meta.get("outputs") or ():
            if o.get("node") == drv.get("node") and drv.get("direction") in ("x", "y"):
                return f"{o['name']}.u{drv['direction']}"
    return None


def _value_at(steps: Sequence[Mapping], key: str, at: float | None, complete: bool):
    """(value, note) of ``key`` at factor ``at`` (None: end of a complete path)."""
    if not steps:
        return None, "no steps"
    if key in ("factor.max", "factor.min"):
        # an extremum along the path (a limit load): the path must pass it, not end on it
        f = values(steps, "factor")
        i = int(np.nanargmax(f) if key == "factor.max" else np.nanargmin(f))
        if i == len(f) - 1 and not complete:
            return None, "path ended before the extremum"
        return float(f[i]), ("" if 0 < i < len(f) - 1 else "extremum at the path end")
    if at is None:
        if not complete:
            return None, "path incomplete"
        v = _num(steps[-1].get(key)) if key == "factor" else _num(steps[-1]["outputs"].get(key))
        return (v, "") if math.isfinite(v) else (None, "not reported")
    f = values(steps, "factor")
    v = values(steps, key)
    hit = np.flatnonzero(np.abs(f - at) <= _MATCH_RTOL * (1.0 + abs(at)))
    if hit.size:
        val = float(v[hit[0]])
        return (val, "") if math.isfinite(val) else (None, "not reported")
    if f.size >= 2 and f[-1] < f[0]:
        # a driver moving towards negative values (energy analyses): interpolate reversed
        f, v = f[::-1], v[::-1]
    if _monotonic(f) and f[0] <= at <= f[-1]:
        val = float(np.interp(at, f, v))
        return (val, "interpolated") if math.isfinite(val) else (None, "not reported")
    return None, f"factor {at:g} not reached"


def reference_checks(
    references: Sequence[Mapping], steps: Sequence[Mapping], complete: bool
) -> list[dict[str, Any]]:
    """Pass/fail of one model against every published/closed-form reference of its case.

    Each entry: the reference fields plus ``model_value``, ``error`` (relative unless
    ``abs_tolerance``), ``passed`` (bool, None when the value is missing) and ``note``.
    """
    checks = []
    for ref in references:
        val, note = _value_at(steps, ref["output"], ref.get("at_factor"), complete)
        entry = {**ref, "model_value": val, "error": None, "passed": None, "note": note}
        if val is not None:
            target = float(ref["value"])
            diff = abs(val - target)
            err = diff if ref.get("abs_tolerance") or target == 0 else diff / abs(target)
            entry["error"] = err
            entry["passed"] = bool(err <= float(ref["tolerance"]))
        checks.append(entry)
    return checks


def estimate_scale(
    estimate: Mapping[str, Any], stick: Y.Yardstick, yardstick: str = "error_rel"
) -> float | None:
    """Largest error estimate of a reference on one yardstick (as its path errors).

    ``estimate`` maps output key -> float (last step) or list of floats (one per step);
    ``stick`` is the reference path's yardstick.
    """
    worst = []
    for key, est in estimate.items():
        arr = np.atleast_1d(np.asarray([_num(e) for e in np.atleast_1d(est)], dtype=float))
        if not np.any(np.isfinite(arr)) or Y.quantity(key) not in SUMMARY_QUANTITIES:
            continue
        if yardstick == "error_rel":
            div = stick.rel(key)
        else:
            div = stick.length if Y.quantity(key) in TRANSLATIONS else 1.0
        worst.append(float(np.nanmax(np.abs(arr))) / div)
    return max(worst) if worst else None


def reference_yardstick(meta: Mapping, ref_steps: Sequence[Mapping]) -> Y.Yardstick:
    """The yardstick of a case's reference path (every output it reports)."""
    keys = sorted(ref_steps[0]["outputs"]) if ref_steps else []
    length = float(meta.get("length_scale") or 1.0)
    return Y.yardstick(Y.as_arrays(ref_steps, keys), length, Y.case_floors(meta))


def choose_reference(meta: Mapping, records: Mapping[str, Mapping]) -> tuple[str | None, str]:
    """The converged reference path of a case and a note when it is a fallback."""
    wanted = meta.get("reference_model")
    candidates = ([wanted] if wanted else []) + [c for c in FALLBACK_REFERENCES if c != wanted]
    for name in candidates:
        rec = records.get(name)
        # a reference that ends on an unstable equilibrium says so (extras) and is not used
        unusable = ((rec or {}).get("extras") or {}).get("reference_usable") is False
        if rec is not None and rec["status"] == "converged" and rec["steps"] and not unusable:
            if name == wanted:
                return name, ""
            why = "not run"
            if wanted in records:
                wr = records[wanted]
                bad = (wr.get("extras") or {}).get("reference_usable") is False
                why = f"{'unusable, ' if bad else ''}{wr['status']}: {wr['message']}"
            return (
                name,
                f"reference {wanted!r} unavailable ({why}); using {name!r}" if wanted else "",
            )
    return None, "no converged reference path; errors only against published references"


def attach_errors(meta: Mapping, records: Sequence[dict]) -> dict[str, Any]:
    """Fill ``errors``, ``refchecks``, ``error_rel``, ``error_L`` and speed ratios of one
    case's records.

    Returns the case-level reference info (``reference``, ``note``, ``uncertainty`` and
    ``uncertainty_L``: the reference's own error estimate on each yardstick, ``yardstick``).
    """
    by_model = {r["model"]: r for r in records}
    ref_name, note = choose_reference(meta, by_model)
    ref = by_model.get(ref_name) if ref_name else None
    length = float(meta.get("length_scale") or 1.0)
    uncertainty = uncertainty_L = None
    extras = (ref or {}).get("extras") or {}
    if ref is not None and ref["steps"]:
        stick = reference_yardstick(meta, ref["steps"])
        for est_key in ("error_estimate_steps", "error_estimate"):  # fem-auto: per step, last
            if isinstance(extras.get(est_key), Mapping):
                uncertainty = estimate_scale(extras[est_key], stick)
                uncertainty_L = estimate_scale(extras[est_key], stick, "error_L")
                break
    t_ref = cost_s(ref)
    for rec in records:
        rec["is_reference"] = rec["model"] == ref_name
        rec["refchecks"] = reference_checks(
            meta.get("references", ()), rec["steps"], rec["status"] == "converged"
        )
        rec["errors"] = None
        rec["error_rel"], rec["error_L"], rec["summary_basis"] = None, None, None
        if ref is not None and rec["steps"] and not rec["is_reference"]:
            # a model whose earlier steps are not equilibria (the thesis's Part 1 relaxation)
            # says so: only its last step is judged
            last = ((rec.get("extras") or {}).get("judged_steps")) == "last"
            steps = rec["steps"][-1:] if last else rec["steps"]
            pe = path_errors(steps, ref["steps"], length, abscissa_output(meta), meta)
            rec["errors"] = pe
            if pe["summary"] is not None and pe["n_points"] >= (1 if last else 2):
                rec["error_rel"], rec["error_L"] = pe["summary"], pe["summary_L"]
                rec["summary_basis"] = "path"
        if rec["error_rel"] is None and not rec["is_reference"]:
            errs = [c["error"] for c in rec["refchecks"] if c["error"] is not None]
            if errs:  # published values: relative to the value itself, on both yardsticks
                rec["error_rel"] = rec["error_L"] = max(errs)
                rec["summary_basis"] = "references"
        t = cost_s(rec)
        rec["speedup_vs_reference"] = t_ref / t if t_ref and t else None
    return {
        "reference": ref_name,
        "note": note,
        "uncertainty": uncertainty,
        "uncertainty_L": uncertainty_L,
        "yardstick": Y.describe("error_rel"),
    }


def cost_s(rec: Mapping | None) -> float | None:
    """A pair's cost for ratios: median CPU time of its solve (wall time in older records)."""
    t = (rec or {}).get("timing") or {}
    return t.get("cpu_median_s", t.get("median_s"))


def speed_ratios(records: Sequence[dict]) -> list[dict]:
    """Model vs its speed baseline in the same run (``SPEED_BASELINES``), per case."""
    by = {(r["case"], r["model"]): r for r in records}
    rows = []
    for (case, model), rec in sorted(by.items()):
        base = by.get((case, SPEED_BASELINES.get(model, "")))
        if base is None or not rec.get("timing") or not base.get("timing"):
            continue
        if rec["status"] != "converged" or base["status"] != "converged":
            continue
        t, tb = cost_s(rec), cost_s(base)
        rows.append(
            {
                "case": case,
                "model": model,
                "baseline": base["model"],
                "model_s": t,
                "baseline_s": tb,
                "ratio": tb / t if t and tb else None,
            }
        )
    return rows
