"""Verification of the ``elastica`` model against independent exact and published values.

Every reference below is computed here from its own formula (Bisshopp-Drucker elliptic
integrals, the circular arc, a quadrature of the follower-load first integral, Euler's
post-buckled elastica, linear imperfect-column theory, a DOP853 integration of the ODE) or taken
from a published table; nothing is compared with numbers the model produced earlier.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import cases
from reduced_models.beam.elastica import (
    Elastica,
    ElasticaError,
    closed_form_dead,
    equilibrium,
    rollup,
    shape_under_tip_load,
    tip_dead_force,
)
from reduced_models.beam.elastica_bvp import ElasticaBVP
from reduced_models.beam.elastica_shooting import follow_path

PCR = math.pi**2 / 4.0  # cantilever Euler load, EI = L = 1


def scene(
    fx=0.0,
    fy=0.0,
    moment=0.0,
    *,
    follower=False,
    guided=False,
    steps=4,
    analysis="",
    angle_deg=0.0,
    L=1.0,
    member="E = 1.0\nI = 1.0\nA = 1.0e4\nthickness = 0.034641",
):
    """A single clamped beam as case TOML, loaded through the validated loader."""
    a = math.radians(angle_deg)
    bx, by = L * math.cos(a), L * math.sin(a)
    guided_txt = '\n[[supports]]\nnode = "B"\ntype = "guided"\n' if guided else ""
    analysis = analysis or f'kind = "load"\nsteps = {steps}'
    text = f"""
