"""Richardson extrapolation, observed order and honest error estimates for ``fem-auto``.

For a quantity computed on meshes with mesh sizes h1 > h2 > h3 (element counts n1 < n2 < n3)
and an error ``f(h) - f* ~ C h^p``, the observed order p solves
``(f2 - f1) / (f3 - f2) = (h1^p - h2^p) / (h2^p - h3^p)`` (closed form for a constant ratio
r = h1/h2 = h2/h3: ``p = log(|f2 - f1| / |f3 - f2|) / log r``) and the extrapolated value is
``f* = f3 + (f3 - f2) / ((h2/h3)^p - 1)`` (Roache, Verification and Validation in Computational
Science and Engineering, 1998, Ch. 5; Celik et al., J. Fluids Eng. 130:078001, 2008).

Each estimate describes the value it is attached to (``Extrapolation.basis``):

* *Asymptotic range* -- the observed order is within ``ASYMPTOTIC_TOL`` of the formal order
  ``P_FORMAL`` = 2 of the corotational element (Celik et al. 2008 ask for such a check before
  trusting an extrapolation).  The value is the extrapolated ``f*``.  With four or more
  meshes its error is estimated from two successive extrapolations (the last three meshes and
  the three before): ``FS_EXTRAPOLATED |f*_last - f*_prev| / (r^(p+2) - 1)``, the next term of
  the error expansion being assumed two orders higher and ``FS_EXTRAPOLATED`` = 3 the safety
  factor of an assumed order (Roache 1998, Sec. 5.9).  With three meshes only the correction
  ``|f* - f3|`` -- the finest mesh's error -- bounds it (cautious: 10-100x pessimistic).
* *Outside the asymptotic range* (order far from 2, differences changing sign, or two meshes):
  no extrapolation.  The value is the finest mesh's ``f3`` and its error the Grid Convergence
  Index with the formal order and Roache's safety factor for an assumed order,
  ``FS_ASSUMED |f3 - f2| / (r^2 - 1)``, ``FS_ASSUMED`` = 3 (``fallback = True``).

Values that agree to round-off get a zero order (``nan``) and the last difference as error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from cases.schema import Scene
from reduced_models.base import Solution

if TYPE_CHECKING:  # the runner lives in models.py, which imports this module
    from fem_reference.models import Runner

P_FORMAL = 2.0
ASYMPTOTIC_TOL = 0.2  # |p_observed - P_FORMAL| within this: asymptotic range
FS_ASSUMED = 3.0  # Roache's GCI safety factor when the order is assumed, not observed
FS_EXTRAPOLATED = 3.0  # same factor on the assumed next order of the extrapolated values


def gci(coarse: float | np.ndarray, fine: float | np.ndarray, ratio: float) -> float | np.ndarray:
    """Grid Convergence Index of the ``fine`` value from two meshes whose element counts differ
    by ``ratio`` (> 1), the order assumed (``P_FORMAL``), not observed:
    ``FS_ASSUMED |fine - coarse| / (ratio^P_FORMAL - 1)`` (Roache 1998, Sec. 5.9).  The one
    rule for a two-mesh error estimate: ``fem-auto`` outside the asymptotic range and the
    replay's stated mesh error (``replay.honesty``, ``replay.servo``)."""
    return FS_ASSUMED * np.abs(np.subtract(fine, coarse)) / (ratio**P_FORMAL - 1.0)


@dataclass(frozen=True)
class Extrapolation:
    """Result for one quantity: the reported value, the error estimate *of that value*
    (absolute), the observed order (nan when undefined), whether the asymptotic-range check
    failed (``fallback``: the value is the finest mesh's), and ``basis`` = ``"extrapolated"``
    | ``"finest"``."""

    value: float
    error: float
    order: float
    fallback: bool
    basis: str = "extrapolated"


def observed_order(f: np.ndarray, n: np.ndarray) -> float:
    """Observed order from the last three values ``f`` on element counts ``n`` (nan if the
    sequence is not monotone)."""
    f1, f2, f3 = (float(x) for x in f[-3:])
    h1, h2, h3 = (1.0 / float(x) for x in n[-3:])
    d21, d32 = f2 - f1, f3 - f2
    if d32 == 0.0 or d21 == 0.0 or d21 * d32 < 0.0:
        return math.nan
    ratio = d21 / d32
    r12, r23 = h1 / h2, h2 / h3
    if abs(r12 - r23) < 1e-12:
        return math.log(ratio) / math.log(r12)

    def g(p: float) -> float:
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    try:
        return float(brentq(g, 1e-3, 20.0))
    except ValueError:
        return math.nan


