"""Errors of a model's path against the case's reference, and checks against published values.

Everything here works on the JSON-level pair records of ``reports.runner`` (steps are dicts
``{"factor", "outputs", "energy", ...}``; missing/non-finite numbers are ``None``), so errors
can be recomputed from a ``results.json`` alone.

Definitions (also printed in the report)
----------------------------------------
* **Path error** of output ``k``: the largest ``|model - reference|`` over the load factors
  both paths reached.  Translations (``.x .y .ux .uy``) are divided by the case's length scale
  ``L`` (the longest member), rotations (``.rot``, rad) are raw, ``factor`` (path analyses) is
  divided by the largest reference factor, anything else by its largest reference magnitude.
  Factors are matched exactly when both paths report the same factors (load analyses), else
  the reference is interpolated linearly (flagged ``interpolated``).
* **Summary error** of a pair (the y axis of the Pareto plots): the largest path error over
  the node displacement and rotation outputs (``.ux``, ``.uy``, ``.rot``) -- a dimensionless
  "worst deviation over the whole path, as a fraction of L (or in rad)".  Without a reference
  path the largest relative error against the case's published references is used instead
  (``summary_basis = "references"``).
* **Reference check**: ``|v - value| / |value|`` (``abs_tolerance``: ``|v - value|``) at
  ``at_factor`` (None: the last step of a converged path) against the reference's tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

TRANSLATIONS = ("x", "y", "ux", "uy")
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


def _scale(key: str, ref: np.ndarray, length: float) -> float:
    """What an error of output ``key`` is divided by (see module docstring)."""
    quantity = key.rsplit(".", 1)[-1]
    if key != "factor" and quantity in TRANSLATIONS:
        return length
    if quantity == "rot":
        return 1.0
    big = float(np.nanmax(np.abs(ref))) if np.any(np.isfinite(ref)) else 0.0
    return big if big > 0 else 1.0


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
) -> dict[str, Any]:
    """Largest error of every common output along the path (see module docstring).

    Returns
    -------
    dict with ``per_output`` (key -> error, None if not comparable), ``summary`` (float or
    None), ``n_points``, ``abscissa`` (``factor`` or the stop output), ``interpolated``,
    ``coverage`` (fraction of the reference's final abscissa the model reached), ``note`` and
    ``per_output_at`` (key -> model load factor where that output's error is largest).
    """
    out: dict[str, Any] = {
        "per_output": {},
        "per_output_at": {},
        "summary": None,
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
    if abscissa != "factor":
        keys = (keys - {abscissa}) | {"factor"}
    summary = []
    for key in sorted(keys):
        ref = values(ref_steps, key)
        mod = values(model_steps, key)[idx_m]
        if interp:
            order = np.argsort(sign * r_abs)
            refv = np.interp(at * sign, (sign * r_abs)[order], ref[order])
        else:
            refv = ref[idx_r]
        diff = np.abs(mod - refv)
        if not np.any(np.isfinite(diff)):
            out["per_output"][key] = None
            continue
        err = float(np.nanmax(diff)) / _scale(key, ref, length)
        out["per_output"][key] = err
        out["per_output_at"][key] = _num(model_steps[idx_m[int(np.nanargmax(diff))]]["factor"])
        if key.rsplit(".", 1)[-1] in SUMMARY_QUANTITIES:
            summary.append(err)
    if abscissa != "factor" and out["coverage"] < 1.0 - 1e-6:
        # traced against a displacement: the part of the reference's range the model never
        # reached is an error of at least that displacement (a model that cannot move there
        # is not accurate there)
        short = (last_ref - reached) / _scale(abscissa, r_abs, length)
        out["per_output"][abscissa] = short
        out["note"] = f"the model reaches {out['coverage']:.0%} of the reference's {abscissa}"
        summary.append(short)
    if summary:
        out["summary"] = max(summary)
    elif out["per_output"]:
        finite = [v for v in out["per_output"].values() if v is not None]
        out["summary"] = max(finite) if finite else None
    return out


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


def estimate_scale(estimate: Mapping[str, Any], length: float) -> float | None:
    """Largest normalised error estimate (same scaling as path errors) of a reference.

    ``estimate`` maps output key -> float (last step) or list of floats (one per step).
    """
    worst = []
    for key, est in estimate.items():
        arr = np.atleast_1d(np.asarray([_num(e) for e in np.atleast_1d(est)], dtype=float))
        if not np.any(np.isfinite(arr)):
            continue
        q = key.rsplit(".", 1)[-1]
        if q in SUMMARY_QUANTITIES:
            worst.append(float(np.nanmax(np.abs(arr))) / (length if q in TRANSLATIONS else 1.0))
    return max(worst) if worst else None


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
    """Fill ``errors``, ``refchecks``, ``summary_error`` and speed ratios of one case's records.

    Returns the case-level reference info (``reference``, ``note``, ``uncertainty``).
    """
    by_model = {r["model"]: r for r in records}
    ref_name, note = choose_reference(meta, by_model)
    ref = by_model.get(ref_name) if ref_name else None
    length = float(meta.get("length_scale") or 1.0)
    uncertainty = None
    extras = (ref or {}).get("extras") or {}
    for est_key in ("error_estimate_steps", "error_estimate"):  # fem-auto: per step, last step
        if isinstance(extras.get(est_key), Mapping):
            uncertainty = estimate_scale(extras[est_key], length)
            break
    t_ref = cost_s(ref)
    for rec in records:
        rec["is_reference"] = rec["model"] == ref_name
        rec["refchecks"] = reference_checks(
            meta.get("references", ()), rec["steps"], rec["status"] == "converged"
        )
        rec["errors"] = None
        rec["summary_error"], rec["summary_basis"] = None, None
        if ref is not None and rec["steps"] and not rec["is_reference"]:
            rec["errors"] = path_errors(rec["steps"], ref["steps"], length, abscissa_output(meta))
            if rec["errors"]["summary"] is not None and rec["errors"]["n_points"] >= 2:
                rec["summary_error"], rec["summary_basis"] = rec["errors"]["summary"], "path"
        if rec["summary_error"] is None and not rec["is_reference"]:
            errs = [c["error"] for c in rec["refchecks"] if c["error"] is not None]
            if errs:
                rec["summary_error"], rec["summary_basis"] = max(errs), "references"
        t = cost_s(rec)
        rec["speedup_vs_reference"] = t_ref / t if t_ref and t else None
    return {"reference": ref_name, "note": note, "uncertainty": uncertainty}


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