[case]
name = "t"
title = "t"
units = "nondim"
[[nodes]]
id = "A"
x = 0.0
y = 0.0
[[nodes]]
id = "B"
x = {bx!r}
y = {by!r}
[[members]]
id = "beam"
from = "A"
to = "B"
kind = "flexible"
{member}
[[supports]]
node = "A"
type = "clamp"
{guided_txt}
[[loads]]
node = "B"
fx = {fx!r}
fy = {fy!r}
moment = {moment!r}
follower = {"true" if follower else "false"}
[analysis]
{analysis}
[[outputs]]
name = "tip"
node = "B"
"""
    return cases.loads(text)


def bisshopp_drucker(a):
    """Cantilever (L = EI = 1) under a downward tip load P = a: (x_tip, deflection, tip angle).

    Bisshopp & Drucker (1945): sqrt(a) = K(k) - F(phi1, k), k^2 = (1 + sin t0)/2,
    sin phi1 = 1/(sqrt 2 k); x = sqrt(2 sin t0 / a); delta = 1 - 2 (E(k) - E(phi1, k))/sqrt a.
    """
    lamL = math.sqrt(a)

    def parts(t0):
        m = (1.0 + math.sin(t0)) / 2.0
        return m, math.asin(1.0 / math.sqrt(2.0 * m))

    def g(t0):
        m, ph = parts(t0)
        return ellipk(m) - ellipkinc(ph, m) - lamL

    t0 = brentq(g, 1e-9, math.pi / 2 - 1e-12, xtol=1e-16, rtol=1e-15)
    m, ph = parts(t0)
    return (
        math.sqrt(2.0 * math.sin(t0) / a),
        1.0 - 2.0 * (ellipe(m) - ellipeinc(ph, m)) / lamL,
        t0,
    )


# -- closed form: Bisshopp-Drucker and Mattiasson -------------------------------------------
@pytest.mark.parametrize("a", [0.5, 1.0, 2.0, 5.0, 10.0, 20.0])
def test_vertical_load_matches_bisshopp_drucker(a):
    x, y, th = tip_dead_force(1.0, 1.0, 0.0, -a)
    xr, dr, tr = bisshopp_drucker(a)
    assert x == pytest.approx(xr, rel=1e-9)
    assert -y == pytest.approx(dr, rel=1e-9)
    assert -th == pytest.approx(tr, rel=1e-9)


def test_scaling_with_length_and_rigidity():
    # P L^2/EI = 2 with L = 3, EI = 7: lengths scale with L, the angle is invariant
    x, y, th = tip_dead_force(3.0, 7.0, 0.0, -2.0 * 7.0 / 9.0)
    xr, dr, tr = bisshopp_drucker(2.0)
    assert (x / 3.0, -y / 3.0, -th) == pytest.approx((xr, dr, tr), rel=1e-9)


# Mattiasson (1981) IJNME 17:145, Table 1: PL^2/EI -> (u/L = 1 - x/L, v/L, tip angle rad).
# (For PL^2/EI = 5 only the two displacements are used.)
MATTIASSON = {
    1.0: (0.05643, 0.30172, 0.46135),
    2.0: (0.16064, 0.49346, 0.78175),
    5.0: (0.38763, 0.71379, None),
    10.0: (0.55500, 0.81061, 1.43029),
}


@pytest.mark.parametrize("a", sorted(MATTIASSON))
def test_mattiasson_table(a):
    x, y, th = tip_dead_force(1.0, 1.0, 0.0, -a)
    u, v, phi = MATTIASSON[a]
    assert 1.0 - x == pytest.approx(u, abs=6e-6)  # 5 printed digits
    assert -y == pytest.approx(v, abs=6e-6)
    if phi is not None:
        assert -th == pytest.approx(phi, abs=6e-6)


# inclined loads: tension, Howell n = 1 compression, near-axial compression, far past 90 deg
INCLINED = [(7.0710678, -7.0710678), (-5.0, -5.0), (2.0, 3.0), (-9.0, 0.5), (-20.0, -1.0),
            (-2.0 * PCR, 2e-3 * PCR), (0.3, -0.01)]  # fmt: skip


@pytest.mark.parametrize("fx,fy", INCLINED)
def test_closed_form_agrees_with_shooting(fx, fy):
    """Two algorithms: root in the modulus (closed form) vs Newton on the root curvature with
    load continuation (shooting)."""
    eq, _ = closed_form_dead(1.0, 1.0, fx, fy)
    *_, (_, (u0, p0, lam, phi), _) = follow_path(1.0, 1.0, fx, fy, 0.0, np.linspace(0, 1, 11))
    assert p0 == pytest.approx(eq.p_start, rel=1e-9, abs=1e-12)
    shot = equilibrium(1.0, 1.0, fx, fy, 1e-300)  # a (negligible) moment forces the shooting
    assert np.allclose(shot.tip(), eq.tip(), rtol=0.0, atol=1e-9)


def ode_tip(p0, fx, fy, L=1.0, EI=1.0, phi_of_tip=None):
    """Integrate theta'' = (fx sin theta - fy cos theta)/EI from the root (DOP853, 1e-13)."""

    def rhs(s, z):
        th, k = z[0], z[1]
        return [k, (fx * math.sin(th) - fy * math.cos(th)) / EI, math.cos(th), math.sin(th)]

    sol = solve_ivp(rhs, (0.0, L), [0.0, p0, 0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14)
    return sol.y[:, -1]


@pytest.mark.parametrize(
    "fx,fy,m,guided",
    [(0.0, -5.0, 8.0, False), (-5.0, 0.0, 3.0, False), (30.0, 0.0, 0.5, False),
     (3.0, -4.0, -2.0, False), (0.0, -20.0, 0.0, True), (-4.0, 6.0, 0.0, True)],
)  # fmt: skip
def test_shooting_satisfies_the_ode(fx, fy, m, guided):
    """The exact elliptic flow against a DOP853 integration from the same root curvature, and
    the tip boundary condition met to 1e-9."""
    eq = equilibrium(1.0, 1.0, fx, fy, m, guided=guided)
    th, k, x, y = ode_tip(eq.p_start, fx, fy)
    xt, yt, tht = eq.tip()
    assert (xt, yt, tht) == pytest.approx((x, y, th), abs=1e-9)
    if guided:
        assert abs(th) < 1e-9
    else:
        assert k == pytest.approx(m, abs=1e-9 * (1.0 + abs(m)))


@pytest.mark.parametrize("lamL", [6.0, 10.0])
def test_tension_with_small_end_moment_matches_linear_theory(lamL):
    """Axial tension P = lamL^2 plus end moment M = 1e-3 (near the pendulum separatrix: needs
    the 1 - m accurate Jacobi functions).  Linear theory EI theta'' = P theta:
    theta_L = M tanh(lam L)/(lam EI), y_L = M (1 - 1/cosh(lam L))/P; corrections O(M^2)."""
    M = 1e-3
    sol = Elastica().solve(scene(fx=lamL**2, moment=M, steps=4))
    assert sol.status == "converged", sol.message
    o = sol.steps[-1].outputs
    assert o["tip.rot"] == pytest.approx(M * math.tanh(lamL) / lamL, rel=1e-6)
    assert o["tip.uy"] == pytest.approx(M * (1.0 - 1.0 / math.cosh(lamL)) / lamL**2, rel=1e-6)


def test_strong_tension_beyond_validated_range_fails():
    sol = Elastica().solve(scene(fx=400.0, moment=1e-2, steps=4))
    assert sol.status == "failed" and "separatrix" in sol.message
    with pytest.raises(ElasticaError, match="separatrix"):
        tip_dead_force(1.0, 1.0, 400.0, 0.4)


# -- roll-up under an end moment --------------------------------------------------------------
@pytest.mark.parametrize("a", [math.pi / 2, math.pi, 2 * math.pi])
def test_rollup_closed_form_and_model(a):
    L, EI = 2.0, 3.0
    M = a * EI / L
    ref = (L * math.sin(a) / a, L * (1.0 - math.cos(a)) / a, a)
    assert rollup(L, EI, M) == pytest.approx(ref, abs=1e-12)
    sol = Elastica().solve(scene(moment=a, steps=4))  # L = EI = 1 scene
    assert sol.status == "converged"
    o = sol.steps[-1].outputs
    assert (o["tip.x"], o["tip.y"], o["tip.rot"]) == pytest.approx(
        (math.sin(a) / a, (1.0 - math.cos(a)) / a, a), abs=1e-12
    )
    assert sol.steps[-1].energy == pytest.approx(a * a / 2.0, rel=1e-12)  # M^2 L / (2 EI)


def test_full_circle_shape_is_a_circle():
    xy, kap = shape_under_tip_load(1.0, 1.0, 0.0, 0.0, 2 * math.pi, n=41)
    r = 1.0 / (2 * math.pi)
    assert np.allclose(np.hypot(xy[:, 0], xy[:, 1] - r), r, atol=1e-12)
    assert np.allclose(kap, 2 * math.pi, rtol=1e-12)


# -- follower force ---------------------------------------------------------------------------
def follower_normal_reference(P):
    """Follower force P staying normal to the tip (pushing 'down'), L = EI = 1.

    First integral: theta'^2 / 2 = P sin(theta - theta_L), so with b = theta - theta_L,
    sqrt(2P) = int_0^T db / sqrt(sin b) (T = -theta_L) and x, y = int (cos, sin)(b - T) ds.
    Substituting b = v^2 removes the end singularity.
    """

    def integral(T, f):
        g = lambda v: 2.0 * v * f(v * v) / math.sqrt(math.sin(v * v))  # noqa: E731
        return quad(g, 0.0, math.sqrt(T), epsabs=1e-13, epsrel=1e-12, limit=200)[0]

    T = brentq(lambda T: integral(T, lambda b: 1.0) - math.sqrt(2.0 * P), 1e-6, 3.0, xtol=1e-15)
    x = integral(T, lambda b: math.cos(b - T)) / math.sqrt(2.0 * P)
    y = integral(T, lambda b: math.sin(b - T)) / math.sqrt(2.0 * P)
    return x, y, -T


@pytest.mark.parametrize("P", [1.0, 3.0, 6.0])
def test_follower_force_against_first_integral(P):
    sol = Elastica().solve(scene(fy=-P, follower=True, steps=2))
    assert sol.status == "converged"
    o = sol.steps[-1].outputs
    assert (o["tip.x"], o["tip.y"], o["tip.rot"]) == pytest.approx(
        follower_normal_reference(P), abs=1e-9
    )


def test_follower_keeps_its_angle_to_the_tip():
    # inclined follower force (angle 120 deg to the tip tangent) + a moment: the explicit
    # solution must satisfy the ODE with phi = theta_L + gamma and kappa(L) = M/EI
    P, gamma, M = 4.0, math.radians(120.0), 0.7
    eq = equilibrium(1.0, 1.0, P * math.cos(gamma), P * math.sin(gamma), M, follower=True)
    x, y, thL = eq.tip()
    phi = thL + gamma
    th, k, xo, yo = ode_tip(eq.root_curvature(), P * math.cos(phi), P * math.sin(phi))
    assert (xo, yo, th, k) == pytest.approx((x, y, thL, M), abs=1e-9)


# -- Euler buckling ---------------------------------------------------------------------------
def test_imperfect_column_below_euler_load_follows_linear_amplification():
    # lateral tip force H = eps P on a column under P < Pcr: y = eps (tan(lam L)/lam - L) + O(eps^3)
    eps = 1e-6
    for ratio in (0.3, 0.7, 0.95):
        P = ratio * PCR
        lam = math.sqrt(P)
        x, y, th = tip_dead_force(1.0, 1.0, -P, eps * P)
        assert y == pytest.approx(eps * (math.tan(lam) / lam - 1.0), rel=1e-5)
        assert abs(th) < 1e-3


def euler_tip_angle(ratio):
    """Post-buckled Euler elastica: P/Pcr = (2 K(k)/pi)^2, tip angle = 2 asin k."""
    k2 = brentq(lambda m: (2.0 * ellipk(m) / math.pi) ** 2 - ratio, 0.0, 1.0 - 1e-15, xtol=1e-16)
    return 2.0 * math.asin(math.sqrt(k2))


def test_post_buckling_tends_to_euler_elastica_as_imperfection_vanishes():
    for ratio in (1.2, 1.5, 2.0):
        ref = euler_tip_angle(ratio)
        errs = []
        for eps in (1e-3, 1e-4, 1e-5):
            th = tip_dead_force(1.0, 1.0, -ratio * PCR, eps * ratio * PCR)[2]
            errs.append(abs(th - ref))
        assert errs[-1] < 1e-4 * ref
        # first order in the imperfection: each 10x smaller eps gives ~10x smaller error
        assert 7.0 < errs[0] / errs[1] < 13.0 and 7.0 < errs[1] / errs[2] < 13.0


def test_imperfect_column_path_does_not_jump():
    """Ramp to 2 Pcr with eps = 1e-2 (catalog-like): the tip rotation grows monotonically on the
    imperfection's side, the deflection stays small below Pcr and is large above."""
    for m_imperf in (0.0, 1e-3):  # closed form (force imperfection) and shooting (moment)
        fy = 1e-2 * 2 * PCR if m_imperf == 0.0 else 0.0
        sol = Elastica().solve(scene(fx=-2 * PCR, fy=fy, moment=m_imperf, steps=40))
        assert sol.status == "converged", sol.message
        rot = sol.path("tip.rot")
        assert np.all(np.diff(rot) > 0.0)
        f = sol.path("factor")
        assert np.all(rot[f <= 0.4] < 0.1)  # P <= 0.8 Pcr
        assert rot[-1] == pytest.approx(euler_tip_angle(2.0), rel=0.05)
        assert all(s.stable for s in sol.steps[1:])


