"""Newton shooting with an analytic Jacobian on the elastica's closed-form pendulum flow
(``elastica_flow``: the pendulum u'' = -lam^2 sin u in Jacobi elliptic functions).

Why this route (not ``solve_ivp`` or collocation): one evaluation of the flow costs a few
special-function calls (~20-40 us), is exact to round-off for any load size, and its derivative
with respect to the root curvature follows analytically from d am(w|m)/dm (DLMF 19.4.2 with
E = F - m D), so Newton shooting on the single unknown root curvature converges quadratically
at ~0.1-0.5 ms per solve.  ``solve_ivp`` shooting needs ~5-20 ms per solve at 1e-10 and a
Chebyshev collocation needs 40-100 nodes and dense Newton solves for curled shapes.

Shooting problems (one unknown, the root curvature p0):

* dead force + tip moment M: residual  kappa(L) - M/EI;
* guided tip (fixed-guided beam, tip rotation held at zero): residual  theta(L);
* follower force at angle gamma to the tip tangent + tip moment: no iteration; the pendulum is
  integrated backwards from the known tip state u(L) = pi - gamma, u'(L) = M/EI.

Load continuation (``follow_path``) walks the load factor with adaptive sub-steps and raises
``ElasticaError`` when Newton cannot converge, when a step would jump (Newton correcting the
tangent predictor by more than ``MAX_CORR`` or by half the root curvature itself -- a switch
to the mirror branch near a bifurcation --, tip rotation or root curvature changing by more
than ``MAX_JUMP``) or when the shooting derivative changes sign (a
conjugate point: limit point or bifurcation, where load control loses the path).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from reduced_models.beam.elastica_flow import TWO_PI, pendulum, tip_flow

MAX_CORR = 0.25  # largest Newton correction |p0 - predictor| * L accepted in a sub-step
MAX_JUMP = 1.0  # largest change of tip rotation (rad) and of root curvature * L per sub-step
RTOL = 1e-10  # residual tolerance relative to the curvature (or rotation) scale


class ElasticaError(RuntimeError):
    """The elastica could not be solved (no convergence, critical point, bad input)."""


# -- shooting -------------------------------------------------------------------------------
def _residual(mode: str, u0: float, p0: float, lam: float, L: float, kL: float) -> tuple:
    """Shooting residual r, dr/dp0, dr/dlam (at fixed p0, kL), tolerance scale, round-off floor.

    dr/dlam uses the scaling u(s; lam, p0) = U(lam s; p0/lam) of the pendulum, so it comes
    from the same Jacobian: d uL/d lam = (pL L - J01 p0)/lam, d pL/d lam = (pL - J11 p0)/lam
    - lam L sin uL.
    """
    uL, pL, J = tip_flow(u0, p0, lam, L)
    if mode == "guided":
        dlam = (pL * L - J[0, 1] * p0) / lam if lam > 0.0 else 0.0
        floor = 8e-16 * (abs(u0) + abs(uL) + 1.0)
        return uL - u0, float(J[0, 1]), dlam, (abs(p0) + lam) * L, floor
    dlam = (pL - J[1, 1] * p0) / lam - lam * L * math.sin(uL) if lam > 0.0 else 0.0
    scale = abs(p0) + abs(pL) + abs(kL) + lam
    return pL - kL, float(J[1, 1]), dlam, scale, 8e-16 * scale


def newton(
    mode: str, u0: float, p_guess: float, lam: float, L: float, kL: float, maxit: int = 30
) -> tuple[float, int, float, float, bool]:
    """Newton on the root curvature p0 (bisection once a sign change is bracketed).

    Returns (p0, iterations, dr/dp0, dr/dlam, converged to ``RTOL``).
    """
    p = p_guess
    lo = hi = None  # residual < 0 at lo, > 0 at hi
    for it in range(1, maxit + 1):
        r, d, dl, scale, floor = _residual(mode, u0, p, lam, L, kL)
        if not (math.isfinite(r) and math.isfinite(d)):
            return p, it, d, dl, False
        if abs(r) <= 1e-3 * RTOL * scale + floor:
            return p, it, d, dl, True
        if r < 0.0:
            lo = p
        else:
            hi = p
        pn = p - r / d if d != 0.0 else math.inf
        if lo is not None and hi is not None and not (min(lo, hi) < pn < max(lo, hi)):
            pn = 0.5 * (lo + hi)
        if abs(pn - p) <= 1e-15 * max(abs(p), lam, 1.0 / L):
            r, d, dl, scale, floor = _residual(mode, u0, pn, lam, L, kL)
            return pn, it, d, dl, abs(r) <= RTOL * scale + floor
        p = pn
    r, d, dl, scale, floor = _residual(mode, u0, p, lam, L, kL)
    return p, maxit, d, dl, abs(r) <= RTOL * scale + floor


def follow_path(
    L: float,
    EI: float,
    fx: float,
    fy: float,
    M: float,
    factors: np.ndarray,
    guided: bool = False,
    min_substep: float = 1e-8,
) -> Iterator[tuple[float, tuple[float, float, float, float], int]]:
    """Continuation in the load factor for dead tip loads (fx, fy, M at factor 1, beam frame).

    Yields ``(factor, (u0, p0, lam, phi), newton_iterations)`` for each requested factor
    (ascending, >= 0): the root state of the pendulum.  Raises ``ElasticaError`` (the message
    names the last converged factor) when the path cannot be followed.  The predictor is the
    exact path tangent dp0/dt = -(dr/dt)/(dr/dp0); the shooting derivative dr/dp0 must stay
    positive (Jacobi's conjugate-point test: the path stays stable).
    """
    mode = "guided" if guided else "moment"
    P = math.hypot(fx, fy)
    phi = math.atan2(fy, fx) if P > 0.0 else math.pi
    u0 = math.pi - phi
    u0 = u0 - TWO_PI if u0 > math.pi else u0
    kt = 0.0 if guided else M / EI  # d(kappa_L)/dt
    d_ref = L if guided else 1.0  # dr/dp0 of the unloaded beam
    # linear-theory root curvature per unit load factor: the tangent at t = 0
    slope = (fy * L / 2.0) / EI if guided else (M + fy * L) / EI
    t_prev, p_prev, th_prev, d_prev = 0.0, 0.0, 0.0, d_ref
    top = float(np.max(factors)) if len(factors) else 1.0
    dt = top
    for target in factors:
        iters = 0
        while t_prev < target:
            h = min(dt, target - t_prev)
            if target - t_prev - h <= 1e-6 * h:  # land exactly on the target, no sliver steps
                h, t = target - t_prev, target
            else:
                t = t_prev + h
            lam = math.sqrt(t * P / EI)
            p_pred = p_prev + slope * h
            p, its, d, dl, ok = newton(mode, u0, p_pred, lam, L, t * kt, maxit=20)
            iters += its
            corr = abs(p - p_pred) * L
            accepted = (
                ok
                and d > 0.0
                and corr <= MAX_CORR
                and corr <= 0.5 * max(abs(p), abs(p_pred)) * L + 1e-9 * lam * L
                and abs(p - p_prev) * L <= MAX_JUMP
            )
            if accepted:
                th = float(pendulum(u0, p, lam, float(L))[0]) - u0
                accepted = abs(th - th_prev) <= MAX_JUMP
            if not accepted:
                dt = 0.5 * h
                if dt < min_substep * max(1.0, abs(target)):
                    why = (
                        "Newton did not converge"
                        if not ok
                        else "shooting derivative changed sign (limit or bifurcation point)"
                        if d <= 0.0
                        else "the path turns too sharply (near a critical point)"
                    )
                    raise ElasticaError(
                        f"cannot follow the load path beyond factor {t_prev:.6g}: {why}; the "
                        f"shooting derivative fell to {d_prev / d_ref:.3g} of its unloaded "
                        "value (it vanishes at limit and bifurcation points)"
                    )
                continue
            # exact tangent: dr/dt = dr/dlam * dlam/dt - d(kappa_L)/dt (moment mode)
            drdt = (dl * P / (2.0 * lam * EI) if lam > 0.0 else 0.0) - (0.0 if guided else kt)
            slope = -drdt / d
            t_prev, p_prev, th_prev, d_prev = t, p, th, d
            if its <= 4:  # easy step: grow the trial step (not the target-clipped one)
                dt = min(2.0 * dt, top)
        yield float(target), (u0, p_prev, math.sqrt(target * P / EI), phi), iters
