"""Verification of the pseudo-rigid-body family against the exact elastica and published claims.

The exact reference here is computed independently of ``reduced_models.beam.elastica``: the
Bisshopp-Drucker elliptic-integral closed form for a transverse tip force and a shooting
solution (variational equations + load continuation, scipy solve_ivp) for general tip loads.

Published claims reproduced, in the form stated:

* Howell (Compliant Mechanisms, Wiley 2001, Table 5.1; Howell & Midha 1995): for a transverse
  load (n = 0) the tip of the characteristic radius gamma L = 0.8517 L follows the exact tip
  locus within 0.5 % of the deflection up to Theta_max = 64.3 deg.
* Su 2009 (J. Mechanisms Robotics 1:021008, doi 10.1115/1.3046148, abstract): the PRB-3R
  approximation error is "much less than that of the conventional PRB 1R model"; maximum tip
  deflection error 1.2 % (his four-bar vs FEA; applied here to the cantilever).

Measured bias a user gets at small loads (what the report must show): PRB-1R is stiffer than
linear theory by K_Theta / (3 gamma) (Howell's fit at n = 0: deflection 3.7 % too small).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import cases
from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support
from reduced_models import registry
from reduced_models.beam import prb, prb_chain, prb_fit, prb_model
from reduced_models.beam import prb_tables as T
from reduced_models.paths.linalg import Banded

# ---------------------------------------------------------------------------------------------
# independent exact solutions (L = EI = 1)
# ---------------------------------------------------------------------------------------------


def exact_transverse(alpha: float) -> tuple[float, float, float]:
    """Tip (x, y, slope) under a transverse dead force alpha (Bisshopp-Drucker closed form)."""
    if alpha == 0.0:
        return 1.0, 0.0, 0.0

    def parts(t0: float) -> tuple[float, float, float]:
        m = (1.0 + math.sin(t0)) / 2.0
        phi1 = math.asin(1.0 / math.sqrt(2.0 * m))
        return m, phi1, ellipk(m) - ellipkinc(phi1, m)

    t0 = brentq(lambda t: parts(t)[2] - math.sqrt(alpha), 1e-14, math.pi / 2 - 1e-14, xtol=1e-15)
    m, phi1, _ = parts(t0)
    x = math.sqrt(2.0 * math.sin(t0) / alpha)
    y = 1.0 - 2.0 / math.sqrt(alpha) * (ellipe(m) - ellipeinc(phi1, m))
    return x, y, t0


def exact_general(fx: float, fy: float, m: float, steps: int = 20) -> np.ndarray:
    """Tip (x, y, slope) under dead loads (fx, fy, m): shooting on the root curvature."""

    def rhs(_s: float, u: np.ndarray, lx: float, ly: float) -> list:
        _, _, th, k, dth, dk = u
        c, s = math.cos(th), math.sin(th)
        return [c, s, k, lx * s - ly * c, dk, (lx * c + ly * s) * dth]

    k0 = 0.0
    for lam in np.linspace(0.0, 1.0, steps + 1)[1:]:
        for _ in range(50):
            sol = solve_ivp(
                rhs, (0.0, 1.0), [0, 0, 0, k0, 0, 1], args=(lam * fx, lam * fy), rtol=1e-12,
                atol=1e-13,
            )  # fmt: skip
            r = sol.y[3, -1] - lam * m
            k0 -= r / sol.y[5, -1]
            if abs(r) < 1e-12:
                break
    return sol.y[:3, -1]


def scene_for(fx: float, fy: float, m: float = 0.0, steps: int = 10, **member: float) -> Scene:
    """Unit cantilever (L = E = I = 1) with a tip load; extra Member fields via ``member``."""
    mem = Member("beam", "A", "B", "flexible", E=1.0, I=1.0, **member)
    return Scene(
        name="t",
        title="t",
        units="nondim",
        nodes=(Node("A", 0.0, 0.0), Node("B", 1.0, 0.0)),
        members=(mem,),
        supports=(Support("A", "clamp"),),
        loads=(Load("P", fx=fx, fy=fy, moment=m, node="B"),),
        analysis=Analysis(kind="load", steps=steps),
        outputs=(Output("tip", "B"),),
    )


def tip(sol: object) -> np.ndarray:
    o = sol.steps[-1].outputs
    return np.array([o["tip.x"], o["tip.y"], o["tip.rot"]])


MODELS = {
    "prb-short": prb.PRBShort,
    "prb-1r": prb.PRB1R,
    "prb-2r": prb.PRB2R,
    "prb-3r": prb.PRB3R,
    "prb-3r-force": prb.PRB3RForce,
    "prb-3r-moment": prb.PRB3RMoment,
    "prb-2rpr": prb.PRB2RPR,
    "prb-fsm-6": lambda: prb.PRBFSM(6),
    "prb-fsm-20": lambda: prb.PRBFSM(20),  # banded (tridiagonal) Hessian route
    "prb-custom": lambda: prb.PRBCustom(matrix=[[math.inf, "inf", 0.2], [2.5, 3.0, 0.8]]),
}


def make(name: str) -> prb_model.PRBModel:
    model = MODELS[name]()
    model.name = name
    return model


# ---------------------------------------------------------------------------------------------
# published parameterisations
# ---------------------------------------------------------------------------------------------


def test_howell_curve_fits_reproduce_table_5_1():
    # a wrong coefficient in the transcription moves gamma by far more than the fit residual
    fit = np.array([T.howell_gamma(n) for n in T.HOWELL_TABLE_N])
    assert np.max(np.abs(fit - T.HOWELL_TABLE_GAMMA)) < 2.5e-3
    # the three K_Theta pieces join continuously (a typo in one piece would open a jump)
    for nb in (-2.5, -1.0):
        assert T.howell_k_theta(nb - 1e-9) == pytest.approx(T.howell_k_theta(nb + 1e-9), abs=0.02)
    # pure moment: gamma K_Theta = c_theta, so a small end moment gives the exact slope ML/EI
    p = T.HOWELL_MOMENT
    assert p["gamma"] * p["K_Theta"] == pytest.approx(p["c_theta"], rel=1e-4)


def test_su_3r_matrices():
    for kset in T.SU_K:
        m = T.prb3r_matrix(kset)
        assert m[:, 2].sum() == pytest.approx(1.0)
        assert np.allclose(np.cumsum(m[:, 2])[:3], [0.10, 0.45, 0.85])  # joints of Su Eq. (24)
        assert np.isinf(m[0, 0]) and np.all(np.isinf(m[:, 1]))


def test_prb1r_characteristic_radius_tip_locus_within_half_percent_to_64_3_deg():
    """Howell's claim: gamma = 0.8517 keeps the locus error below 0.5 % up to 64.3 deg."""
    alphas = np.concatenate([np.geomspace(1e-3, 1.0, 25), np.linspace(1.0, 12.0, 120)])
    tips = np.array([exact_transverse(a) for a in alphas])

    def locus_error(gamma: float) -> tuple[np.ndarray, np.ndarray]:
        ax, b = tips[:, 0] - (1.0 - gamma), tips[:, 1]
        theta = np.degrees(np.arctan2(b, ax))
        err = np.abs(np.hypot(ax, b) - gamma) / np.hypot(1.0 - tips[:, 0], b)
        return theta, err

    theta, err = locus_error(T.HOWELL_N0["gamma"])
    assert err[theta <= 64.0].max() < 0.005
    crossing = theta[np.argmax(err > 0.005)]  # measured: 64.27 deg
    assert crossing == pytest.approx(T.HOWELL_N0["Theta_max_deg"], abs=0.5)
    assert err[theta >= 70.0].min() > 0.01  # beyond Theta_max the error grows quickly
    # the curve-fit value the model uses at n = 0 (0.852144) stays within 0.51 % (measured 0.507)
    theta, err = locus_error(T.howell_gamma(0.0))
    assert err[theta <= 64.3].max() < 0.0051


