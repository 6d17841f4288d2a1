"""What a replay run records besides its settled steps: snap-throughs (``jump``) and the
time history, animation frames and settling figures (``extras``)."""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem_reference.replay import honesty as honest
from fem_reference.replay import modes
from reduced_models.base import Step

BRANCH_RATIO = 3.0  # a settled end this many times further than the tangent predicts


def _predicted(run: object, q: np.ndarray, lam: float, lam_next: float) -> float:
    """max|w K^-1 f_ext| |dlam| / L: the motion the tangent at the settled state ``(q,
    lam)`` predicts for the load step to ``lam_next`` (inf if that tangent is singular)."""
    _, K, *_ = run.integ.forces(q, lam)
    f = np.asarray(run.sys.external(q), dtype=float) * (lam_next - lam)
    try:
        d = spla.spsolve(sp.csc_matrix(K), f)
    except RuntimeError:
        return math.inf
    move = float(np.max(np.abs(run.w * d))) / run.L
    return move if math.isfinite(move) else math.inf


def jump(
    run: object,
    mark: tuple,
    prev: Step | None,
    after: Step,
    stable_from: tuple[np.ndarray, float] | None = None,
    predicted: float | None = None,
) -> dict | None:
    """Report the increment of replay ``run`` since ``mark`` (history index, W, U, D, q at
    its start) as a jump (a snap-through) if its settled end lies on another branch than
    its settled start.  ``stable_from``: (q, factor) of the last settled state found stable,
    where the static path's stability loss is looked for (``factor_static``; by default the
    increment's start).  ``predicted``: the tangent's motion for the increment / L, when
    the reach knows it (``sweep.ContinuousRamp.move``; else computed, ``_predicted``).

    A candidate moved at least ``JUMP_MIN_DISTANCE`` and either ``BRANCH_RATIO`` x more
    than the tangent at the start predicts for the load step, or dissipated more than
    ``jump_dissipation`` of the work done (a quasi-static ramp dissipates ~ 1 / (omega_1
    T_ramp) of it).  It is a jump if (1) the static path traced from the start does not
    stay stable up to the end's factor and land on the settled end (``honesty.same_branch``;
    it does for the smooth, fast natural path of an imperfect column past its Euler load,
    which the lagging ramp also crosses with a burst of motion), and (2) its trajectory
    passed a state whose tangent is not positive definite, or it was dissipative (a failed
    trace of a smooth increment is no snap).
    ``jump_dissipation`` = inf switches jumps off (a driver or servo does unbooked work).

    The onset is the last history state (before the kinetic-energy peak) whose tangent is
    still positive definite (bisection on the lowest eigenvalue), i.e. where the trajectory
    left the stable branch: the limit point, up to the quasi-static lag.
    """
    h, (i0, W0, U0, D0, q_prev) = run.hist, mark
    if not math.isfinite(run.o.jump_dissipation):
        return None
    dD = run.D - run.D_impact - D0
    scale = max(abs(run.W - W0), abs(run.strain(-1) - U0), 1e-300)
    dissipative = dD > run.o.jump_dissipation * scale
    dist = np.max(np.abs(run.w * (h.q[-1] - q_prev))) / run.L
    if prev is None or dist < honest.JUMP_MIN_DISTANCE:  # a settling move, not a snap
        return None
    if predicted is None and not dissipative:
        predicted = _predicted(run, q_prev, prev.factor, after.factor)
    if not (dissipative or dist > BRANCH_RATIO * predicted):
        return None
    same = None  # boom events: the static trace knows no pushes or locks
    if not run.integ.pairs:
        same = honest.same_branch(run.sys, q_prev, prev.factor, h.q[-1], after.factor, run.w, dist)
    if same:
        return None
    kin = np.asarray(h.kinetic[i0:])
    ipk = i0 + int(np.argmax(kin))

    def eig(i: int) -> float:
        r, K, *_ = run.integ.forces(h.q[i], h.factor[i], h.t[i])
        return float(modes.lowest_modes(K, run.M, k=1)[0][0])

    # the first of ~12 samples up to the peak that is unstable, then bisection
    grid = np.unique(np.linspace(max(i0 - 1, 0), ipk, 12).round().astype(int))
    neg = [i for i in grid if eig(i) < 0.0]
    if not (neg or dissipative):  # never left the stable region, nor dissipated like a snap
        return None
    if neg:
        hi = neg[0]
        lo = int(grid[max(int(np.searchsorted(grid, hi)) - 1, 0)])
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if eig(mid) > 0.0 else (lo, mid)
    else:  # never visibly left the stable region: first rise of kinetic energy
        lo = i0 + int(np.argmax(kin >= 0.01 * kin.max()))
    before = run.sys.step(h.q[lo], h.factor[lo], 0, None)
    # load factor that holds the onset shape in static equilibrium (least squares)
    f = np.asarray(run.sys.external(h.q[lo]), dtype=float)
    r0 = np.asarray(run.sys.residual(h.q[lo], 0.0), dtype=float)
    lam_eq = float(r0 @ f / (f @ f)) if f @ f > 0 else math.nan
    # reported at the static path's stability loss; the dynamic onset alongside
    q_s, lam_0 = (q_prev, float(prev.factor)) if stable_from is None else stable_from
    static = honest.static_limit(run.sys, q_s, lam_0, after.factor) or (None, "snap", None)
    lam_s, kind, roundoff = static
    lam_d = float(h.factor[lo])
    out = dict(factor=lam_d if lam_s is None else lam_s, factor_dynamic=lam_d, kind=kind)
    out.update(factor_static=lam_s, factor_equilibrium=lam_eq, t=float(h.t[lo]))
    out["factor_roundoff"] = roundoff
    out.update(from_factor=float(prev.factor), to_factor=after.factor)
    out.update(dissipated=float(dD), dissipated_ratio=float(dD / scale))
    out.update(peak_kinetic=float(kin.max()), jump_distance=float(dist))
    out.update(before=dict(before.outputs), after=dict(after.outputs))
    out["settled_before"] = dict(prev.outputs)
    return out