def _richardson(f: np.ndarray, n: np.ndarray) -> tuple[float, float]:
    """(f*, observed order) of the last three values (f* = nan outside the asymptotic
    range)."""
    p = observed_order(f, n)
    if math.isnan(p) or abs(p - P_FORMAL) > ASYMPTOTIC_TOL:
        return math.nan, p
    rr = float(n[-1] / n[-2])
    return float(f[-1]) + (float(f[-1]) - float(f[-2])) / (rr**p - 1.0), p


def extrapolate(f: np.ndarray, n: np.ndarray, scale: float = 0.0) -> Extrapolation:
    """Value and honest error estimate from values ``f`` (m,) on element counts ``n`` (m,)
    (see the module docstring).

    ``scale`` is a magnitude for the round-off test (e.g. a length for displacements).
    """
    f = np.asarray(f, dtype=float)
    n = np.asarray(n, dtype=float)
    if f.size == 1:
        return Extrapolation(float(f[0]), math.nan, math.nan, True, "finest")
    f2, f3 = float(f[-2]), float(f[-1])
    d32 = f3 - f2
    floor = 1e-11 * max(abs(f3), abs(scale), 1e-300)
    if abs(d32) <= floor:
        return Extrapolation(f3, abs(d32), math.nan, False, "finest")
    rr = float(n[-1] / n[-2])
    star, p = _richardson(f, n) if f.size >= 3 else (math.nan, math.nan)
    if math.isnan(star):  # outside the asymptotic range: the finest value with its GCI
        return Extrapolation(f3, float(gci(f2, f3, rr)), p, True, "finest")
    if f.size >= 4:
        prev, _ = _richardson(f[:-1], n[:-1])
        if not math.isnan(prev):
            err = FS_EXTRAPOLATED * abs(star - prev) / (rr ** (p + 2.0) - 1.0)
            return Extrapolation(star, max(err, floor), p, False)
    return Extrapolation(star, abs(star - f3), p, False)