# -- guided tip: symmetry gives the exact answer -------------------------------------------------
@pytest.mark.parametrize("F", [2.0, 6.0, 20.0])
def test_guided_beam_is_two_half_cantilevers(F):
    """A fixed-guided beam under a transverse tip force bends antisymmetrically: each half is a
    cantilever of length L/2 under the same force (Bisshopp-Drucker with PL^2/EI = F/4)."""
    sol = Elastica().solve(scene(fy=-F, guided=True, steps=4))
    assert sol.status == "converged"
    xr, dr, _ = bisshopp_drucker(F / 4.0)
    o = sol.steps[-1].outputs
    assert o["tip.x"] == pytest.approx(xr, rel=1e-9)  # 2 * (L/2) * x/L
    assert -o["tip.y"] == pytest.approx(dr, rel=1e-9)
    assert o["tip.rot"] == pytest.approx(0.0, abs=1e-9)


# -- model-level outputs: frame, shape, energy, stress ---------------------------------------------
def test_model_outputs_energy_and_stress_for_a_rotated_beam():
    a, ang = 2.0, 30.0  # PL^2/EI, beam drawn at 30 deg; load perpendicular to it
    c, s = math.cos(math.radians(ang)), math.sin(math.radians(ang))
    sol = Elastica().solve(scene(fx=a * s, fy=-a * c, steps=2, angle_deg=ang))
    assert sol.status == "converged"
    st = sol.steps[-1]
    xr, dr, tr = bisshopp_drucker(a)
    gx, gy = c * xr + s * dr, s * xr - c * dr  # beam-frame (x, -delta) rotated by 30 deg
    assert (st.outputs["tip.x"], st.outputs["tip.y"]) == pytest.approx((gx, gy), abs=1e-9)
    assert st.outputs["tip.rot"] == pytest.approx(-tr, abs=1e-9)
    shape = st.shapes["beam"]
    assert shape.shape == (41, 2)
    assert np.allclose(shape[0], 0.0, atol=1e-15) and np.allclose(shape[-1], (gx, gy), atol=1e-12)
    # strain energy: int M^2/(2 EI) ds = int_0^t0 sqrt(P/2) sqrt(sin t0 - sin t) dt
    U = quad(lambda t: math.sqrt(a / 2.0 * (math.sin(tr) - math.sin(t))), 0.0, tr, epsabs=1e-14)[0]
    assert st.energy == pytest.approx(U, rel=1e-9)
    # largest moment at the root: P * x_tip; stress = E t kappa / 2
    assert st.max_stress == pytest.approx(0.034641 * a * xr / 2.0, rel=1e-9)


