"""Verification of the scikit-fem Reissner beam (fem_reference/reissner.py).

Against closed forms computed here, independently of the solver:

* roll-up under an end moment: circle of radius EI/M, tip (L sin(phi)/phi, L(1-cos phi)/phi),
  energy M^2 L / (2 EI) -- exact for any EA, GA (no axial or shear force arises);
* Bisshopp & Drucker (1945) elliptic-integral cantilever under a dead tip load, checked
  itself against Mattiasson (1981, doi:10.1002/nme.1620170113, Table 1);
* a follower tip force that stays normal to the tip section: the pendulum equation
  phi'' = (P/EI) cos(phi) integrated once, its quadratures by scipy.integrate.quad;
* linear Timoshenko cantilever tip deflection P L^3/(3 EI) + P L/GA (shear flexibility).

Observed h-convergence orders are fitted and asserted (P1 one-point: 2, P2 two-point: 4), the
consistent tangent is compared with a finite-difference Jacobian (dead and follower loads),
and the reduced quadrature is shown to matter (full integration locks).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from fem_reference.reissner import ReissnerBeam, solve_cantilever

INF = math.inf


# --- closed forms ----------------------------------------------------------------------------


def rollup(phi: float, s: np.ndarray) -> np.ndarray:
    """Points (len(s), 2) of a unit cantilever rolled up by the end moment M = phi EI / L."""
    return np.column_stack([np.sin(phi * s) / phi, (1.0 - np.cos(phi * s)) / phi])


def bisshopp_drucker(alpha: float) -> tuple[float, float, float]:
    """Unit cantilever, dead downward tip load alpha = P L^2 / EI: (x_tip, y_tip, rot_tip).

    With the tip angle psi0 and the modulus k^2 = (1 + sin psi0)/2, sin(phi1) = 1/(k sqrt 2):
    sqrt(alpha) = K(k) - F(phi1, k), delta/L = 1 - 2/sqrt(alpha) (E(k) - E(phi1, k)) and,
    from the first integral, x/L = sqrt(2 sin(psi0) / alpha).
    """

    def k2_phi1(psi0: float) -> tuple[float, float]:
        k2 = 0.5 * (1.0 + math.sin(psi0))
        return k2, math.asin(1.0 / math.sqrt(2.0 * k2))

    def gap(psi0: float) -> float:
        k2, phi1 = k2_phi1(psi0)
        return ellipk(k2) - ellipkinc(phi1, k2) - math.sqrt(alpha)

    psi0 = brentq(gap, 1e-12, 0.5 * math.pi - 1e-15, xtol=1e-15)
    k2, phi1 = k2_phi1(psi0)
    delta = 1.0 - 2.0 / math.sqrt(alpha) * (ellipe(k2) - ellipeinc(phi1, k2))
    return math.sqrt(2.0 * math.sin(psi0) / alpha), -delta, -psi0


def follower_normal(alpha: float) -> tuple[float, float, float]:
    """Unit cantilever, tip force alpha EI/L^2 kept normal to the tip section (initially +y).

    phi = theta_tip - theta obeys phi'' = alpha cos(phi), phi(L) = phi'(L) = 0, hence
    phi'^2 / 2 = alpha sin(phi) and sqrt(2 alpha) = int_0^theta_tip dphi / sqrt(sin phi);
    x_tip, y_tip follow from int cos(theta_tip - phi) ds (and sin) in closed form plus
    J = int_0^theta_tip sqrt(sin phi) dphi.  Valid for theta_tip < pi (alpha < 13.7).
    """

    def length_integral(theta_tip: float) -> float:
        # phi = t^2 removes the 1/sqrt singularity at phi = 0
        def f(t: float) -> float:
            return 2.0 * t / math.sqrt(math.sin(t * t)) if t > 0 else 2.0

        return quad(f, 0.0, math.sqrt(theta_tip), epsabs=1e-14, epsrel=1e-13)[0]

    th = brentq(lambda t: length_integral(t) - math.sqrt(2 * alpha), 1e-9, 3.0, xtol=1e-15)
    J = quad(lambda p: math.sqrt(math.sin(p)), 0.0, th, epsabs=1e-14, epsrel=1e-13)[0]
    k = math.sqrt(2.0 * alpha)
    root = 2.0 * math.sqrt(math.sin(th))
    return (
        (math.cos(th) * root + math.sin(th) * J) / k,
        (math.sin(th) * root - math.cos(th) * J) / k,
        th,
    )


def fitted_order(n: list[int], err: list[float]) -> float:
    """Least-squares slope of log(err) against log(1/n)."""
    return float(-np.polyfit(np.log(n), np.log(err), 1)[0])


def tip_error(r, exact: tuple[float, float, float]) -> float:
    return max(abs(r.tip_x - exact[0]), abs(r.tip_y - exact[1]), abs(r.tip_rot - exact[2]))


# --- the closed forms themselves -------------------------------------------------------------


# Mattiasson (1981) Table 1: PL^2/EI -> (u/L, v/L, tip angle), 5 digits
MATTIASSON = {1.0: (0.05643, 0.30172, 0.46135), 10.0: (0.55500, 0.81061, 1.43029)}


def test_bisshopp_drucker_matches_published_table():
    for alpha, (u, v, th) in MATTIASSON.items():
        x, y, rot = bisshopp_drucker(alpha)
        assert abs((1.0 - x) - u) < 1e-5
        assert abs(-y - v) < 1e-5
        assert abs(-rot - th) < 1e-5


def test_follower_closed_form_small_load_is_linear():
    # alpha -> 0: the follower and the dead load agree with P L^2/(2EI), P L^3/(3EI)
    x, y, th = follower_normal(1e-4)
    assert y == pytest.approx(1e-4 / 3.0, rel=1e-3)
    assert th == pytest.approx(1e-4 / 2.0, rel=1e-3)
    assert x == pytest.approx(1.0, abs=1e-7)


# --- roll-up ---------------------------------------------------------------------------------


@pytest.mark.parametrize("phi", [0.5 * math.pi, math.pi, 2.0 * math.pi])
def test_rollup_p1_order_two(phi):
    ns, errs = [4, 8, 16, 32], []
    for n in ns:
        r = solve_cantilever(1.0, 1.0, 1e4, 1e4, 0.0, 0.0, phi, n, 4, degree=1)
        assert r.converged, r.message
        # tip rotation is exact (theta is linear in s and P1 holds it)
        assert r.tip_rot == pytest.approx(phi, abs=1e-9)
        s = np.linspace(0.0, 1.0, n + 1)
        errs.append(np.max(np.hypot(*(r.shape - rollup(phi, s)).T)))
    order = fitted_order(ns, errs)
    assert abs(order - 2.0) < 0.2, (errs, order)
    assert errs[-1] < 1e-3


@pytest.mark.parametrize("phi", [0.5 * math.pi, math.pi, 2.0 * math.pi])
def test_rollup_p2_order_four_and_energy(phi):
    ns, errs = [4, 8, 16], []
    for n in ns:
        # soft EA, GA on purpose: under a pure moment the Reissner answer does not depend on them
        r = solve_cantilever(2.0, 3.0, 50.0, 20.0, 0.0, 0.0, phi * 3.0 / 2.0, n, 4)
        assert r.converged, r.message
        s = np.linspace(0.0, 1.0, n + 1)
        errs.append(np.max(np.hypot(*(r.shape / 2.0 - rollup(phi, s)).T)))
        assert r.energy == pytest.approx((phi * 1.5) ** 2 * 2.0 / (2 * 3.0), rel=1e-9)
    order = fitted_order(ns, errs)
    assert abs(order - 4.0) < 0.3, (errs, order)
    assert errs[-1] < 1e-5


# --- dead tip load: elliptic integrals -------------------------------------------------------


@pytest.mark.parametrize("alpha", [1.0, 3.0, 10.0])
def test_cantilever_dead_load_p1_order_two(alpha):
    exact = bisshopp_drucker(alpha)
    ns = [8, 16, 32]
    errs = []
    for n in ns:
        r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -alpha, 0.0, n, 10, degree=1)
        assert r.converged, r.message
        errs.append(tip_error(r, exact))
    order = fitted_order(ns, errs)
    assert abs(order - 2.0) < 0.2, (errs, order)
    assert errs[-1] < 5e-4


@pytest.mark.parametrize("alpha", [1.0, 3.0, 10.0])
def test_cantilever_dead_load_p2(alpha):
    exact = bisshopp_drucker(alpha)
    ns = [4, 8]
    errs = []
    for n in ns:
        r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -alpha, 0.0, n, 10)
        assert r.converged, r.message
        errs.append(tip_error(r, exact))
    assert abs(fitted_order(ns, errs) - 4.0) < 0.4, errs
    # 16 elements: at the ~1e-8 alpha floor of the shear/axial penalty (module docstring)
    r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -alpha, 0.0, 16, 10)
    assert tip_error(r, exact) < 2e-6


def test_scaling_with_length_and_stiffness():
    # same alpha = P L^2 / EI on L = 2.5, EI = 7: positions scale with L, rotation unchanged
    exact = bisshopp_drucker(3.0)
    L, EI = 2.5, 7.0
    r = solve_cantilever(L, EI, INF, INF, 0.0, -3.0 * EI / L**2, 0.0, 16, 10)
    assert r.converged
    assert r.tip_x / L == pytest.approx(exact[0], abs=2e-6)
    assert r.tip_y / L == pytest.approx(exact[1], abs=2e-6)
    assert r.tip_rot == pytest.approx(exact[2], abs=2e-6)


# --- follower load ---------------------------------------------------------------------------


@pytest.mark.parametrize("alpha", [1.0, 3.0])
def test_follower_normal_tip_force(alpha):
    exact = follower_normal(alpha)
    ns, errs = [8, 16, 32], []
    for n in ns:
        r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, alpha, 0.0, n, 10, follower=True, degree=1)
        assert r.converged, r.message
        errs.append(tip_error(r, exact))
    assert abs(fitted_order(ns, errs) - 2.0) < 0.2, errs
    r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, alpha, 0.0, 16, 10, follower=True)
    assert tip_error(r, exact) < 2e-6
    # and it is not the dead-load answer (the test would catch a follower flag ignored)
    dead = solve_cantilever(1.0, 1.0, INF, INF, 0.0, alpha, 0.0, 16, 10)
    assert abs(dead.tip_rot - exact[2]) > 1e-2


# --- shear, locking, tangent, bookkeeping ----------------------------------------------------


def test_timoshenko_shear_flexibility_small_load():
    L, EI, GA, P = 1.0, 1.0, 20.0, 1e-6  # EI/(GA L^2) = 0.05: shear adds 15 %
    r = solve_cantilever(L, EI, 1e6, GA, 0.0, P, 0.0, 8, 1)
    assert r.tip_y == pytest.approx(P * L**3 / (3 * EI) + P * L / GA, rel=1e-5)
    # the shear-rigid limit recovers Euler-Bernoulli
    r = solve_cantilever(L, EI, INF, INF, 0.0, P, 0.0, 8, 1)
    assert r.tip_y == pytest.approx(P * L**3 / (3 * EI), rel=1e-6)


def test_reduced_quadrature_prevents_locking():
    exact = bisshopp_drucker(1.0)
    reduced = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -1.0, 0.0, 8, 5, degree=1)
    full = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -1.0, 0.0, 8, 5, degree=1, intorder=2)
    assert tip_error(reduced, exact) < 2e-3
    assert tip_error(full, exact) > 0.1  # locked: the penalised shear stiffens the element


@pytest.mark.parametrize("follower", [False, True])
def test_tangent_matches_finite_differences(follower):
    beam = ReissnerBeam(1.3, 2.0, 300.0, 150.0, 5, degree=2)
    rng = np.random.default_rng(7)
    x = 0.3 * rng.standard_normal(beam.basis.N)
    f0, m, lam = np.array([0.7, -1.1]), 0.4, 0.8
    r0, K = beam.residual_and_tangent(x, lam, f0, m, follower)
    K = K.toarray()
    h = 1e-6
    J = np.empty_like(K)
    for j in range(beam.basis.N):
        e = np.zeros_like(x)
        e[j] = h
        rp, _ = beam.residual_and_tangent(x + e, lam, f0, m, follower)
        rm, _ = beam.residual_and_tangent(x - e, lam, f0, m, follower)
        J[:, j] = (rp - rm) / (2 * h)
    assert np.max(np.abs(J - K)) < 1e-6 * np.max(np.abs(K))
    assert np.linalg.norm(r0) > 0


def test_zero_load_zero_displacement():
    r = solve_cantilever(1.0, 1.0, 1e4, 1e4, 0.0, 0.0, 0.0, 8, 3)
    assert r.converged and r.iterations == 0
    assert (r.tip_x, r.tip_y, r.tip_rot) == (1.0, 0.0, 0.0)


def test_failure_is_reported_not_hidden():
    # PL^2/EI = 30 in one increment without step cuts: Newton does not converge
    r = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -30.0, 0.0, 16, 1, max_cuts=0)
    assert not r.converged
    assert r.factor == 0.0 and "failed" in r.message
    # with step cutting the same load is solved
    ok = solve_cantilever(1.0, 1.0, INF, INF, 0.0, -30.0, 0.0, 16, 1)
    assert ok.converged and ok.factor == 1.0


def test_bad_input():
    with pytest.raises(ValueError):
        solve_cantilever(1.0, -1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 4, 1)
    with pytest.raises(ValueError):
        solve_cantilever(1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 0.0, 4, 0)


# --- cross-check of the corotational FE reference on single members --------------------------


def _corotational_tip(scene, n: int) -> dict[str, float]:
    """Tip outputs of the corotational FE (assembly.build + static.load_control) at factor 1."""
    assembly = pytest.importorskip("fem_reference.assembly", reason="corotational FE not built")
    static = pytest.importorskip(
        "fem_reference.statics.static", reason="FE static solvers not built"
    )
    for mod, name in ((assembly, "build"), (static, "load_control"), (static, "State")):
        if not hasattr(mod, name):
            pytest.skip(f"fem_reference.{mod.__name__.rsplit('.', 1)[-1]}.{name} not available yet")
    system = assembly.build(scene, n)
    start = static.State(np.zeros(system.ndof), 0.0)
    end = static.load_control(system, start, 1.0, 0.1, static.Options())
    return system.outputs(end.u)


def _single_member_scene(beta: float, fx: float, fy: float, m: float, follower: bool):
    from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support

    c, s = math.cos(beta), math.sin(beta)
    x0, y0 = 0.3, -0.2  # off the origin on purpose
    return Scene(
        name="reissner-cross-check",
        title="single clamped member",
        units="nondim",
        nodes=(Node("A", x0, y0), Node("B", x0 + c, y0 + s)),
        members=(Member("beam", "A", "B", "flexible", E=1.0, I=1.0, A=1.0e4),),
        supports=(Support("A", "clamp"),),
        loads=(Load("P", fx=fx, fy=fy, moment=m, node="B", follower=follower),),
        analysis=Analysis(kind="load", steps=10),
        outputs=(Output("tip", "B"),),
    )


@pytest.mark.parametrize(
    "beta, fx, fy, m, follower",
    [
        (0.0, 0.0, -3.0, 0.0, False),  # dead tip load, PL^2/EI = 3
        (0.0, 0.0, 3.0, 0.0, True),  # follower tip load
        (math.radians(30.0), 1.0, -2.0, 0.5, False),  # inclined member, force + moment
    ],
)
def test_corotational_agrees_with_reissner(beta, fx, fy, m, follower):
    scene = _single_member_scene(beta, fx, fy, m, follower)
    c, s = math.cos(beta), math.sin(beta)
    # Reissner in the member frame, same EA, shear-rigid (the corotational element has no shear)
    r = solve_cantilever(
        1.0, 1.0, 1.0e4, INF, c * fx + s * fy, -s * fx + c * fy, m, 32, 10, follower=follower
    )
    assert r.converged, r.message
    ref = (0.3 + c * r.tip_x - s * r.tip_y, -0.2 + s * r.tip_x + c * r.tip_y, r.tip_rot)
    diffs = []
    for n in (32, 64):
        out = _corotational_tip(scene, n)
        diffs.append(
            max(
                abs(out["tip.x"] - ref[0]), abs(out["tip.y"] - ref[1]), abs(out["tip.rot"] - ref[2])
            )
        )
    # the corotational error (Reissner P2 is ~1e-7 here) shrinks at second order
    assert diffs[1] < 2e-4, diffs
    assert abs(math.log2(diffs[0] / diffs[1]) - 2.0) < 0.3, diffs