def extrapolate_table(
    values: dict[str, np.ndarray],
    n: np.ndarray,
    scales: dict[str, float] | None = None,
    same: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Vectorised over steps: ``values[key]`` is (m meshes, n_steps).

    ``same`` (m, n_steps) bool selects, per step, the meshes that enter its estimate (those on
    the finest mesh's branch, ``same_branch``; default all): a step left with one mesh has
    no estimate (error and order nan, the finest value).

    Returns ``{"value": {key: (n_steps,)}, "error": ..., "order": ..., "fallback": ...}``
    as nested dicts of arrays.
    """
    scales = scales or {}
    n = np.asarray(n, dtype=float)
    out = {"value": {}, "error": {}, "order": {}, "fallback": {}}
    for key, tab in values.items():
        tab = np.asarray(tab, dtype=float)
        sel = np.ones(tab.shape, dtype=bool) if same is None else same
        res = [
            extrapolate(tab[sel[:, j], j], n[sel[:, j]], scales.get(key, 0.0))
            for j in range(tab.shape[1])
        ]
        out["value"][key] = np.array([r.value for r in res])
        out["error"][key] = np.array([r.error for r in res])
        out["order"][key] = np.array([r.order for r in res])
        out["fallback"][key] = np.array([r.fallback for r in res])
    return out


def _point_pairs(keys: list[str]) -> list[tuple[str, str]]:
    """(x key, y key) of every point's position and displacement pair among ``keys``."""
    return [
        (k, k[:-1] + "y")
        for k in keys
        if k.rsplit(".", 1)[-1] in ("x", "ux") and k[:-1] + "y" in keys
    ]


def extrapolate_points(
    values: dict[str, np.ndarray],
    n: np.ndarray,
    scales: dict[str, float] | None = None,
    same: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """``extrapolate_table`` with each point's (x, y) pair extrapolated in its convergence
    frame: first axis along the two finest meshes' difference, per step.

    Componentwise, a rotation of the drawing mixes two observed orders (the cantilever's
    tip x converges at order 1.7, its y at 2.0), so the extrapolated answer and its fallback
    depended on the frame the scene is drawn in (1.7e-6 of the excursion at 37 deg); in the
    convergence frame they do not.  Errors are mapped back as the bound |c| e1 + |s| e2;
    both components report the first axis's observed order.
    """
    values = dict(values)
    frames = []
    for kx, ky in _point_pairs(list(values)):
        X, Y = np.asarray(values[kx], float), np.asarray(values[ky], float)
        dx, dy = X[-1] - X[-2], Y[-1] - Y[-2]
        r = np.hypot(dx, dy)
        c = np.divide(dx, r, out=np.ones_like(r), where=r > 0)
        s = np.divide(dy, r, out=np.zeros_like(r), where=r > 0)
        values[kx], values[ky] = X * c + Y * s, Y * c - X * s
        frames.append((kx, ky, c, s))
    out = extrapolate_table(values, n, scales, same)
    for kx, ky, c, s in frames:
        a, b = out["value"][kx], out["value"][ky]
        out["value"][kx], out["value"][ky] = a * c - b * s, a * s + b * c
        ea, eb = out["error"][kx], out["error"][ky]
        out["error"][kx] = np.abs(c) * ea + np.abs(s) * eb
        out["error"][ky] = np.abs(s) * ea + np.abs(c) * eb
        # the point converges along the first axis (the second one's finest difference is
        # zero by construction: no order of its own); a fallback on either axis is the point's
        out["order"][ky] = out["order"][kx]
        fb = out["fallback"][kx] | out["fallback"][ky]
        out["fallback"][kx], out["fallback"][ky] = fb, fb.copy()
    return out


def branch_changes(critical_points: list, factors: np.ndarray) -> np.ndarray:
    """How many branch changes (a snap, a switch at a bifurcation: ``critical_points``
    entries with ``switched``) a load-stepped path has passed at each of ``factors``
    (n_steps,), counted from the first factor in the direction of loading; an int array."""
    f = np.asarray(factors, dtype=float)
    ev = np.array([cp["factor"] for cp in critical_points if cp.get("switched")], dtype=float)
    d, span = ev[:, None] - f[0], (f - f[0])[None, :]
    return np.sum((d * span > 0.0) & (np.abs(d) < np.abs(span)), axis=0)


def same_branch(runs: list, kind: str) -> np.ndarray:
    """(m, n_steps) bool: whether mesh i's state at step j lies on the branch of the finest
    mesh's (the last of ``runs``, Runners with equally many steps).

    A load-stepped path that snapped or switched at a bifurcation on one mesh and not (yet)
    on another holds states of different branches between the two events: their difference
    is the distance between the branches, not a discretisation error, and Richardson on it
    is meaningless (DAS-2D Ex. 3: the coarse meshes stay on the unstable fundamental branch
    up to its limit point while the finest switches at the bifurcation before it).  So a
    mesh is on the finest mesh's branch where it has passed as many branch changes.  A path
    analysis's coarse meshes are re-solved through the finest path (``_retrace``): all same.
    """
    fin = runs[-1]
    same = np.ones((len(runs), len(fin.steps)), dtype=bool)
    if kind == "path":
        return same
    factors = np.array([s.factor for s in fin.steps], dtype=float)
    ref = branch_changes(fin.extras.get("critical_points") or [], factors)
    for i, r in enumerate(runs[:-1]):
        same[i] = branch_changes(r.extras.get("critical_points") or [], factors) == ref
    return same


def _branch_note(ns: np.ndarray, same: np.ndarray, factors: np.ndarray) -> tuple[str, list]:
    """The message and the ``extras["off_branch"]`` records (``factor``, ``meshes`` used,
    ``excluded``, whether an ``estimate`` is left) of the steps some mesh was left out of
    (``same_branch``)."""
    part = np.flatnonzero(~same.all(axis=0))
    if part.size == 0:
        return "", []
    records = [
        {
            "factor": float(factors[j]),
            "meshes": ns[same[:, j]].astype(int).tolist(),
            "excluded": ns[~same[:, j]].astype(int).tolist(),
            "estimate": bool(same[:, j].sum() >= 2),
        }
        for j in part
    ]
    parts = []
    for has, what in ((False, "no error estimate"), (True, "an error estimate from fewer meshes")):
        at = [r for r in records if r["estimate"] is has]
        if at:
            out = sorted({n for r in at for n in r["excluded"]})
            parts.append(
                f"{what} at {len(at)} steps (factors {at[0]['factor']:.6g}-"
                f"{at[-1]['factor']:.6g}): meshes {out} are on another branch there (they "
                "snapped or switched branch at another factor)"
            )
    note = "; ".join(parts)
    return note, records


# -- fem-auto: combine the runs of a mesh sequence ---------------------------------------------


def _scale(key: str, L: float, steps: list) -> float:
    """The magnitude of output ``key`` for ``extrapolate``'s round-off test: the length
    scale for positions, 1 rad for rotations, else the largest |value| along the path in its
    own units (energy, a driver's force or torque, a factor): a force judged against the load
    factor's size was "at round-off" in N m and not in N mm (DAS-2D Ex. 4's crank torque)."""
    if key.endswith((".x", ".y", ".ux", ".uy")):
        return L
    if key.endswith(".rot"):
        return 1.0
    if key == "energy":
        return max([abs(s.energy) for s in steps] + [1e-300])
    if key == "factor":
        return max([abs(s.factor) for s in steps] + [1e-300])
    vals = [abs(s.outputs.get(key, 0.0)) for s in steps]
    return max([v for v in vals if math.isfinite(v)] + [1e-300])


def _retrace(runner: Runner, key: str, values: np.ndarray) -> bool:
    """Re-solve a coarse mesh by displacement control through the finest path's values of the
    (monotone) stop output; replaces ``runner.steps``.  A step that fails from the previous
    re-solved state is tried once more from the coarse path's own state nearest in the stop
    output (a perfect column's first step crosses its bifurcation: drawn turned by 37 deg,
    displacement control from the straight state failed on two meshes, and fem-auto fell
    back to the finest mesh).  False if that fails too."""
    from fem_reference.models import _rec
    from fem_reference.statics import static as S

    sysm = runner.system
    func = sysm.output_functional(key)
    own = [(func[2] + func[1] * s.u[func[0]], s) for s in runner.states] if func[0] >= 0 else []
    st = runner.states[0]
    steps = [runner.steps[0]]
    for k in range(1, len(values)):
        v, dv = float(values[k]), float(abs(values[k] - values[k - 1]))
        try:
            st = S.displacement_control(sysm, st, func, v, dv, runner.opts)
        except S.SolveError:
            if not own:
                return False
            near = min(own, key=lambda t: abs(t[0] - v))[1]
            try:
                st = S.displacement_control(sysm, near, func, v, dv, runner.opts)
            except S.SolveError:
                return False
        steps.append(_rec(sysm, st, st.lam, None))
    runner.steps = steps
    return True


def combine(scene: Scene, name: str, sequence: tuple[int, ...], runs: list) -> Solution:
    """Combine ``runs`` = [(Runner, status, message)] on element counts ``sequence`` into the
    ``fem-auto`` Solution (see ``FEMAuto``)."""
    fin, fstatus, fmsg = runs[-1]
    extras: dict = {"sequence": list(sequence), "statuses": [r[1] for r in runs]}
    if fstatus != "converged" or len(fin.steps) == 0:
        return Solution(
            scene.name,
            name,
            fstatus if fstatus != "converged" else "failed",
            f"finest mesh (n={sequence[-1]}): {fmsg or 'no steps'}",
            tuple(fin.steps),
            extras,
        )
    kind = scene.analysis.kind
    message = fmsg  # the finest run's own note (e.g. an unstable end) is kept
    if fin.extras.get("reference_usable") is False:
        extras["reference_usable"] = False
    _critical(runs, sequence, extras)
    usable = [(n, r) for n, (r, st, _) in zip(sequence, runs) if st == "converged"]
    if kind == "path":
        key = scene.analysis.stop_output
        vals = np.array([s.outputs.get(key, np.nan) for s in fin.steps]) if key else None
        mono = vals is not None and np.all(np.diff(vals) * np.sign(vals[-1] - vals[0]) > 0)
        if mono:
            usable = [(n, r) for n, r in usable[:-1] if _retrace(r, key, vals)] + [usable[-1]]
        else:
            message = message + "; " if message else ""
            message += (
                "path not monotone in its stop output: steps are the finest mesh's; "
                "error estimates from the end point and the limit points"
            )
            usable_end = usable
            usable = []
            _limit_and_end(scene, fin, usable_end, extras)
    usable = [(n, r) for n, r in usable if len(r.steps) == len(fin.steps)]
    if len(usable) < 2:
        if kind != "path" or not message:
            message = message or "fewer than two usable meshes: no error estimate"
        return Solution(scene.name, name, "converged", message, tuple(fin.steps), extras)
    ns = np.array([n for n, _ in usable], dtype=float)
    keys = list(fin.steps[0].outputs)
    table = {k: np.array([[s.outputs[k] for s in r.steps] for _, r in usable]) for k in keys}
    table["energy"] = np.array([[s.energy for s in r.steps] for _, r in usable])
    solved_factor = kind in ("path", "distance")
    if solved_factor:
        table["factor"] = np.array([[s.factor for s in r.steps] for _, r in usable])
    L = fin.system.length_scale()
    same = same_branch([r for _, r in usable], kind)
    factors = np.array([s.factor for s in fin.steps], dtype=float)
    note, off = _branch_note(ns, same, factors)
    if off:
        extras["off_branch"] = off
        message = f"{message}; {note}" if message else note
    ex = extrapolate_points(table, ns, {k: _scale(k, L, fin.steps) for k in table}, same)
    steps = []
    for j, s in enumerate(fin.steps):
        outs = {k: float(ex["value"][k][j]) for k in keys}
        steps.append(
            replace(
                s,
                outputs=outs,
                energy=float(ex["value"]["energy"][j]),
                factor=float(ex["value"]["factor"][j]) if solved_factor else s.factor,
                info={**s.info, "richardson": 1.0},
            )
        )
    extras["error_estimate"] = {k: float(ex["error"][k][-1]) for k in table}
    extras["observed_order"] = {k: float(ex["order"][k][-1]) for k in table}
    extras["order_fallback"] = sorted(k for k in table if ex["fallback"][k][-1])
    extras["error_estimate_steps"] = {k: ex["error"][k].tolist() for k in table}
    extras["observed_order_steps"] = {k: ex["order"][k].tolist() for k in table}
    extras["meshes_used"] = ns.astype(int).tolist()
    if kind == "path":
        _limit_and_end(scene, fin, usable, extras, end=False)
    return Solution(scene.name, name, "converged", message, tuple(steps), extras)


def _critical(runs: list, sequence: tuple[int, ...], extras: dict) -> None:
    """The finest run's critical points (``bifurcation.Watch``), each with its factor
    Richardson-extrapolated over the meshes that found a point of the same kind at the same
    position in their list and located it (a factor interpolated across a load step is no
    member of a convergent sequence)."""
    fin = runs[-1][0]
    pts = fin.extras.get("critical_points")
    if pts is None:
        return
    out = []
    for i, cp in enumerate(pts):
        same = [
            (n, r.extras["critical_points"][i]["factor"])
            for n, (r, _, _) in zip(sequence, runs)
            if len(r.extras.get("critical_points", ())) > i
            and r.extras["critical_points"][i]["kind"] == cp["kind"]
            and r.extras["critical_points"][i].get("located", True)
        ]
        item = dict(cp)
        if len(same) >= 2 and cp.get("located", True):
            e = extrapolate(
                np.array([f for _, f in same]), np.array([n for n, _ in same]), abs(cp["factor"])
            )
            item.update(factor_extrapolated=e.value, error=e.error, order=e.order)
        out.append(item)
    extras["critical_points"] = out


def _limit_and_end(scene: Scene, fin: Runner, usable: list, extras: dict, end: bool = True) -> None:
    """Richardson on the path's limit points (matched by order) and, if ``end``, on the end
    point (landed exactly on the stop criterion in every mesh)."""
    usable = [(n, r) for n, r in usable if "limit_points" in r.extras]
    lps = fin.extras.get("limit_points", [])
    out = []
    for i, lp in enumerate(lps):
        same = [
            (n, r.extras["limit_points"][i]["factor"])
            for n, r in usable
            if len(r.extras["limit_points"]) == len(lps)
            and r.extras["limit_points"][i]["kind"] == lp["kind"]
        ]
        item = dict(lp)
        if len(same) >= 2:
            e = extrapolate(
                np.array([f for _, f in same]), np.array([n for n, _ in same]), abs(lp["factor"])
            )
            item.update(
                factor_extrapolated=e.value,
                error=e.error,
                order=e.order,
                factors_by_mesh={str(n): f for n, f in same},
            )
        out.append(item)
    extras["limit_points"] = out
    if not end:
        return
    ends = [(n, r.steps[-1]) for n, r in usable if r.steps] if usable else []
    if len(ends) >= 2:
        ns = np.array([n for n, _ in ends], dtype=float)
        keys = list(fin.steps[-1].outputs) + ["factor"]
        L = fin.system.length_scale()
        err, order = {}, {}
        for k in keys:
            vals = np.array([s.factor if k == "factor" else s.outputs[k] for _, s in ends])
            e = extrapolate(vals, ns, _scale(k, L, fin.steps))
            err[k], order[k] = e.error, e.order
        extras["error_estimate"] = err
        extras["observed_order"] = order