def test_path_analysis_stops_after_passing_the_stop_value():
    sol = Elastica().solve(
        scene(fy=-10.0, analysis='kind = "path"\nstop_output = "tip.uy"\nstop_value = -0.5\n'
              "factor_end = 1.0\nmax_steps = 100")
    )  # fmt: skip
    uy = sol.path("tip.uy")
    assert sol.status == "converged"
    assert uy[-1] <= -0.5 < uy[-2]
    assert sol.steps[-1].factor < 0.5
    # without factor_end the path contract asks for tracing on: a load ramp declines
    sol = Elastica().solve(
        scene(fy=-10.0, analysis='kind = "path"\nstop_output = "tip.uy"\nstop_value = -0.5\n'
              "max_steps = 100")
    )  # fmt: skip
    assert sol.status == "not-applicable" and "factor_end" in sol.message


# -- failure honesty --------------------------------------------------------------------------
def test_perfect_column_past_euler_load_fails_with_reason():
    sol = Elastica().solve(scene(fx=-2 * PCR, steps=8))
    assert sol.status == "failed"
    assert "Euler" in sol.message and "bifurcation" in sol.message
    f = sol.path("factor")
    assert f.max() <= 0.5 + 1e-12 and len(f) == 5  # up to and including P = Pcr
    assert np.allclose(sol.path("tip.uy"), 0.0)
    with pytest.raises(ElasticaError):
        tip_dead_force(1.0, 1.0, -1.01 * PCR, 0.0)


