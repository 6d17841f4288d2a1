"""Verification of the corotational FE reference (fem_reference) against exact solutions.

Every expected value here is a closed form, an elliptic-integral elastica solution
(``reduced_models.beam.elastica``, an independent exact solver), a published number or a hand-solved
equilibrium -- never a number the FE produced earlier.  Convergence orders are fitted from
h-refinement and asserted.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, fsolve, minimize

import cases
from cases.schema import (
    Analysis,
    Driver,
    Load,
    Member,
    Node,
    Output,
    Scene,
    Support,
    TorsionSpring,
)
from fem_reference.assembly import build
from fem_reference.auto import FEMAuto
from fem_reference.models import FEM, MODELS, Runner
from fem_reference.statics import static as S
from reduced_models.beam.elastica import tip_dead_force

# -- scene builders ----------------------------------------------------------------------------


def scene(nodes, members, supports, loads, analysis=None, outputs=(), springs=(), name="t"):
    return Scene(
        name=name,
        title=name,
        units="nondim",
        nodes=tuple(Node(i, float(x), float(y)) for i, x, y in nodes),
        members=tuple(members),
        supports=tuple(supports),
        loads=tuple(loads),
        analysis=analysis or Analysis(kind="load", steps=4),
        outputs=tuple(Output(n, n) for n in outputs),
        torsion_springs=tuple(springs),
    )


def cantilever(fx=0.0, fy=0.0, m=0.0, follower=False, EA=1e7, steps=4, angle=0.0, **an):
    c, s = math.cos(angle), math.sin(angle)
    return scene(
        [("A", 0, 0), ("B", c, s)],
        [Member("beam", "A", "B", "flexible", E=1.0, I=1.0, A=EA)],
        [Support("A", "clamp")],
        [Load("P", fx=fx, fy=fy, moment=m, node="B", follower=follower)],
        Analysis(kind=an.pop("kind", "load"), steps=steps, **an),
        ["B"],
    )


def mechanism(angle_deg: float = 0.0) -> Scene:
    """A linkage using every feature: flexible, rigid and spring members, pinned ends, welded
    ends, torsion springs (one to ground, preloaded), a slider at an angle, dead, follower,
    moment and along-member loads.  ``angle_deg`` rotates the whole drawing."""
    a = math.radians(angle_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    pts = {"O": (0, 0), "B": (0.3, 0.4), "C": (1.0, 0.5), "D": (1.2, 0.0)}
    nodes = [(k, *(R @ np.array(v, float))) for k, v in pts.items()]

    def f(x, y):
        return tuple(R @ np.array([x, y]))

    fx1, fy1 = f(0.2, -0.5)
    fx2, fy2 = f(-0.3, 0.1)
    fx3, fy3 = f(0.0, -0.4)
    return scene(
        nodes,
        [
            Member("crank", "O", "B", "flexible", E=1.0, I=0.02, A=50.0, end_b="pin"),
            Member("coupler", "B", "C", "rigid", end_a="pin", end_b="pin"),
            Member("rocker", "C", "D", "flexible", E=1.0, I=0.03, A=60.0),
            Member("spring", "B", "D", "spring", k=2.0, free_length=1.05),
        ],
        [Support("O", "clamp"), Support("D", "slider", angle_deg=30.0 + angle_deg)],
        [
            Load("P1", fx=fx1, fy=fy1, node="C", follower=True),
            Load("P2", fx=fx2, fy=fy2, moment=0.05, node="B"),
            Load("P3", fx=fx3, fy=fy3, member="rocker", fraction=0.5, follower=True),
        ],
        Analysis(kind="load", steps=4),
        ["B", "C", "D"],
        [
            TorsionSpring("t1", "C", "rocker", "coupler", 0.3, 10.0),
            TorsionSpring("t2", "B", "coupler", None, 0.2, -5.0),
        ],
    )


# -- consistency of the discrete operators ------------------------------------------------------


def fd_jacobian(system, u, lam, h=1e-6):
    J = np.zeros((system.ndof, system.ndof))
    for j in range(system.ndof):
        e = np.zeros(system.ndof)
        e[j] = h
        J[:, j] = (system.residual(u + e, lam) - system.residual(u - e, lam)) / (2 * h)
    return J


@pytest.mark.parametrize(
    "sc",
    [
        cantilever(fx=0.3, fy=-1.0, m=0.4, follower=True, EA=200.0),
        cantilever(fx=0.3, fy=-1.0, m=0.4, follower=False, EA=200.0),
        mechanism(),
    ],
    ids=["follower", "dead", "mechanism"],
)
def test_tangent_equals_finite_difference_jacobian(sc):
    # rigid_factor = 1: a 1e6-stiff link would bury the comparison in FD round-off
    system = build(sc, 5, rigid_factor=1.0)
    rng = np.random.default_rng(1)
    u = 0.2 * rng.standard_normal(system.ndof)
    _, K = system.residual_and_tangent(u, 0.7)
    J = fd_jacobian(system, u, 0.7, h=1e-7)
    # absolute bound: FD error is ~1e-5 here (entries up to 7e4); load-stiffness and spring
    # entries are O(0.1-1), so a missing or wrong term fails
    assert np.abs(K.toarray() - J).max() <= 3e-5
    # the follower-load stiffness is not symmetric: the test would miss it otherwise
    if any(ld.follower for ld in sc.loads):
        assert np.abs(J - J.T).max() > 0.1


@pytest.mark.parametrize(
    "sc",
    [cantilever(fx=0.3, fy=-1.0, m=0.4, follower=True, EA=200.0), mechanism()],
    ids=["follower", "mechanism"],
)
def test_band_fast_path_equals_sparse_tangent_and_solves(sc):
    """The solvers' fast path (residual first, tangent assembled straight into LAPACK band
    storage) is the same operator as the csr ``residual_and_tangent`` (sliders at an angle,
    springs, torsion springs and follower loads included) and its LU solves K x = b."""
    system = build(sc, 6, rigid_factor=1.0)
    rng = np.random.default_rng(2)
    u = 0.2 * rng.standard_normal(system.ndof)
    r, K = system.residual_and_tangent(u, 0.7)
    ev = system.evaluate(u, 0.7)
    np.testing.assert_array_equal(ev.r, r)
    bw = system.bandwidth
    ab = system.tangent_band(ev)
    Kd = K.toarray()
    off = np.abs(np.subtract.outer(np.arange(len(Kd)), np.arange(len(Kd))))
    i, j = np.nonzero(off <= bw)
    assert np.abs(ab[2 * bw + i - j, j] - Kd[i, j]).max() <= 1e-13 * np.abs(Kd).max()
    assert np.count_nonzero(Kd[off > bw]) == 0  # nothing lies outside the band
    b = rng.standard_normal(system.ndof)
    x = system.factor(ev).solve(b)
    assert np.abs(Kd @ x - b).max() <= 1e-10 * np.abs(b).max()


def test_band_stability_matches_dense_eigenvalues():
    """The banded stability test (Cholesky inertia, warm-started inverse iteration, bisection
    for indefinite matrices, held driver coordinate) against dense ``eigvalsh`` of the same
    scaled symmetric tangent, on a stable and on an unstable state."""
    pcr = math.pi**2 / 4.0
    system = build(cantilever(fx=-pcr, EA=1e4), 24)
    rng = np.random.default_rng(3)
    i_tip = system.output_functional("B.ux")[0]
    z = np.zeros(system.ndof)
    trivial = {lam: S.newton(system, z, lam, S.Options()).u for lam in (0.5, 1.3)}
    assert S.stability(system, trivial[1.3], 1.3, dense_max=0)["n_neg"] == 1  # beyond Euler
    for lam, u in [
        (0.5, trivial[0.5]),
        (1.3, trivial[1.3]),
        (0.7, 1e-3 * rng.standard_normal(system.ndof)),
    ]:
        for exclude in (None, i_tip):
            band = S.stability(system, u, lam, dense_max=0, exclude=exclude)
            dense = S.stability(system, u, lam, dense_max=10**6, exclude=exclude)
            assert band["stable"] == dense["stable"]
            assert band["n_neg"] == dense["n_neg"]
            assert band["min_eig"] == pytest.approx(dense["min_eig"], rel=1e-7)


def test_zero_load_gives_zero_displacement():
    sc = cases.load("das2d-ex2-parallelogram")
    sc0 = scene(
        [(n.id, n.x, n.y) for n in sc.nodes],
        sc.members,
        sc.supports,
        [Load("P", member="coupler", fraction=0.5, fy=0.0)],
        Analysis(kind="load", steps=3),
        [o.node for o in sc.outputs],
    )
    sol = FEM(16).solve(sc0)
    assert sol.ok
    for st in sol.steps:
        assert all(abs(v) == 0.0 for k, v in st.outputs.items() if k.endswith((".ux", ".uy")))
        assert st.energy == 0.0


def test_objectivity_rigid_rotation_of_the_scene():
    """Rotating the drawing (and every load and slider) rotates the displacements and leaves
    rotations, energy and stability unchanged."""
    sol0 = FEM(8).solve(mechanism(0.0))
    sol1 = FEM(8).solve(mechanism(37.0))
    assert sol0.ok and sol1.ok
    a = math.radians(37.0)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    moved = 0.0
    for s0, s1 in zip(sol0.steps, sol1.steps):
        for n in ("B", "C", "D"):
            d0 = np.array([s0.outputs[f"{n}.ux"], s0.outputs[f"{n}.uy"]])
            d1 = np.array([s1.outputs[f"{n}.ux"], s1.outputs[f"{n}.uy"]])
            np.testing.assert_allclose(d1, R @ d0, atol=1e-9)
            assert s1.outputs[f"{n}.rot"] == pytest.approx(s0.outputs[f"{n}.rot"], abs=1e-9)
            moved = max(moved, float(np.linalg.norm(d0)))
        assert s1.energy == pytest.approx(s0.energy, rel=1e-8)
        assert s1.stable == s0.stable
    assert moved > 0.05  # the loads really deform the linkage


# -- single beams against closed forms -------------------------------------------------------


def fitted_order(ns, errors):
    """Slope of log(error) against log(h), h = 1/n."""
    return float(np.polyfit(np.log(1.0 / np.asarray(ns)), np.log(errors), 1)[0])


@pytest.mark.parametrize("phi", [math.pi / 2, math.pi, 2 * math.pi])
def test_rollup_under_end_moment_closed_form_and_order(phi):
    """Pure end moment M: circular arc of curvature M/EI; tip (sin phi/phi, (1-cos phi)/phi)."""
    exact = np.array([math.sin(phi) / phi - 1.0, (1.0 - math.cos(phi)) / phi])
    ns = [4, 8, 16, 32, 64]
    errs = []
    for n in ns:
        sol = FEM(n, stability=False).solve(cantilever(m=phi, steps=2, EA=1e4))
        assert sol.ok
        tip = sol.steps[-1].outputs
        assert tip["B.rot"] == pytest.approx(phi, abs=1e-12)
        errs.append(np.abs(np.array([tip["B.ux"], tip["B.uy"]]) - exact))
    errs = np.array(errs)
    if phi == 2 * math.pi:
        # the corotational polygon of equal chords closes exactly on a full circle
        assert errs.max() < 1e-12
        return
    comps = [0, 1] if phi == math.pi / 2 else [1]  # at pi, x of the polygon is exact too
    for c in comps:
        p = fitted_order(ns, errs[:, c])
        assert abs(p - 2.0) <= 0.2, (phi, c, p)
    assert errs[-1].max() < 2e-4


@pytest.mark.parametrize("load", [1.0, 3.0, 10.0])
def test_cantilever_dead_tip_load_vs_elastica(load):
    """PL^2/EI up to 10 (Bisshopp-Drucker / Mattiasson); nearly inextensible (EA = 1e7)."""
    x, y, th = tip_dead_force(1.0, 1.0, 0.0, -load)
    sol = FEMAuto(sequence=(8, 16, 32), stability=False).solve(cantilever(fy=-load, steps=5))
    assert sol.ok
    tip = sol.steps[-1].outputs
    got = np.array([tip["B.x"], tip["B.y"], tip["B.rot"]])
    np.testing.assert_allclose(got, [x, y, th], rtol=0, atol=2e-5)
    # the error estimate is honest: the true error lies within it (plus the EA = 1e7 stretch)
    est = sol.extras["error_estimate"]
    assert abs(tip["B.y"] - y) <= est["B.y"] + 2e-6
    assert abs(sol.extras["observed_order"]["B.y"] - 2.0) <= 0.2


def test_follower_tip_load_vs_pendulum_closed_form():
    """A tip force that stays perpendicular to the tip tangent: the deformed beam is an
    elastica under the dead force R(theta_L) (0, -P); theta_L solves the consistency
    condition (elliptic-integral pendulum solution + brentq)."""
    P = 2.0

    def g(th):
        return tip_dead_force(1.0, 1.0, P * math.sin(th), -P * math.cos(th))[2] - th

    th = brentq(g, -1.5, -1e-6)
    x, y, _ = tip_dead_force(1.0, 1.0, P * math.sin(th), -P * math.cos(th))
    sol = FEMAuto(sequence=(8, 16, 32), stability=False).solve(
        cantilever(fy=-P, follower=True, steps=4)
    )
    assert sol.ok
    tip = sol.steps[-1].outputs
    np.testing.assert_allclose([tip["B.x"], tip["B.y"], tip["B.rot"]], [x, y, th], atol=2e-5)
    # a dead load of the same size gives a clearly different answer
    assert abs(tip_dead_force(1.0, 1.0, 0.0, -P)[2] - th) > 0.05


def test_column_postbuckling_with_imperfection_vs_elastica():
    """Cantilever column at P = 1.5 Pcr (Pcr = pi^2 EI / 4L^2) with a 1 % lateral imperfection
    force: large post-buckled deflection against the exact elastica."""
    P = 1.5 * math.pi**2 / 4.0
    x, y, th = tip_dead_force(1.0, 1.0, -P, 0.01 * P)
    sol = FEMAuto(sequence=(8, 16, 32), stability=False).solve(
        cantilever(fx=-P, fy=0.01 * P, steps=10)
    )
    assert sol.ok
    tip = sol.steps[-1].outputs
    assert th > 1.0  # really post-buckled
    np.testing.assert_allclose([tip["B.x"], tip["B.y"], tip["B.rot"]], [x, y, th], atol=5e-5)


def test_perfect_column_stability_flag_at_euler_load():
    """The trivial path of a perfect column is stable below Pcr and unstable above it
    (branch switching off: ``bifurcation = false`` keeps the fundamental branch)."""
    pcr = math.pi**2 / 4.0
    sol = FEM(32, bifurcation=False).solve(cantilever(fx=-1.1 * pcr, steps=11))
    assert sol.ok
    for st in sol.steps:
        below = st.factor * 1.1 < 0.999
        above = st.factor * 1.1 > 1.001
        if below:
            assert st.stable and st.info["n_neg"] == 0 and st.info["min_pivot"] > 0
        if above:
            assert st.stable is False and st.info["n_neg"] == 1


# -- joints, springs, supports, along-member loads --------------------------------------------


def two_cantilevers(end="pin", P=6e-5):
    """Horizontal and vertical cantilever joined at J; small vertical load at J."""
    return scene(
        [("G1", -1, 0), ("G2", 0, -1), ("J", 0, 0)],
        [
            Member("m1", "G1", "J", "flexible", E=1.0, I=1.0, A=1e4, end_b=end),
            Member("m2", "G2", "J", "flexible", E=1.0, I=1.0, A=3.0, end_b=end),
        ],
        [Support("G1", "clamp"), Support("G2", "clamp")],
        [Load("P", fy=-P, node="J")],
        Analysis(kind="load", steps=1),
        ["J"],
    )


def test_pinned_joint_frame_hand_solution():
    """Pins share translations, not rotations: m1 carries the load in bending (3EI/L^3), m2
    axially (EA/L); v = -P/(3 + 3); m1's end turns by 1.5 v/L, m2's end not at all."""
    P = 6e-5
    r = Runner(two_cantilevers("pin", P), 8, {})
    assert r.run()[0] == "converged"
    out = r.steps[-1].outputs
    v = -P / 6.0
    assert out["J.uy"] == pytest.approx(v, rel=1e-6)
    assert abs(out["J.ux"]) < 1e-5 * abs(v)  # second-order shortening of m1 only
    d = r.system.full(r.states[-1].u)
    end_rot = r.system.extra["end_rot"]
    assert d[end_rot[("m1", "b")]] == pytest.approx(1.5 * v, rel=1e-6)
    assert abs(d[end_rot[("m2", "b")]]) < 1e-9
    # welding the joint changes the answer (moment transfer): the pins are real
    rw = Runner(two_cantilevers("weld", P), 8, {})
    rw.run()
    assert abs(rw.steps[-1].outputs["J.uy"] - v) > 0.1 * abs(v)


def test_simply_supported_beam_with_load_along_member():
    """Pin + horizontal slider, central load given as member fraction 0.5: end slope
    P L^2 / (16 EI) (small load, linear range)."""
    P = 1e-4
    sc = scene(
        [("A", 0, 0), ("B", 2.0, 0)],
        [Member("beam", "A", "B", "flexible", E=1.0, I=1.0, A=1e5)],
        [Support("A", "pin"), Support("B", "slider", angle_deg=0.0)],
        [Load("P", member="beam", fraction=0.5, fy=-P)],
        Analysis(kind="load", steps=1),
        ["A", "B"],
    )
    out = FEM(8).solve(sc).steps[-1].outputs
    assert out["A.rot"] == pytest.approx(-P * 4.0 / 16.0, rel=1e-6)
    assert out["B.rot"] == pytest.approx(P * 4.0 / 16.0, rel=1e-6)
    assert abs(out["B.uy"]) < 1e-14 and abs(out["A.ux"]) < 1e-14


def test_torsion_spring_linkage_hand_solution():
    """Two rigid links with torsion springs (one to ground, one between the links, both
    preloaded) and a linear spring to ground; equilibrium from the 2-DOF potential."""
    L1, L2, k1, k2, ks = 1.0, 0.7, 2.0, 1.5, 3.0
    a1, a2 = math.radians(20.0), math.radians(-10.0)
    p1, p2 = math.radians(8.0), math.radians(-12.0)
    F = np.array([0.4, -1.1])
    A = L1 * np.array([math.cos(a1), math.sin(a1)])
    B = A + L2 * np.array([math.cos(a2), math.sin(a2)])
    G = np.array([1.9, -0.6])
    l0 = 0.9 * np.linalg.norm(B - G)
    sc = scene(
        [("O", 0, 0), ("A", *A), ("B", *B), ("G", *G)],
        [
            Member("l1", "O", "A", "rigid"),
            Member("l2", "A", "B", "rigid", end_a="pin"),
            Member("s", "B", "G", "spring", k=ks, free_length=l0),
        ],
        [Support("O", "pin"), Support("G", "pin")],
        [Load("F", fx=F[0], fy=F[1], node="B")],
        Analysis(kind="load", steps=4),
        ["A", "B"],
        [
            TorsionSpring("k1", "O", "l1", None, k1, math.degrees(p1)),
            TorsionSpring("k2", "A", "l2", "l1", k2, math.degrees(p2)),
        ],
    )

    def e(t):
        return np.array([math.cos(t), math.sin(t)])

    def de(t):
        return np.array([-math.sin(t), math.cos(t)])

    def grad(q):
        t1, t2 = q
        rb = L1 * e(a1 + t1) + L2 * e(a2 + t2)
        d = rb - G
        ln = np.linalg.norm(d)
        fs = ks * (ln - l0) * d / ln  # gradient of the spring energy w.r.t. r_B
        g1 = k1 * (t1 - p1) - k2 * (t2 - t1 - p2) + (fs - F) @ (L1 * de(a1 + t1))
        g2 = k2 * (t2 - t1 - p2) + (fs - F) @ (L2 * de(a2 + t2))
        return [g1, g2]

    def potential(q):
        t1, t2 = q
        rb = L1 * e(a1 + t1) + L2 * e(a2 + t2)
        return (
            0.5 * k1 * (t1 - p1) ** 2
            + 0.5 * k2 * (t2 - t1 - p2) ** 2
            + 0.5 * ks * (np.linalg.norm(rb - G) - l0) ** 2
            - F @ rb
        )

    q0 = minimize(potential, [0.0, 0.0], method="BFGS").x  # the minimum next to the drawing
    t1, t2 = fsolve(grad, q0, xtol=1e-13)  # polished on the analytic gradient
    sol = FEM(1).solve(sc)
    assert sol.ok
    out = sol.steps[-1].outputs
    rb = L1 * e(a1 + t1) + L2 * e(a2 + t2)
    # rigid links are stiff elements: 1e-6 relative compliance
    assert out["A.rot"] == pytest.approx(t1, abs=1e-5)
    np.testing.assert_allclose([out["B.x"], out["B.y"]], rb, atol=1e-5)
    assert abs(t1) > 0.05 and abs(t2) > 0.05


def test_das2d_constant_force_mechanism_published_force():
    """Howell (2001) Sec. 10.3 / DAS-2D Example 5: F = k1 Phi / r2 = 12.78 N; the energy
    analysis reports the driver reaction, which must also equal dU/dx (no other loads)."""
    sc = cases.load("das2d-ex5-constant-force")
    sol = FEM(1).solve(sc)
    assert sol.ok
    x = sol.path("factor")
    f = sol.path("driver.force")
    assert np.interp(-16.279179, x[::-1], f[::-1]) == pytest.approx(-12.776, rel=5e-3)
    U = sol.path("energy")
    dUdx = np.gradient(U, x)
    np.testing.assert_allclose(f[2:-2], dUdx[2:-2], rtol=2e-3)


def test_distance_analysis_finds_the_load_for_a_tip_deflection():
    """Distance analysis: load factor that puts the tip at y = -0.6 (elastica + brentq)."""
    sc = cantilever(
        fy=-1.0,
        kind="distance",
        steps=2,
        driver=Driver("displacement", 0.0, -0.6, node="B", direction="y"),
    )
    P = brentq(lambda p: tip_dead_force(1.0, 1.0, 0.0, -p)[1] + 0.6, 0.1, 10.0)
    sol = FEMAuto(sequence=(8, 16, 32), stability=False).solve(sc)
    assert sol.ok
    assert sol.steps[-1].outputs["B.uy"] == pytest.approx(-0.6, abs=1e-12)
    assert sol.steps[-1].factor == pytest.approx(P, rel=1e-5)


# -- model behaviour -----------------------------------------------------------------------------


def test_mass_matrix_total_mass_and_rigid_link_inertia():
    """Consistent mass: a uniform translation carries the total mass rho A L; a rigid link
    spinning about its centre has the bar inertia rho A L^3 / 12."""
    sc = scene(
        [("A", 0, 0), ("B", 2.0, 0), ("D", 3.0, 0.0), ("C", 3.0, 1.0)],
        [
            Member("b", "A", "B", "flexible", E=1.0, I=0.1, A=0.5, density=3.0),
            Member("r", "D", "C", "rigid", A=0.2, I=0.01, density=2.0, end_a="pin"),
        ],
        [],
        [],
        Analysis(kind="load", steps=1),
        ["A"],
    )
    system = build(sc, 6)
    M = system.mass().toarray()
    assert np.allclose(M, M.T)
    ux = np.zeros(system.ndof)
    ux[~system.is_rotation] = 1.0  # every translation DOF moves by one: both directions
    total = 3.0 * 0.5 * 2.0 + 2.0 * 0.2 * 1.0
    assert ux @ M @ ux == pytest.approx(2.0 * total, rel=1e-12)
    # rigid link D-C spinning at rate 1 about its midpoint: vD = (0.5, 0), vC = (-0.5, 0)
    v = np.zeros(system.ndof)
    iD, iC = system.node_dofs("D"), system.node_dofs("C")
    v[iD[0]], v[iC[0]] = 0.5, -0.5
    rot = system.extra["end_rot"]
    for key in (("r", "a"), ("r", "b")):
        v[system.free[rot[key]]] = 1.0
    J_bar = 2.0 * 0.2 * 1.0**3 / 12.0 + 2.0 * 0.01 * 1.0  # translation part + rotary rho I L
    assert v @ M @ v == pytest.approx(J_bar, rel=1e-12)


def test_failed_is_honest_for_a_mechanism_without_stiffness():
    sc = scene(
        [("O", 0, 0), ("A", 1, 0)],
        [Member("link", "O", "A", "rigid")],
        [Support("O", "pin")],
        [Load("P", fy=-1.0, node="A")],
        Analysis(kind="load", steps=2),
        ["A"],
    )
    sol = FEM(4).solve(sc)
    assert sol.status == "failed"
    assert len(sol.steps) == 1 and sol.steps[0].factor == 0.0
    assert "singular" in sol.message or "stalled" in sol.message


def test_registry_and_not_applicable():
    assert MODELS == {
        "fem-N": "fem_reference.models:FEM",
        "fem-auto": "fem_reference.auto:FEMAuto",
        "replay": "fem_reference.replay.model:Replay",
    }
    sc = cantilever(fy=-1.0)
    sweep = Scene(
        **{**sc.__dict__, "analysis": Analysis(kind="sweep", sweep_key="x", sweep_values=(1.0,))}
    )
    assert FEM(4).solve(sweep).status == "not-applicable"
    assert FEM(4).name == "fem-4" and FEMAuto().name == "fem-auto"


def test_newton_tolerances_reach_round_off_level():
    """Converged steps carry small residuals relative to the applied load."""
    sol = FEM(64).solve(cantilever(fy=-3.0, steps=3))
    for st in sol.steps[1:]:
        assert st.info["residual"] < 1e-6 * 3.0  # round-off floor of EA = 1e7 on 64 elements
    assert S.Options().rtol <= 1e-8
