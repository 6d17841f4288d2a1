"""Newton finish of a held-settled state: the static equilibrium the motion came to rest at.

A state settled by holding the load (``run._Run.hold``) passes the settling test: its
velocity, acceleration and static distance max|w K^-1 r| are below ``settle_tol`` L.  Where
it lies inside that ball is decided by the round-off of the motion, so the same scene in
another encoding (rotated, mirrored, in other units, its nodes renumbered) settles elsewhere
in it: outputs that are nearly zero then differ by up to ``settle_tol`` L, and a tangent test
near zero (a perfect column's tied mirror branches) can flip.  ``finish`` takes Newton on
the same mesh, load and locked booms from the settled state -- its first correction is the
settling test's static distance -- to the equilibrium itself (correction <= ``FINISH_TOL``
L, quadratic: two or three iterations), at rest.  The finish is accepted only if it converges
and stays within ``FINISH_BALL`` settle_tol L of the settled state (the equilibrium the
motion came to rest at, not another one Newton reaches from it); otherwise the settled state
is kept and the reason returned, which the replay states.

w: 1 for translations, L for rotations (``modes.dof_weights``).
"""

from __future__ import annotations

import numpy as np

from fem_reference.replay import integrator as ev

FINISH_TOL = 1e-12  # last Newton correction max|w dq| / L that ends the finish
FINISH_BALL = 100.0  # finished state within this x settle_tol L of the settled one
FINISH_ITER = 6  # Newton iterations at most (quadratic from settle_tol: two or three)


def newton_finish(
    run: object, s: ev.State, step: tuple[np.ndarray, np.ndarray] | None
) -> tuple[ev.State | None, str]:
    """The static equilibrium at rest that the settled state ``s`` of replay ``run`` lies
    next to: Newton on r(q, lam) + G^T mu = 0, g(q) = 0 (locked booms; boom pushes at time
    s.t) from (s.q, s.mu), its first correction ``step`` = (dq, dmu) the settling test's
    (``_Run.static_check``: the same evaluation and factorisation, not done again).

    Returns
    -------
    (state, "") : the finished state (velocities and accelerations zero), or
    (None, reason) : Newton did not converge within ``FINISH_ITER`` iterations, hit a
        singular tangent, or left the ball of ``FINISH_BALL`` settle_tol L around ``s.q``.
    """
    integ, L, w = run.integ, run.L, run.w
    ball = FINISH_BALL * run.o.settle_tol * L
    if step is None:
        return None, "singular tangent"
    q, mu = s.q.copy(), s.mu.copy()
    for it in range(FINISH_ITER):
        if it:
            r, K, _, Gc, gc, Hs = integ.forces(q, s.lam, s.t)
            Kt = ev.combine([(1.0, K)] + [(m_, H) for m_, H in zip(mu, Hs)])
            try:
                solve = ev.factor(Kt, integ.bw)
            except RuntimeError:
                return None, "singular tangent"
            step = (-solve(r + Gc.T @ mu), np.zeros(0))
            if Gc.shape[0]:  # bordered by the locked booms' rows: G dq = -g
                step = ev.bordered(solve, Gc, step[0], gc)
        integ.newton_iterations += 1
        dq, dmu = step
        mu = mu + dmu if dmu.size else mu
        err = float(np.max(np.abs(w * dq), initial=0.0))
        q = q + dq
        moved = float(np.max(np.abs(w * (q - s.q)), initial=0.0))
        if not (moved <= ball):  # nan too
            return None, f"Newton left the settled state by {moved / L:.1e} L"
        if err <= FINISH_TOL * L:  # at rest in equilibrium: no acceleration (M^-1 r would
            # be the residual's round-off sent through the stiff, light modes)
            rest = integ.start(s.t, s.lam, q, np.zeros_like(q))
            rest.acc[:], rest.a[:], rest.mu = 0.0, 0.0, mu
            return rest, ""
    return None, f"Newton did not converge in {FINISH_ITER} iterations (last {err / L:.1e} L)"


def finished(run: object, s: ev.State, chk: dict) -> tuple[ev.State, dict]:
    """The held-settled state ``s`` (the run's current state, its ``_Run.static_check``
    ``chk``) finished by ``newton_finish``, with the finished state's own check; or ``s``
    and ``chk`` with ``chk["unfinished"]`` saying why the finish was not accepted.  The
    history's sample of ``s`` shows the finished state, at rest (the time history holds
    each answer and ends on the last); the motion goes on from ``s`` itself, within
    settle_tol L of it: going on from the finished state left a symmetric switch's snap
    landing to round-off (DAS-2D Ex. 3 ramped in other units landed on the other branch)."""
    rest, why = newton_finish(run, s, chk.get("step"))
    chk_rest = None if rest is None else run.static_check(rest)
    if chk_rest is None:
        return s, {**chk, "unfinished": why or "the finished state failed the settling test"}
    h = run.hist
    if h.q and h.q[-1] is s.q:
        h.q[-1], h.kinetic[-1], h.strain[-1] = rest.q, 0.0, None
    return rest, chk_rest


def note(extras: dict) -> str:
    """The message's word on settled states kept unfinished (``extras["settle"]
    ["unfinished"]``: [{factor, why}]): "" when every state is an equilibrium to round-off."""
    kept = extras.get("settle", {}).get("unfinished") or []
    if not kept:
        return ""
    return (
        f"; {len(kept)} settled state(s) kept as settled (within settle_tol L of equilibrium),"
        f" not finished by Newton (factor {kept[0]['factor']:.6g}: {kept[0]['why']})"
    )