def test_guided_column_past_its_euler_load_fails():
    sol = Elastica().solve(scene(fx=-2 * math.pi**2, guided=True, steps=8))  # Pcr = pi^2 EI/L^2
    assert sol.status == "failed"
    assert "limit or bifurcation" in sol.message
    assert sol.path("factor").max() <= 0.5 + 1e-12


def test_limit_point_is_reported_not_jumped():
    """Upward tip force + opposing moment: the shooting derivative falls to zero near factor
    0.929 (a fold of the load path).  Load control must stop there, not jump branches."""
    sol = Elastica().solve(scene(fy=10.0, moment=-10.0, steps=20))
    assert sol.status == "failed"
    assert "beyond factor 0.92" in sol.message
    assert sol.steps[-1].factor == pytest.approx(0.9)
    assert all(s.stable for s in sol.steps[1:])


def test_not_applicable_reason():
    one = scene(fy=-1.0)
    two = dataclasses.replace(one, members=one.members * 2)
    why = Elastica().applies_to(two)
    assert why and "single" in why
    sol = Elastica().solve(two)
    assert sol.status == "not-applicable" and sol.message == why


# -- solve_bvp baseline -----------------------------------------------------------------------
def test_bvp_baseline_matches_bisshopp_drucker():
    sol = ElasticaBVP().solve(scene(fy=-2.0, steps=2))
    assert sol.status == "converged"
    xr, dr, tr = bisshopp_drucker(2.0)
    o = sol.steps[-1].outputs
    assert (o["tip.x"], -o["tip.y"], -o["tip.rot"]) == pytest.approx((xr, dr, tr), rel=1e-8)