def critical_point(jp: dict) -> dict:
    """The jump ``jp`` as ``extras["critical_points"]`` reports it (DESIGN.md, "Critical
    points"; the FE's ``bifurcation.Watch`` form): kind "snap", or "bifurcation" where the
    settled end lies on a supercritical branch through the static critical state (a buckled
    column; ``honesty.static_limit``), ``factor`` where the static path from the
    last stable settled state loses stability (``factor_static``: the scene's critical
    factor on the replay's mesh, as the FE locates it), else where the dynamic jump started
    (``factor_dynamic``, alongside: the ramp's state left the stable region, lagging the
    static factor by the ramp rate, at a time step of the adaptive grid; ``factor_roundoff``
    where the static factor is a located bifurcation), ``from`` the outputs at the dynamic
    onset, ``to`` the settled outputs after the jump."""
    lam = jp["factor_dynamic"] if jp["factor_static"] is None else jp["factor_static"]
    point = {"kind": jp["kind"], "factor": lam, "switched": True}
    point.update({"from": dict(jp["before"]), "to": dict(jp["after"])})
    point.update(factor_static=jp["factor_static"], factor_dynamic=jp["factor_dynamic"])
    if jp["factor_roundoff"] is not None:
        point["factor_roundoff"] = jp["factor_roundoff"]
    point["to_factor"] = jp["to_factor"]
    return point


def tied_point(run: object, stable_from: tuple[np.ndarray, float] | None, lam: float) -> dict:
    """The bifurcation at which the replay was held at a saddle between two mirror-image
    branches (``sweep.off_saddle``, ``run.tied``), as the FE's ``bifurcation.Watch`` reports
    it (kind "bifurcation", not switched, ``tied``): located on the static path from the last
    stable settled state (``honesty.static_limit``), else at the first factor held there."""
    found = None if stable_from is None else honest.static_limit(run.sys, *stable_from, lam)
    factor, _, roundoff = found or (run.tied[0], None, None)
    point = {"kind": "bifurcation", "factor": float(factor), "switched": False, "tied": True}
    if roundoff is not None:
        point["factor_roundoff"] = roundoff
    return point


TIED_NOTE = (
    "; bifurcation at factor {:.6g} into two mirror-image branches of equal energy (a perfect "
    "structure: no rule drawn from the scene picks one): held on the fundamental branch, "
    "unstable beyond it; an imperfection picks a branch"
)


def extras(run: object, system: object, jumps: list[dict], probes: list[dict]) -> dict:
    """The Solution extras of replay ``run`` of ``system``: ``history`` (time series, lists,
    at most ``history_samples``), ``jumps``, ``critical_points`` (the jumps as snaps),
    ``events``, ``probes``, ``frames`` (arrays, at
    most ``frames``) and ``settle`` (timing, damping and energy-balance figures)."""
    o = run.o
    h = run.hist
    idx = downsample(len(h.t), o.history_samples)
    history = {
        key: [float(getattr(h, key)[i]) for i in idx]
        for key in ("t", "factor", "kinetic", "dissipated", "external_work")
    }
    history["strain"] = [run.strain(i) for i in idx]
    out_of = getattr(system, "outputs", None)  # FE systems: outputs without shapes (cheaper)
    if getattr(system, "outputs_need_factor", False):  # a prescribed coordinate: q alone is not
        outs = [out_of(h.q[i], h.factor[i]) for i in idx]  # the state
    else:
        outs = [
            out_of(h.q[i]) if out_of else system.step(h.q[i], h.factor[i], 0, None).outputs
            for i in idx
        ]
    for key in outs[0] if outs else ():
        history[key] = [float(d.get(key, math.nan)) for d in outs]
    fi = downsample(len(h.t), o.frames)
    W, U, T, D = h.external_work[-1], run.strain(-1) - run.U0, h.kinetic[-1], h.dissipated[-1]
    frames = dict(t=np.array(h.t)[fi], factor=np.array(h.factor)[fi], q=np.array(h.q)[fi])
    frames["n_elements"] = getattr(system, "n_elements", None)
    settle = dict(T1=run.T1, omega1=run.w1, damping=run.damping_note, time_steps=len(h.t) - 1)
    settle["newton_iterations"] = run.integ.newton_iterations
    settle["factorizations"] = run.integ.factorizations
    settle["point_masses_added"] = run.point_masses
    settle["energy_balance_error"] = (W - U - T - D) / max(abs(W), abs(U), 1e-300)
    out = dict(history=history, jumps=jumps, events=run.events, probes=probes)
    out["critical_points"] = [critical_point(jp) for jp in jumps]
    out.update(frames=frames, settle=settle)
    return out


def downsample(n: int, cap: int) -> np.ndarray:
    """At most ``cap`` indices of range(n), evenly spread, first and last included."""
    return np.arange(n) if n <= cap else np.unique(np.linspace(0, n - 1, cap).round().astype(int))