def test_prb1r_model_tip_on_characteristic_circle_and_slope_factor():
    sol = make("prb-1r").solve(scene_for(0.0, 5.0))
    g, c = T.howell_gamma(0.0), T.howell_c_theta(0.0)
    x, y, rot = tip(sol)
    theta = math.atan2(y, x - (1.0 - g))
    assert math.hypot(x - (1.0 - g), y) == pytest.approx(g, rel=1e-12)
    assert rot == pytest.approx(c * theta, rel=1e-12)
    # equilibrium alpha (cos Theta + n sin Theta) = K_Theta Theta (Howell), n = 0
    # to the model's stated residual tolerance RESIDUAL_TOL EI/L (EI = L = 1)
    assert 5.0 * math.cos(theta) == pytest.approx(T.howell_k_theta(0.0) * theta, abs=1e-8)


def test_prb1r_small_load_bias_against_linear_theory():
    """K_Theta is a large-deflection average: at small loads the model is too stiff."""
    alpha = 1e-4
    y = tip(make("prb-1r").solve(scene_for(0.0, alpha)))[1]
    ratio = y / (alpha / 3.0)
    bias = 3.0 * T.howell_gamma(0.0) / T.howell_k_theta(0.0)
    assert ratio == pytest.approx(bias, rel=1e-3)
    assert ratio == pytest.approx(0.9629, abs=1e-3)  # the report quotes -3.7 %


