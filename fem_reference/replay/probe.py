"""Stability of the replay's settled states: the tangent's verdict, or a kick and a watch.

A settled state of a conservative system whose tangent is clearly positive definite (or
clearly not) is stable (unstable) by the tangent test alone; one near its limit, or every
state when asked (``ReplayOptions.probe``), is kicked along its softest mode (or by the
thesis's nodal impulse) and watched: it returns (stable) or departs (unstable).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse.linalg as spla

from cases.schema import Scene
from fem_reference.replay import events
from fem_reference.replay import integrator as ev

if TYPE_CHECKING:
    from fem_reference.replay.run import ReplayOptions, _Run

PROBE_NEWTON = 0.1  # Newton tolerance of a probe / settle_tol
PROBE_LTE = 0.1  # local error per step of a probe / the kick's excursion (lte_tol: ~0.3 of 1e-3 L)
# probe="auto": a settled state is kicked when its lowest eigenvalue of (K, M) is within this
# fraction of omega_1^2 of zero (its lowest frequency below ~22 % of the unloaded one): near
# a limit point or bifurcation, where a kick of the probe's size can leave a shallow well
# (or the equilibrium found under load control lies elsewhere, test_replay_probe) and the
# sign of an eigenvalue near zero is the least certain
PROBE_MARGIN = 0.05


def probe_plan(o: ReplayOptions, k: int, n: int, conservative: bool) -> str:
    """What settled state ``k`` of ``n`` gets: "probe" (kicked), "tangent" (the tangent
    test's verdict, kicked only when it is near its limit: ``unprobed``) or "none" (no
    verdict: follower loads, or probes switched off)."""
    last = k == n - 1
    if not conservative or o.probe == "none" or o.probe == "last" and not last:
        return "none"
    return "probe" if o.probe == "all" or last else "tangent"


def unprobed(run: _Run, eig: float, want: str) -> dict | None:
    """The stability record of a settled state that is not kicked: skipped (``want`` "none")
    or the tangent's verdict ("tangent": a conservative system at rest in an equilibrium
    whose tangent is positive definite is stable -- its energy is a Lyapunov function, the
    damping makes it asymptotic -- and one with a negative eigenvalue is not); None when it
    must be kicked ("probe", or |eig| below ``PROBE_MARGIN`` omega_1^2)."""
    if want == "none":
        return {"stable": None, "verdict": "skipped"}
    if want == "tangent" and abs(eig) >= PROBE_MARGIN * run.w1**2:
        return {"stable": bool(eig > 0.0), "verdict": "tangent"}
    return None


def stability(run: _Run, s: ev.State, chk: dict, want: str, scene: Scene | None) -> tuple:
    """Tangent test and (``probe_plan``, ``unprobed``) impulse probe of the settled state
    ``s``: (eig, probe record)."""
    eig, mode = chk.get("tangent") or run.tangent_test(chk)
    return eig, unprobed(run, eig, want) or kick(run, s, eig, mode, scene)


def kick(run: _Run, s: ev.State, eig: float, mode: np.ndarray, scene: Scene | None) -> dict:
    """Kick the settled state ``s`` and watch: returns (stable), departs (unstable).

    Steps are sized by the probed mode (up to tau / 10, local error ``PROBE_LTE`` of the
    kick's excursion) and one factorisation serves steps of one size; a probe that comes
    to rest at an equilibrium stops there (returned if within 2 % of the kick of ``s``).
    """
    o, M = run.o, run.M
    om = max(math.sqrt(abs(eig)), 1e-3 * run.w1)
    if o.probe_node is not None:
        f = np.zeros(run.sys.ndof)  # the thesis's nodal impulse (1 N s in ADAMS)
        for k, i, c in events.node_map(run.sys, o.probe_node)[1]:
            f[i] += c * o.probe_impulse[k]
        v0 = spla.spsolve(M.tocsc(), f)
    else:
        v0 = mode / np.max(np.abs(run.w * mode)) * o.probe_amplitude * run.L * om
    d_ref = float(np.max(np.abs(run.w * v0))) / om
    # decay / growth time of the probed mode, damping included
    c = float(mode @ (run.integ.damping(s) @ mode)) / float(mode @ (M @ mode))
    tau = max(1.0 / om, c / om**2)
    integ, q0 = run.integ, s.q
    saved = [p.locked for p in integ.pairs], run.h, run.s  # s: not always the run's
    start = integ.start(s.t, s.lam, s.q, s.v + v0)
    peak, rest = [0.0], []

    def watch(st: ev.State) -> str | None:
        d = float(np.max(np.abs(run.w * (st.q - q0))))
        peak[0] = max(peak[0], d)
        if d > 20.0 * d_ref:
            return "departed"
        vnorm = float(np.max(np.abs(run.w * st.v)))
        if st.t - s.t <= tau:
            return None
        if d < 0.02 * peak[0] and vnorm < 0.02 * om * peak[0]:
            return "returned"
        # at rest in an equilibrium (it stays there): within 2 % of the kick's excursion
        # of q0 it returned (the offset is q0's own distance to the load-controlled
        # equilibrium, amplified by a near-singular tangent), further away undecided
        if run.static_check(st) is not None:
            rest.append(d / run.L)
            return "returned" if d < 0.02 * d_ref else "undecided"
        return None

    # steps up to tau / 10: a soft, overdamped probed mode (tau >> T1 near a limit point)
    # needs no finer steps than its own time scale; the error test sizes them, to a
    # fraction of the kick's excursion (the probe's motion, far below lte_tol L)
    run.s, run.h = start, min(run.h, tau / 10)
    hmax = max(o.dt_max * run.T1, tau / 10)
    lte = min(o.lte_tol, PROBE_LTE * d_ref / run.L)
    integ.keep_lu = {}  # modified Newton across steps: the tangent barely changes
    tight = integ.newton_tol  # a probe's Newton: 1/10 of its at-rest test, not 1/100
    integ.newton_tol = PROBE_NEWTON * o.settle_tol
    try:
        end, verdict = run.advance(
            s.t + 60.0 * tau, lambda t: s.lam, watch, False, hmax, lte, steady=True
        )
    except ev.ReplayError:
        end, verdict = start, None
    finally:
        integ.keep_lu, integ.newton_tol = None, tight
        for p, lk in zip(integ.pairs, saved[0]):
            p.locked = lk
        run.h, run.s = saved[1:]
    d_end = float(np.max(np.abs(run.w * (end.q - q0)))) / run.L
    stable = {"returned": True, "departed": False}.get(verdict)
    out = dict(stable=stable, peak=peak[0] / run.L, final=d_end, time=end.t - s.t)
    if rest:
        out["at_rest_distance"] = rest[0]  # / L, where it came to rest
    return {**out, "verdict": verdict or "undecided"}
