"""``elastica``: the exact large-deflection Euler-Bernoulli (inextensible) cantilever.

Two exact solution routes share one closed-form pendulum flow (``elastica_flow``):

* **Dead tip force, no tip moment** -- elliptic-integral closed form in the style of
  Bisshopp & Drucker (1945) and Mattiasson (1981), valid for any load angle (tensile or
  compressive axial component).  With c = |sin(u0/2)| (u0 = pi - load angle) the tip is a
  turning point of the pendulum and the load fixes the modulus through

      lam L = K(m) - F(psi*, m),   sin psi* = c / sqrt(m),   lam = sqrt(P/EI),

  the inflection-free fundamental branch that starts at the unloaded beam.  (With no tip
  moment the curvature EI kappa(s) = (r_L - r(s)) x F vanishes only where the force line meets
  the beam, so this branch has no interior inflection point at any load angle; the branches
  with n inflection points, lam L = (2n+1) K -/+ F, are other equilibria that load continuation
  from the straight beam does not reach.  Inflection points do occur under tip moments and
  follower forces, which the shooting route handles.)  It is
  solved by a safeguarded Newton in z = cos psi* (or in log(zmax - z) for large loads, so the
  complementary parameter 1 - m keeps its relative precision), with K, F written as Carlson
  R_F (``scipy.special.elliprf``) and the derivative from R_D.  ~40-60 us per solve.
* **Anything else** (tip moment, combined loads, guided tip, follower force): Newton shooting on
  the root curvature with the analytic Jacobian of the elliptic flow and load continuation
  (``elastica_shooting.follow_path``); follower loads are explicit (backward pendulum from the
  tip).  The model reports ``failed`` when continuation meets a limit or bifurcation point it
  cannot pass (for instance a perfect column past Euler's load), never an unconverged number.

Accuracy: the equations are satisfied to ~1e-13 relative for moderate loads (measured against
40-digit mpmath Bisshopp-Drucker values: 1e-14 up to PL^2/EI = 100 for a vertical load).  All
elliptic functions take the complementary parameter 1 - m exactly (see ``elastica_flow``).
Orbits that hug the pendulum separatrix over a long span (strong tension, sqrt(P L^2/EI) > 12
with 1 - m < 1e-12) lose ~3e-15 exp(sqrt(P L^2/EI)) near the saddle; the model reports
``failed`` there instead of a degraded number (``conditioning_issue``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.special import elliprd, elliprf

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.beam.elastica_flow import pendulum, tip_states
from reduced_models.beam.elastica_shooting import ElasticaError, follow_path
from reduced_models.beam.elastica_state import (
    N_SHAPE,
    Equilibrium,
    SampledShape,
    conditioning_issue,
)
from reduced_models.beam.single_beam import (
    Cantilever,
    cantilever_of,
    output_map,
)

__all__ = [
    "Elastica",
    "ElasticaError",
    "Equilibrium",
    "closed_form_dead",
    "conditioning_issue",
    "follower_equilibrium",
    "equilibrium",
    "rollup",
    "shape_under_tip_load",
    "tip_dead_force",
]

_STATE = ("u_start", "p_start", "lam", "phi")  # Equilibrium fields of a forward root state


# a compression whose load lies within this angle (rad) of the beam's axis is perfect: the
# round-off of a load drawn along a beam that is itself drawn rotated, not an imperfection
PERFECT = 1e-12
PERFECT_COLUMN = (
    "perfect axial compression above the Euler load pi^2 EI/(4 L^2): bifurcation, "
    "no preferred buckling direction (add a transverse imperfection)"
)


def follower_equilibrium(L: float, EI: float, P: float, gamma: float, M: float) -> Equilibrium:
    """Exact state under a follower tip force (magnitude P at angle gamma to the tip tangent)
    and a tip moment M: the pendulum integrated backwards from the known tip state."""
    lam = math.sqrt(P / EI) if P > 0.0 else 0.0
    uL = math.pi - gamma if P > 0.0 else 0.0
    # backward arc length sb = L - s: ub(sb) = u(L - sb), ub'(0) = -u'(L) = -M/EI
    u0 = float(pendulum(uL, -M / EI, lam, float(L))[0])
    phi = math.pi - u0 if P > 0.0 else math.pi
    return Equilibrium(L=L, lam=lam, phi=phi, u_start=uL, p_start=-M / EI, reverse=True)


def _g_and_slope(z, e, c, zmax, lamL):  # noqa: ANN001, ANN202
    """G(z) = K(m) - F(psi*, m) - lam L and dG/dz, with t = 1 - m computed without cancellation.

    Arrays of one shape (one entry per load); ``e`` = zmax - z where known exactly (large-load
    regime), NaN elsewhere.  Returns G, dG/dz and s = sin psi*.
    """
    d2 = np.where(np.isnan(e), (zmax - z) * (zmax + z), e * (2.0 * zmax - e))  # zmax^2 - z^2
    s2 = c * c + d2  # sin^2 psi* = 1 - z^2
    s = np.sqrt(s2)
    t = d2 / s2  # 1 - m
    m = c * c / s2
    z2 = z * z
    K = elliprf(0.0, t, 1.0)
    F = s * elliprf(z2, zmax * zmax, 1.0)
    Dc = elliprd(0.0, t, 1.0) / 3.0
    Ds = s2 * s / 3.0 * elliprd(z2, zmax * zmax, 1.0)
    # dG/dz = (dK/dm - dF/dm) dm/dz + 1/(s Delta*), dm/dz / (2 t) = m z / d2
    slope = ((K - Dc) - (F - Ds - s * z / zmax)) * m * z / d2 + 1.0 / (s * zmax)
    return K - F - lamL, slope, s


def _safe_newton(f, x, lo, hi, increasing, lamL):  # noqa: ANN001, ANN202
    """Newton on monotone g(x) = f(x)[0], one root per entry of the arrays, each bracketed in
    (lo, hi) and increasing or not (``increasing``: bool array); bisection where a step leaves
    the bracket.  Returns (roots, iterations)."""
    its = np.full(x.shape, 60)
    active = np.ones(x.shape, dtype=bool)
    for it in range(1, 60):
        g, d = f(x)
        up = (g > 0.0) == increasing
        hi, lo = np.where(active & up, x, hi), np.where(active & ~up, x, lo)
        xn = x - g / d
        # the evaluated state meets the tolerance, or the correction is at round-off
        done = active & (
            (np.abs(g) <= 1e-15 * (1.0 + lamL)) | (np.abs(xn - x) <= 4e-16 * np.abs(x))
        )
        its[done] = it
        active &= ~done
        if not active.any():
            break
        x = np.where(active, np.where((lo < xn) & (xn < hi), xn, 0.5 * (lo + hi)), x)
    return x, its


def closed_form_dead(L: float, EI: float, fx: float, fy: float) -> tuple[Equilibrium, int]:
    """Exact cantilever under a dead tip force (beam frame, fx along the beam, tension +).

    Returns the ``Equilibrium`` of the fundamental (inflection-free) branch and the number of
    Newton iterations.  Raises ``ElasticaError`` for a perfect axial compression above the
    Euler load pi^2 EI / (4 L^2) (a bifurcation: no preferred buckling direction).
    """
    ((eq, its),) = closed_form_dead_path(L, EI, fx, fy, np.array([1.0]))
    if isinstance(eq, ElasticaError):
        raise eq
    return eq, its


def closed_form_dead_path(
    L: float, EI: float, fx: float, fy: float, factors: np.ndarray
) -> list[tuple[Equilibrium | ElasticaError, int]]:
    """``closed_form_dead`` at the loads t (fx, fy) for every t in ``factors`` (shape (n,)),
    all Newton solves at once (one array call per special function and iteration).

    Returns (Equilibrium or the ElasticaError of that load, Newton iterations) per factor.
    """
    t = np.asarray(factors, dtype=float)
    P = np.hypot(t * fx, t * fy)
    if not (L > 0.0 and EI > 0.0 and np.isfinite(P).all()):
        raise ElasticaError(f"bad input L={L}, EI={EI}, P={P.max()}")
    lam = np.sqrt(P / EI)
    phi = np.arctan2(t * fy, t * fx)
    u0 = math.pi - phi
    u0 = np.where(u0 > math.pi, u0 - 2.0 * math.pi, u0)  # (-pi, pi]
    c = np.abs(np.sin(0.5 * u0))
    zmax = np.abs(np.cos(0.5 * u0))
    lamL = lam * L
    # straight: no load, pure tension, or perfect compression (a bifurcation past Euler)
    straight = (P == 0.0) | (c <= PERFECT) | (zmax == 0.0) | (c == 1.0)
    bent = np.flatnonzero(~straight)
    z, e, its = np.zeros_like(t), np.full_like(t, np.nan), np.zeros(t.shape, dtype=int)
    if bent.size:
        cb, zb, lb = c[bent], zmax[bent], lamL[bent]
        half = 0.5 * zb
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            g_half, slope_half, _ = _g_and_slope(half, np.full_like(half, np.nan), cb, zb, lb)
            # G(zmax/2) >= 0: the root is in [0, zmax/2], Newton in z (G smooth and bounded
            # there); else in (zmax/2, zmax), Newton in y = ln(zmax - z) (G ~ -y/2 there).  One
            # Newton for both kinds of entries: one special-function call per iteration.
            isy = g_half < 0.0
            y0 = np.maximum(np.log(half) + g_half / (half * slope_half), -744.0)
            x0 = np.where(isy, y0, np.minimum(lb * zb, 0.5 * half))
            lo = np.where(isy, -745.0, 0.0)
            hi = np.where(isy, np.log(half), half)

            def gzy(x):  # noqa: ANN001, ANN202
                ey = np.where(isy, np.exp(np.where(isy, x, 0.0)), np.nan)
                g, d, _ = _g_and_slope(np.where(isy, zb - ey, x), ey, cb, zb, lb)
                return g, np.where(isy, -ey * d, d)

            x, its[bent] = _safe_newton(gzy, x0, lo, hi, ~isy, lb)
            eb = np.where(isy, np.exp(np.where(isy, x, 0.0)), np.nan)
            e[bent], z[bent] = eb, np.where(isy, zb - eb, x)
            # the residual and sin psi* at the roots
            g, _, sb = _g_and_slope(z[bent], eb, cb, zb, lb)
        ze = z[bent]
        d2 = np.where(isy, eb * (2.0 * zb - eb), (zb - ze) * (zb + ze))
        g_all, s_all, d2_all = (np.zeros_like(t) for _ in range(3))
        g_all[bent], s_all[bent], d2_all[bent] = g, sb, d2
    out: list[tuple[Equilibrium | ElasticaError, int]] = []
    for i in range(t.size):
        if P[i] == 0.0:
            eq = Equilibrium(L=L, lam=0.0, phi=math.pi, u_start=0.0, p_start=0.0)
        elif c[i] <= PERFECT and lamL[i] > 0.5 * math.pi * (1.0 + 1e-12):
            eq = ElasticaError(PERFECT_COLUMN)
        elif straight[i]:
            eq = Equilibrium(L=L, lam=float(lam[i]), phi=float(phi[i]), u_start=float(u0[i]),
                             p_start=0.0)  # fmt: skip
        elif not abs(g_all[i]) <= 1e-12 * max(1.0, lamL[i]):
            eq = ElasticaError(f"closed form did not converge (residual {g_all[i]:.3g})")
        else:
            si = float(s_all[i])
            # |u| grows from the root: inflection-free
            p0 = math.copysign(2.0 * float(lam[i]) * float(c[i]) / si * float(z[i]), u0[i])
            # 1 - m = d2 / s^2 rounds above 1 when m = c^2 / s^2 < eps (a column with a 1e-9
            # imperfection below Euler): a negative m makes every Jacobi function NaN
            m1 = min(float(d2_all[i]) / (si * si), 1.0)
            eq = Equilibrium(L=L, lam=float(lam[i]), phi=float(phi[i]), u_start=float(u0[i]),
                             p_start=p0, m1=m1)  # fmt: skip
        out.append((eq, int(its[i])))
    return out


def equilibrium(
    L: float,
    EI: float,
    fx: float,
    fy: float,
    m: float = 0.0,
    *,
    guided: bool = False,
    follower: bool = False,
) -> Equilibrium:
    """Exact state under tip loads (beam frame); raises ``ElasticaError`` if not reachable.

    Dead force only: closed form.  Follower force: explicit (angle to the tip tangent is
    atan2(fy, fx)).  Otherwise: shooting with load continuation from the unloaded beam.
    """
    if follower and not guided and (fx or fy):
        eq = follower_equilibrium(L, EI, math.hypot(fx, fy), math.atan2(fy, fx), m)
    elif m == 0.0 and not guided:
        eq = closed_form_dead(L, EI, fx, fy)[0]
    else:
        *_, (_, (u0, p0, lam, phi), _) = follow_path(L, EI, fx, fy, m, np.array([1.0]), guided)
        eq = Equilibrium(L=L, lam=lam, phi=phi, u_start=u0, p_start=p0)
    why = conditioning_issue(eq)
    if why:
        raise ElasticaError(why)
    return eq


def tip_dead_force(
    L: float, EI: float, fx: float, fy: float, m: float = 0.0
) -> tuple[float, float, float]:
    """Tip position and rotation (x, y, theta) in the beam frame under dead tip loads.

    Parameters
    ----------
    L, EI : length, flexural rigidity.
    fx, fy : tip force in the beam frame (fx along the undeformed beam, tension +).
    m : tip moment (counter-clockwise +).
    """
    return equilibrium(L, EI, fx, fy, m).tip()


def shape_under_tip_load(
    L: float,
    EI: float,
    fx: float,
    fy: float,
    m: float = 0.0,
    n: int = N_SHAPE,
    *,
    guided: bool = False,
    follower: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Deformed centre line (n, 2) (beam frame, equal arc-length spacing) and curvature (n,)."""
    eq = equilibrium(L, EI, fx, fy, m, guided=guided, follower=follower)
    _, kap, x, y, _ = eq.sample(np.linspace(0.0, L, n))
    return np.column_stack([x, y]), kap