REGISTRY_LINES = {
    "prb-short": "reduced_models.beam.prb:PRBShort",
    "prb-1r": "reduced_models.beam.prb:PRB1R",
    "prb-2r": "reduced_models.beam.prb:PRB2R",
    "prb-3r": "reduced_models.beam.prb:PRB3R",
    "prb-3r-force": "reduced_models.beam.prb:PRB3RForce",
    "prb-3r-moment": "reduced_models.beam.prb:PRB3RMoment",
    "prb-2rpr": "reduced_models.beam.prb:PRB2RPR",
    "prb-fsm-N": "reduced_models.beam.prb:PRBFSM",
    "prb-custom": "reduced_models.beam.prb:PRBCustom",
}


@pytest.fixture
def registered(monkeypatch):
    """The PRB entries in the registry (added by the lead; set here if not there yet)."""
    for name, target in REGISTRY_LINES.items():
        if name not in registry.MODELS:
            monkeypatch.setitem(registry.MODELS, name, target)


def test_force_deflection_error_over_the_whole_range(registered):
    r = prb_fit.force_deflection_error("prb-1r", [1e-3, 1.0, 5.0, 10.0], reference=_ref)
    assert r.status == ("converged",) * 4
    assert r.deflection_rel[0] == pytest.approx(-0.0371, abs=1e-3)  # small loads: -3.7 %
    assert abs(r.deflection_rel[2]) < 0.01 and abs(r.deflection_rel[3]) < 0.01
    f = prb_fit.force_deflection_error("prb-fsm-16", [1e-3, 10.0], reference=_ref)
    # midpoint FSM: linear-limit ratio 1 - 1/(4 N^2)
    assert f.deflection_rel[0] == pytest.approx(-1.0 / (4 * 16**2), rel=1e-2)


def _ref(L: float, EI: float, fx: float, fy: float, m: float = 0.0) -> tuple:
    assert L == 1.0 and EI == 1.0 and fx == 0.0 and m == 0.0
    return exact_transverse(fy)


def test_su_3r_error_much_less_than_1r_and_within_1_2_percent():
    """Su 2009: 3R error much smaller than 1R; 1.2 % max tip deflection error (four-bar)."""
    alphas = np.linspace(0.5, 7.2, 8)  # Theta <= 64.3 deg: inside the 1R's stated range
    ex = np.array([exact_transverse(a) for a in alphas])

    def errors(name: str) -> tuple[float, float]:
        t = np.array([tip(make(name).solve(scene_for(0.0, a, steps=5))) for a in alphas])
        return np.hypot(*(t[:, :2] - ex[:, :2]).T).max(), np.abs(t[:, 2] - ex[:, 2]).max()

    p1, a1 = errors("prb-1r")
    p3, a3 = errors("prb-3r-force")
    assert p3 < 0.6 * p1  # measured 0.73 % vs 1.50 % of L
    assert a3 < 0.25 * a1  # measured 0.0066 vs 0.066 rad
    assert p3 < 0.012
    # the load-independent averages (Table 1) over force and moment paths
    for name in ("prb-3r", "prb-3r-moment"):
        assert errors(name)[0] < 0.03


def test_su_3r_moment_set_under_end_moment():
    m_grid = [0.5, 1.5, 3.0]
    # measured max: 0.88 % (moment set), 2.1 % (Table 1 averages, at ML/EI = 3)
    for name, bound in (("prb-3r-moment", 0.012), ("prb-3r", 0.025)):
        for mm in m_grid:
            t = tip(make(name).solve(scene_for(0.0, 0.0, mm, steps=6)))
            exact = np.array([math.sin(mm) / mm, (1 - math.cos(mm)) / mm, mm])
            assert math.hypot(*(t[:2] - exact[:2])) < bound


