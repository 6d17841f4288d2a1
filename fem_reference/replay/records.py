"""What a replay run records besides its settled steps: snap-throughs (``jump``) and the
time history, animation frames and settling figures (``extras``)."""

from __future__ import annotations

import math

import numpy as np

from fem_reference.replay import honesty as honest
from fem_reference.replay import integrator as ev
from reduced_models.base import Step


def jump(run: object, mark: tuple, prev: Step | None, after: Step) -> dict | None:
    """Report the increment of replay ``run`` since ``mark`` (history index, W, U, D, q at
    its start) as a jump if it was dissipative.

    The onset is the last history state (before the kinetic-energy peak) whose tangent is
    still positive definite (bisection on the lowest eigenvalue), i.e. where the trajectory
    left the stable branch: the limit point, up to the quasi-static lag.
    """
    h, (i0, W0, U0, D0, q_prev) = run.hist, mark
    dD = run.D - run.D_impact - D0
    scale = max(abs(run.W - W0), abs(run.strain(-1) - U0), 1e-300)
    if dD <= run.o.jump_dissipation * scale:
        return None
    dist = np.max(np.abs(run.w * (h.q[-1] - q_prev))) / run.L
    if dist < honest.JUMP_MIN_DISTANCE:  # a settling move, not a snap
        return None
    kin = np.asarray(h.kinetic[i0:])
    ipk = i0 + int(np.argmax(kin))

    def eig(i: int) -> float:
        r, K, *_ = run.integ.forces(h.q[i], h.factor[i], h.t[i])
        return float(ev.lowest_modes(K, run.M, k=1)[0][0])

    # the first of ~12 samples up to the peak that is unstable, then bisection
    grid = np.unique(np.linspace(max(i0 - 1, 0), ipk, 12).round().astype(int))
    neg = [i for i in grid if eig(i) < 0.0]
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
    lam_s = None
    if prev is not None:
        lam_s = honest.static_limit(run.sys, q_prev, float(prev.factor), after.factor)
    lam_d = float(h.factor[lo])
    out = dict(factor=lam_d if lam_s is None else lam_s, factor_dynamic=lam_d)
    out.update(factor_static=lam_s, factor_equilibrium=lam_eq, t=float(h.t[lo]))
    out.update(from_factor=float(prev.factor) if prev else math.nan, to_factor=after.factor)
    out.update(dissipated=float(dD), dissipated_ratio=float(dD / scale))
    out.update(peak_kinetic=float(kin.max()), jump_distance=float(dist))
    out.update(before=dict(before.outputs), after=dict(after.outputs))
    out["settled_before"] = dict(prev.outputs) if prev else {}
    return out


def extras(run: object, system: object, jumps: list[dict], probes: list[dict]) -> dict:
    """The Solution extras of replay ``run`` of ``system``: ``history`` (time series, lists,
    at most ``history_samples``), ``jumps``, ``events``, ``probes``, ``frames`` (arrays, at
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
    out.update(frames=frames, settle=settle)
    return out


def downsample(n: int, cap: int) -> np.ndarray:
    """At most ``cap`` indices of range(n), evenly spread, first and last included."""
    return np.arange(n) if n <= cap else np.unique(np.linspace(0, n - 1, cap).round().astype(int))