def rollup(L: float, EI: float, M: float) -> tuple[float, float, float]:
    """Closed form under a pure end moment: a circular arc of curvature M/EI.

    Returns tip (x, y, theta) = (L sin a / a, L (1 - cos a) / a, a), a = M L / EI.
    """
    a = M * L / EI
    if a == 0.0:
        return L, 0.0, 0.0
    return L * math.sin(a) / a, L * 2.0 * math.sin(0.5 * a) ** 2 / a, a


class Elastica:
    """Exact inextensible elastica of a single clamped beam (free or guided tip)."""

    name = "elastica"
    OPTIONS: dict = {}  # no options
    card = ModelCard(
        name="elastica",
        family="elastica",
        summary="exact large-deflection Euler-Bernoulli beam (elliptic integrals / pendulum "
        "shooting); the reference for single-beam scenes",
        assumptions=(
            "inextensible, shear-rigid Euler-Bernoulli beam (EA and GA ignored: the axial "
            "stretch P/EA of the FE reference is not modelled)",
            "linear elastic moment-curvature law M = EI kappa, straight uniform beam",
            "one clamped end; tip free or guided (rotation held, translations free)",
            "loads at the tip only: dead force, moment, or follower force at a fixed angle to "
            "the tip tangent (follower + guided tip = dead force)",
            "load control along the fundamental path; limit and bifurcation points are "
            "reported as failures, not traced",
            "stability from Jacobi's conjugate-point test on the shooting derivative "
            "(follower loads are non-conservative: stability not assessed)",
        ),
        validity="exact for the inextensible elastica (equations met to ~1e-13 relative); "
        "strongly tensioned beams with sqrt(PL^2/EI) > 12 on a near-separatrix orbit are "
        "declined as failed; differs from a real beam by O(P/EA, t^2/L^2)",
        references=(
            "Bisshopp K.E., Drucker D.C. (1945) Large deflection of cantilever beams. "
            "Q. Appl. Math. 3:272-275",
            "Mattiasson K. (1981) Numerical results from large deflection beam and frame "
            "problems analysed by means of elliptic integrals. IJNME 17:145-153, "
            "doi 10.1002/nme.1620170113 (Table 1: cantilever with tip load)",
            "Howell L.L. (2001) Compliant Mechanisms, Wiley, ch. 5 (elliptic integral "
            "solutions, load-angle parameter n)",
            "Timoshenko S.P., Gere J.M. (1961) Theory of Elastic Stability, 2nd ed., Sec. 2.7 "
            "(post-buckled Euler elastica)",
            "Byrd P.F., Friedman M.D. (1971) Handbook of Elliptic Integrals; DLMF ch. 19, 22 "
            "(Jacobi functions, Carlson forms, derivatives in m)",
        ),
    )

    def applies_to(self, scene: Scene) -> str | None:
        """None for a single straight clamped beam loaded at its tip, else the reason."""
        beam = cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if not (beam.L > 0.0 and math.isfinite(beam.EI) and beam.EI > 0.0):
            return "the beam needs a positive length and finite positive E*I"
        return None

    # -- path -----------------------------------------------------------------------------
    def _states(self, beam: Cantilever, factors: np.ndarray):
        """Yield (factor, Equilibrium, iterations, stable, its ``ends()`` or None) along the
        load ramp."""
        L, EI = beam.L, beam.EI
        if beam.follower and not beam.guided and (beam.fx or beam.fy):
            P, gamma = math.hypot(beam.fx, beam.fy), math.atan2(beam.fy, beam.fx)
            for t in factors:
                yield float(t), follower_equilibrium(L, EI, t * P, gamma, t * beam.m), 0, None, None
        elif beam.guided or beam.m != 0.0:
            for t, (u0, p0, lam, phi), its in follow_path(
                L, EI, beam.fx, beam.fy, beam.m, factors, beam.guided
            ):
                # follow_path only accepts states with a positive shooting derivative
                eq = Equilibrium(L=L, lam=lam, phi=phi, u_start=u0, p_start=p0)
                yield t, eq, its, True, None
        else:
            path = closed_form_dead_path(L, EI, beam.fx, beam.fy, factors)
            # the tip states and the Jacobi test (the shooting derivative d kappa(L)/d kappa(0)
            # stays positive) of all states at once, up to the first that failed
            n = next((i for i, (eq, _) in enumerate(path) if isinstance(eq, ElasticaError)), None)
            eqs = [eq for eq, _ in path[:n]]
            u0, p0, lam, phi = (np.array([getattr(e, k) for e in eqs]) for k in _STATE)
            m1 = np.array([np.nan if e.m1 is None else e.m1 for e in eqs])
            uL, pL, A, B, U2, slope = tip_states(u0, p0, lam, L, m1)
            c, d = np.cos(phi), np.sin(phi)
            # theta(L), kappa(0), kappa(L), x(L), y(L), int kappa^2 (Equilibrium.ends)
            ends = zip(*(a.tolist() for a in (uL - u0, p0, pL, -A * c + B * d, -A * d - B * c, U2)))
            for t, (eq, its), stable, end in zip(
                factors, path, [*(slope > 0.0).tolist(), None], [*ends, None]
            ):
                if isinstance(eq, ElasticaError):
                    raise eq
                yield float(t), eq, its, stable, end

    def _step(
        self, beam: Cantilever, t: float, eq: Equilibrium, its: int, stable: bool,
        ends: tuple | None, outputs_of: Callable[[float, float, float], dict], Et: float | None,
    ) -> Step:  # fmt: skip
        """One Step; ``ends`` = ``eq.ends()`` when already computed, ``outputs_of`` the scene's
        output map, ``Et`` = E t of the member (None: no stress), looked up once per solve."""
        th, k0, kL, x, y, U2 = eq.ends() if ends is None else ends
        outputs = outputs_of(x, y, th)
        kmax = eq.max_abs_curvature(abs(k0 if eq.reverse else kL))
        if beam.guided:
            residual = abs(th)
        else:
            kL_load = t * beam.m / beam.EI
            residual = abs(kL - kL_load) / max(abs(k0) + abs(kL_load) + eq.lam, 1e-300)
        return Step(
            factor=t,
            outputs=outputs,
            energy=0.5 * beam.EI * U2,
            iterations=its,
            stable=stable,
            shapes=SampledShape(beam, eq),
            max_stress=None if Et is None else float(Et * kmax / 2.0),  # E t |kappa| / 2
            info={"root_curvature": k0, "tip_residual": residual},
        )

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of the scene's load ramp (``load``; ``path`` = load ramp with
        ``max_steps`` increments, stopping once ``stop_output`` passes ``stop_value``)."""
        why = self.applies_to(scene)
        if why is not None:
            return not_applicable(scene, self.name, why)
        beam = cantilever_of(scene)
        a = scene.analysis
        if a.kind == "path":
            factors = np.linspace(0.0, a.factor_end, a.max_steps + 1)
        else:
            factors = load_factors(scene)
        steps: list[Step] = []
        start = None
        outputs_of = output_map(scene, beam)  # output keys and frames looked up once
        mem = scene.member(beam.member)
        Et = None if mem.thickness is None or mem.E is None else mem.E * mem.thickness
        try:
            for t, eq, its, stable, ends in self._states(beam, factors):
                why = conditioning_issue(eq)
                if why:
                    raise ElasticaError(f"at factor {t:.6g}: {why}")
                step = self._step(beam, t, eq, its, stable, ends, outputs_of, Et)
                steps.append(step)
                if a.kind == "path" and a.stop_output and a.stop_value is not None:
                    # stop at the first step on the other side of stop_value than step 0
                    gap = step.outputs.get(a.stop_output, math.nan) - a.stop_value
                    if start is None:
                        start = gap if gap != 0.0 else None
                    elif gap == 0.0 or (gap > 0.0) != (start > 0.0):
                        break
        except ElasticaError as exc:
            return Solution(scene.name, self.name, "failed", str(exc), tuple(steps))
        kind = (
            "follower (explicit)"
            if beam.follower and not beam.guided and (beam.fx or beam.fy)
            else "shooting + continuation"
            if beam.guided or beam.m != 0.0
            else "elliptic closed form"
        )
        return Solution(
            scene.name, self.name, "converged", f"{kind}, {len(steps)} steps", tuple(steps)
        )