# ---------------------------------------------------------------------------------------------
# finite segment model: convergence order
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("placement", "order"), [("mid", 2.0), ("end", 1.0)], ids=["midpoint", "end"]
)
def test_fsm_converges_to_elastica_with_observed_order(placement, order):
    load = (-1.5, 3.0, 1.0)
    exact = exact_general(*load)
    ns = np.array([4, 8, 16, 32, 64])
    err = []
    for n in ns:
        model = prb.PRBFSM(int(n), placement, shapes=False)
        model.name = f"prb-fsm-{n}"
        err.append(np.hypot(*(tip(model.solve(scene_for(*load)))[:2] - exact[:2])))
    slope = -np.polyfit(np.log(ns), np.log(err), 1)[0]
    assert slope == pytest.approx(order, abs=0.1)  # measured 2.006 (mid), 0.984 (end)
    assert err[-1] < (5e-4 if placement == "mid" else 2e-2)


# ---------------------------------------------------------------------------------------------
# every energy model: derivatives, recovered end loads, zero load, small loads
# ---------------------------------------------------------------------------------------------


def _chain_state(model: prb_model.PRBModel, scene: Scene) -> tuple:
    sol = model.postprocess(scene, model.solve(scene))
    assert sol.status == "converged", sol.message
    beam = model._beam(scene)
    matrix = np.asarray(sol.extras["prb_matrix"])
    chain = prb_chain.PRBChain(matrix, beam.L, beam.EI, beam.EA)
    return sol, chain, np.asarray(sol.extras["prb_states"][-1])


def central(fun: object, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of fun at x, one row per coordinate: shape (n,) + fun's shape."""
    return np.array([(fun(x + h * e) - fun(x - h * e)) / (2 * h) for e in np.eye(x.size)])


@pytest.mark.parametrize("name", list(MODELS))
def test_gradient_hessian_and_reported_end_loads(name):
    load = (0.0, -4.0, 0.0) if name == "prb-1r" else (1.5, -3.0, 0.7)
    scene = scene_for(*load, A=50.0)
    sol, chain, x = _chain_state(make(name), scene)
    f = np.array(load)
    g, H = chain.grad_hess(x, f)
    Hd = H.to_dense() if isinstance(H, Banded) else H
    assert np.allclose(g, central(lambda y: chain.potential(y, f), x), atol=1e-7)
    assert np.allclose(Hd, central(lambda y: chain.grad_hess(y, f)[0], x), atol=1e-6)
    assert np.allclose(Hd, chain.grad_hess(x, f, dense=True)[1])
    # reported end loads: J^T f equals the finite-difference gradient of the stored energy,
    # with J itself by finite differences of the tip pose (nothing from the analytic code)
    info = sol.steps[-1].info
    f_rep = np.array([info["load_fx"], info["load_fy"], info["load_m"]])
    dU = central(chain.strain_energy, x)
    J = central(lambda y: np.array(chain.tip(y)), x)  # (n, 3): d(X, Y, Phi)/dx_k per row
    assert np.allclose(J @ f_rep, dU, atol=1e-6)
    assert np.allclose(f_rep, f, atol=1e-6)
    assert sol.steps[-1].stable is True


@pytest.mark.parametrize("name", list(MODELS))
def test_zero_load_gives_zero_displacement(name):
    sol = make(name).solve(scene_for(0.0, -2.0) if name == "prb-1r" else scene_for(1.0, -2.0, 0.5))
    s0 = sol.steps[0]
    assert s0.factor == 0.0 and s0.energy == 0.0
    assert [s0.outputs[f"tip.{q}"] for q in ("ux", "uy", "rot")] == [0.0, 0.0, 0.0]


def _linear_ratio(matrix: np.ndarray) -> float:
    """Small-load tip deflection of a PRB matrix / (alpha/3): 3 sum (1 - s_j)^2 / k_j."""
    s = np.concatenate([[0.0], np.cumsum(matrix[:, 2])[:-1]])
    j = np.isfinite(matrix[:, 0])
    return float(3.0 * np.sum((1.0 - s[j]) ** 2 / matrix[j, 0]))


@pytest.mark.parametrize(
    ("name", "known"),
    [
        ("prb-short", 0.75),  # pivot at L/2, K = EI/L
        ("prb-1r", 0.9629),  # 3 gamma / K_Theta (Howell's fit at n = 0)
        ("prb-2r", None),
        ("prb-3r", 1.0221),  # Su Table 1 averages: 2.2 % softer than linear theory
        ("prb-3r-force", None),
        ("prb-3r-moment", None),
        ("prb-2rpr", 1.0221),
        ("prb-fsm-6", 1.0 - 1.0 / (4 * 36)),  # midpoint rule: 1 - 1/(4 N^2)
        ("prb-fsm-20", 1.0 - 1.0 / (4 * 400)),
    ],
)
def test_small_loads_against_linear_beam_theory(name, known):
    """Report each model's small-load bias against y = P L^3/(3 EI) and assert it."""
    alpha = 1e-5
    sol = make(name).solve(scene_for(0.0, alpha, steps=1))
    ratio = tip(sol)[1] / (alpha / 3.0)
    expected = _linear_ratio(np.asarray(sol.extras["prb_matrix"]))
    assert ratio == pytest.approx(expected, rel=1e-4)
    if known is not None:
        assert ratio == pytest.approx(known, abs=2e-4)
    print(f"{name}: small-load deflection / linear theory = {ratio:.4f}")


def test_fixed_guided_small_load_matches_linear_theory():
    scene = cases.load("fixed-guided-beam")
    scene = dataclasses.replace(
        scene,
        loads=tuple(dataclasses.replace(ld, fy=-1e-4) for ld in scene.loads),
        analysis=Analysis(kind="load", steps=1),
    )
    model = make("prb-fsm-20")
    sol = model.postprocess(scene, model.solve(scene))
    assert sol.status == "converged"
    o = sol.steps[-1].outputs
    assert o["tip.rot"] == 0.0
    # guided tip: y = F L^3/(12 EI) in linear theory; the midpoint FSM integrates the linear
    # curvature with the midpoint rule, whose known error gives the factor 1 - 1/N^2 here
    assert o["tip.uy"] == pytest.approx(-1e-4 / 12.0 * (1.0 - 1.0 / 20**2), rel=1e-4)
    # the recovered tip moment is the guide's reaction, F L / 2 in magnitude
    assert abs(sol.steps[-1].info["load_m"]) == pytest.approx(0.5e-4, rel=2e-3)


def test_2rpr_axial_stretch_is_exact_for_a_bar_in_tension():
    sol = make("prb-2rpr").solve(scene_for(2.0, 0.0, A=100.0, steps=2))
    assert sol.steps[-1].outputs["tip.ux"] == pytest.approx(2.0 / 100.0, rel=1e-9)
    assert sol.steps[-1].energy == pytest.approx(0.5 * 2.0**2 / 100.0, rel=1e-9)
    # without an area the prismatic springs are rigid and the message says so
    sol = make("prb-2rpr").solve(scene_for(2.0, -1.0))
    assert "rigid" in sol.message and sol.steps[-1].outputs["tip.x"] <= 1.0


def test_shape_is_the_prbs_own_chain_and_stress_its_own_moment():
    """The drawn shape is the PRB's pivots and links; stress from the PRB's own end loads."""
    scene = scene_for(0.0, -3.0, thickness=0.1)
    model = make("prb-3r")
    solved = model.solve(scene)
    assert not any(s.shapes for s in solved.steps), "the timed solve draws nothing"
    s = model.postprocess(scene, solved).steps[-1]
    xy = s.shapes["beam"]
    # root, the rigid root link's end (first pivot), two more pivots, tip
    assert xy.shape == (5, 2) and np.allclose(xy[0], 0.0)
    seg = np.hypot(*np.diff(xy, axis=0).T)
    assert seg == pytest.approx(np.array(T.SU_GAMMA), rel=1e-12)  # rigid links keep lengths
    assert xy[-1] == pytest.approx([s.outputs["tip.x"], s.outputs["tip.y"]], abs=1e-14)
    # dead transverse load: the moment is largest at the clamp, P times the tip's lever arm
    assert s.max_stress == pytest.approx(0.1 * 3.0 * xy[-1, 0] / 2.0, rel=1e-9)


PRB_NAMES = ("prb-short", "prb-1r", "prb-2r", "prb-3r", "prb-2rpr", "prb-fsm-4", "prb-fsm-16")


@pytest.mark.parametrize("case", cases.catalog_names())
def test_shape_tips_are_the_reported_tips_on_every_catalog_case(case):
    import reports

    scene = cases.load(case)
    solved = 0
    for name in PRB_NAMES:
        sol = reports.solve(scene, name)
        if sol.status == "not-applicable" or len(scene.members) != 1:
            continue  # mechanisms (assembler): one shape per member, tested in test_mechanism
        solved += 1
        if scene.model_options(name).get("das2d"):
            continue  # DAS-2D's Euler shape ends at the Euler tip (tests/test_prb_das2d.py)
        tip = scene.outputs[0].name
        for st in sol.steps:
            (xy,) = st.shapes.values()
            reported = [st.outputs[f"{tip}.x"], st.outputs[f"{tip}.y"]]
            assert xy[-1] == pytest.approx(reported, abs=1e-12), (name, st.factor)
    if "single-beam" in scene.tags and "follower" not in scene.tags:
        assert solved, "a single-beam case with dead loads that no PRB model solves"


# ---------------------------------------------------------------------------------------------
# applicability and honesty
# ---------------------------------------------------------------------------------------------


def test_declines_with_reasons():
    follower = cases.load("cantilever-follower-load")
    assert "follower" in make("prb-3r").applies_to(follower)
    assert make("prb-3r").solve(follower).status == "not-applicable"
    assert "moment" in make("prb-1r").applies_to(scene_for(0.0, 1.0, 0.5))
    assert "range" in make("prb-1r").applies_to(cases.load("column-postbuckling"))
    assert "guided" in make("prb-1r").applies_to(cases.load("fixed-guided-beam"))
    assert "matrix" in prb.PRBCustom().applies_to(scene_for(0.0, 1.0))
    bad = prb.PRBCustom(matrix=[[1.0, math.inf, 0.3], [1.0, math.inf, 0.3]])
    assert "sum to 1" in bad.applies_to(scene_for(0.0, 1.0))


def test_pure_moment_uses_howell_moment_parameters():
    sol = make("prb-1r").solve(scene_for(0.0, 0.0, 0.1, steps=1))
    assert "moment" in sol.message
    assert tip(sol)[2] == pytest.approx(0.1, rel=1e-3)  # slope ML/EI at small moment


# ---------------------------------------------------------------------------------------------
# PRB optimizer
# ---------------------------------------------------------------------------------------------


def test_derived_2r_matrix_against_exact_solutions():
    """The derived 2R table is judged by its errors against independent exact solutions
    (force and moment paths), not by refitting it."""
    fx = np.array([tip(make("prb-2r").solve(scene_for(0.0, a, steps=4))) for a in (2.0, 10.0)])
    ex = np.array([exact_transverse(a) for a in (2.0, 10.0)])
    assert np.hypot(*(fx[:, :2] - ex[:, :2]).T).max() < 0.025
    t = tip(make("prb-2r").solve(scene_for(0.0, 0.0, 2.0, steps=4)))
    assert math.hypot(t[0] - math.sin(2.0) / 2.0, t[1] - (1 - math.cos(2.0)) / 2.0) < 0.04


def test_fit_prb_3r_at_least_as_good_as_su_sets():
    """The optimizer, started from the midpoint FSM, matches or beats Su's published 3R sets
    on the loads it fits (tip force PL^2/EI <= 10 and end moment ML/EI <= 2)."""
    kw = {"moment_range": (0.0, 2.0), "n_points": 10}
    r = prb_fit.fit_prb(3, (0.0, 10.0), **kw)
    assert r.success and r.matrix[:, 2].sum() == pytest.approx(1.0)
    for kset in T.SU_K:  # measured: fit 1.67 % / 0.010 rad; best Su set 1.91 % / 0.014 rad
        pos, ang = prb_fit.tip_errors(T.prb3r_matrix(kset), (0.0, 10.0), **kw)
        assert r.max_position_error <= pos and r.max_angle_error <= ang


def test_save_to_case_and_cli_roundtrip(tmp_path, capsys):
    src = cases.resolve("cantilever-tip-load")
    case = tmp_path / "case.toml"
    case.write_text(src.read_text())
    rc = prb_fit.fit_prb_cli(["2", "--alpha-max", "4", "--points", "5", "--save", str(case)])
    out = capsys.readouterr().out
    assert rc == 0 and "PRB matrix" in out and "prb-custom" in out
    scene = cases.load(case)
    opts = scene.model_options("prb-custom")
    model = prb.PRBCustom(**opts)
    model.name = "prb-custom"
    matrix = prb_chain.check_matrix(opts["matrix"])
    assert np.isinf(matrix[0, 0]) and matrix.shape == (3, 3)
    sol = model.solve(scene)
    assert sol.status == "converged"
    with pytest.raises(ValueError, match="already"):
        prb_fit.save_to_case(case, matrix)
    assert prb_fit.fit_prb_cli(["0"]) == 2
    assert prb_fit.fit_prb_cli(["two"]) == 2  # argparse error: usage line, no traceback
    assert prb_fit.fit_prb_cli(["2", "--save", str(tmp_path / "missing.toml")]) == 2
