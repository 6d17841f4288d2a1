"""Verification of the damped dynamics replay (fem_reference.replay.run).

Small test systems with exact static solutions (a shallow von Mises truss with a known snap,
a two-link column with a known critical load) check the integrator itself; the FE scenes check
that settled states equal the static FE reference.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.optimize as so
import scipy.sparse as sp

import cases
from fem_reference.assembly import build
from fem_reference.models import FEM
from fem_reference.replay.integrator import GenAlpha, ramp
from fem_reference.replay.model import Replay, write_animation, write_vtu_series
from fem_reference.replay.run import ReplayOptions, ramp_and_hold, replay_system
from fem_reference.statics import static
from reduced_models.base import Step

# --------------------------------------------------------------------------------------------
# test systems (DiscreteSystem protocol) with exact statics


class VonMisesTruss:
    """Two bars from (-a, 0) and (a, 0) to an apex at (0, h); apex DOFs (ux, uy); load -P y."""

    ndof = 2

    def __init__(self, a=1.0, h=0.2, EA=100.0, P=1.0, m=1.0, tilt=0.0):
        self.a, self.h, self.EA, self.P, self.m = a, h, EA, P, m
        self.S = np.array([[-a, 0.0], [a, 0.0]])
        self.X = np.array([0.0, h])
        self.l0 = math.hypot(a, h)
        self.f = np.array([tilt * P, -P])

    def _bars(self, u):
        d = self.X + u - self.S  # (2, 2) bar vectors from supports to apex
        ln = np.hypot(d[:, 0], d[:, 1])
        N = self.EA * (ln - self.l0) / self.l0
        return d, ln, N

    def residual(self, u, lam):
        d, ln, N = self._bars(u)
        return (N / ln) @ d - lam * self.f

    def residual_and_tangent(self, u, lam):
        d, ln, N = self._bars(u)
        K = np.zeros((2, 2))
        for di, li, Ni in zip(d, ln, N):
            n = di / li
            K += self.EA / self.l0 * np.outer(n, n) + Ni / li * (np.eye(2) - np.outer(n, n))
        return self.residual(u, lam), sp.csr_matrix(K)

    def external(self, u):
        return self.f.copy()

    def mass(self):
        return sp.csr_matrix(self.m * np.eye(2))

    def strain_energy(self, u):
        _, ln, _ = self._bars(u)
        return float(np.sum(0.5 * self.EA * (ln - self.l0) ** 2 / self.l0))

    def step(self, u, lam, iterations, stable):
        out = {"apex.ux": float(u[0]), "apex.uy": float(u[1]), "apex.y": float(self.h + u[1])}
        return Step(lam, out, self.strain_energy(u), iterations, stable)

    def length_scale(self):
        return self.a

    def node_dofs(self, node):
        return (0, 1)

    def node_xy(self, node):
        return (0.0, self.h)

    # exact symmetric statics: lam(y) for apex height y
    def lam_of_y(self, y):
        ln = math.hypot(self.a, y)
        return -2.0 * self.EA * (ln - self.l0) / self.l0 * y / ln / self.P


class TwoLinkColumn:
    """Two rigid links (length l) with torsion springs k at base and middle, dead load P on top.

    DOFs: link angles from vertical (rad), rotary inertia J each.  Straight state stable iff
    lam P l / k < (3 - sqrt 5) / 2.
    """

    ndof = 2
    rotation_dofs = (0, 1)

    def __init__(self, k=1.0, l=1.0, P=1.0, J=1.0):
        self.k, self.l, self.P, self.J = k, l, P, J
        self.Ks = k * np.array([[2.0, -1.0], [-1.0, 1.0]])

    def residual(self, u, lam):
        return self.Ks @ u - lam * self.external(u)

    def residual_and_tangent(self, u, lam):
        K = self.Ks - lam * self.P * self.l * np.diag(np.cos(u))
        return self.residual(u, lam), sp.csr_matrix(K)

    def external(self, u):
        return self.P * self.l * np.sin(u)

    def mass(self):
        return sp.csr_matrix(self.J * np.eye(2))

    def strain_energy(self, u):
        return float(0.5 * u @ self.Ks @ u)

    def step(self, u, lam, iterations, stable):
        return Step(
            lam, {"th1": float(u[0]), "th2": float(u[1])}, self.strain_energy(u), iterations, stable
        )

    def length_scale(self):
        return 2 * self.l


LAM_CRIT_COLUMN = (3.0 - math.sqrt(5.0)) / 2.0


def truss_branch(tr: VonMisesTruss, lam: float, lo: float, hi: float) -> float:
    """Exact apex height on the branch bracketed by [lo, hi]."""
    return so.brentq(lambda y: tr.lam_of_y(y) - lam, lo, hi, xtol=1e-15)


def truss_limit(tr: VonMisesTruss) -> tuple[float, float]:
    """Upper limit point (y, lam) of the symmetric branch (0 < y < h)."""
    res = so.minimize_scalar(
        lambda y: -tr.lam_of_y(y), bounds=(0.0, tr.h), method="bounded", options={"xatol": 1e-12}
    )
    return res.x, tr.lam_of_y(res.x)


# --------------------------------------------------------------------------------------------
# the integrator on exact systems


def test_settles_to_exact_static_truss():
    tr = VonMisesTruss()
    yl, lcr = truss_limit(tr)
    factors = np.linspace(0, 0.9 * lcr, 4)
    sol = replay_system(tr, factors, options=ReplayOptions(probe="none"))
    assert sol.ok, sol.message
    for st in sol.steps:
        y = truss_branch(tr, st.factor, yl, tr.h + 1e-9)
        assert abs(st.outputs["apex.y"] - y) < 1e-6 * tr.a
        assert abs(st.outputs["apex.ux"]) < 1e-12
        assert st.info["distance"] < 1e-7
    assert sol.extras["jumps"] == []


def test_time_step_convergence_is_second_order():
    """Fixed steps on a ramped, mass-damped truss (the replay's default damping): the error in
    displacement and velocity at T falls as h^2 for the default and another rho_inf."""
    tr = VonMisesTruss()
    T = 6.0  # ~2.6 periods of the lowest mode

    def run(N: int, rho: float) -> np.ndarray:
        integ = GenAlpha(tr, (1.0, 0.0, None), [], np.ones(2), tr.a, rho_inf=rho, newton_tol=1e-14)
        s, h = integ.start(0.0, 0.0, np.zeros(2), np.zeros(2)), T / N
        for i in range(N):
            s = integ.step(s, h, 0.25 * ramp((i + 1) * h / T))
        return np.concatenate([s.q, s.v * T])

    for rho in (0.6, 1.0):
        ref = run(2048, rho)
        Ns = np.array([64, 128, 256])
        err = np.array([np.max(np.abs(run(N, rho) - ref)) for N in Ns])
        order = -np.polyfit(np.log(Ns), np.log(err), 1)[0]
        assert 1.9 < order < 2.1, (rho, order, err)


def test_energy_balance_through_a_snap():
    """External work = strain + kinetic + dissipated (viscous), across a snap-through."""
    tr = VonMisesTruss()
    lcr = truss_limit(tr)[1]
    factors = np.linspace(0.0, 1.3 * lcr, 11)
    errs = []
    for tol in (1e-4, 1e-6):
        sol = replay_system(tr, factors, options=ReplayOptions(probe="none", lte_tol=tol))
        assert sol.ok and len(sol.extras["jumps"]) == 1
        h = sol.extras["history"]
        W, U, T, D = (h[k][-1] for k in ("external_work", "strain", "kinetic", "dissipated"))
        assert W > 0.1 and D > 0.5 * W  # the snap dissipated most of the work
        errs.append(abs(W - (U - h["strain"][0]) - T - D) / W)
    # stated tolerance: 1e-2 at the default step control, 1e-3 at lte_tol = 1e-6
    assert errs[0] < 1e-2 and errs[1] < 1e-3 and errs[1] < errs[0]


@pytest.mark.parametrize("lam", [0.2, 0.37, 0.39, 0.6])
def test_probe_agrees_with_exact_stability_column(lam):
    """Two-link column: straight state stable iff lam P l / k < (3 - sqrt 5) / 2 (held
    there by ``ramp_and_hold``: the default ramp leaves a saddle, ``test_ramp_leaves_...``)."""
    col = TwoLinkColumn()
    sol = replay_system(col, np.array([0.0, lam]), reach=ramp_and_hold)
    assert sol.ok, sol.message
    st = sol.steps[-1]
    exact_eig = (3.0 - 2.0 * lam - math.sqrt(5.0)) / 2.0  # lowest eigenvalue of K at theta = 0
    assert st.info["lowest_eigenvalue"] == pytest.approx(exact_eig, abs=1e-9)
    assert st.stable is (lam < LAM_CRIT_COLUMN)
    assert st.info["tangent_stable"] == float(lam < LAM_CRIT_COLUMN)


def test_auto_probe_kicks_only_near_the_limit_and_the_last_state():
    """probe = "auto" on the two-link column: every state gets the exact verdict; the tangent
    test decides where the lowest eigenvalue (3 - sqrt 5) / 2 - lam is at least 5 % of
    omega_1^2 = (3 - sqrt 5) / 2 away from zero (lam outside (0.363, 0.401)), the kick
    decides within that band and at the last state."""
    factors = np.array([0.0, 0.1, 0.2, 0.3, 0.37, 0.39, 0.5, 0.6])
    sol = replay_system(TwoLinkColumn(), factors, reach=ramp_and_hold)  # straight throughout
    assert sol.ok, sol.message
    verdicts = [p["verdict"] for p in sol.extras["probes"]]
    expected = ["tangent"] * 4 + ["returned", "departed", "tangent", "departed"]
    assert verdicts == expected
    assert [s.stable for s in sol.steps] == [bool(lam < LAM_CRIT_COLUMN) for lam in factors]


COLUMN = """
[case]
name = "straight-column"
title = "Cantilever column under an axial dead load"
units = "nondim"
[[nodes]]
id = "A"
x = 0.0
y = 0.0
[[nodes]]
id = "B"
x = 0.0
y = 1.0
[[members]]
id = "col"
from = "A"
to = "B"
kind = "flexible"
E = 1.0
I = 1.0
A = 1.0e4
[[supports]]
node = "A"
type = "clamp"
[[loads]]
node = "B"
fy = -1.0
[analysis]
kind = "load"
steps = 2
factor_end = 3.0
[[outputs]]
name = "tip"
node = "B"
"""


def test_fe_probe_agrees_with_fe_tangent_test():
    """FE column (P_cr = pi^2 / 4 = 2.47): straight at P = 1.5 stable, at P = 3 unstable; the
    kick verdicts on the straight states (held there by ``ramp_and_hold``) agree with the
    static FE reference's tangent test."""
    sc = cases.loads(COLUMN)
    fs = FEM(8, bifurcation=False).solve(sc)  # the straight branch, as the replay is held
    factors = [s.factor for s in fs.steps]

    def held(**options):
        o = ReplayOptions(**options)
        return replay_system(build(sc, 8), factors, scene=sc, options=o, reach=ramp_and_hold)

    rp = held()
    assert fs.ok and rp.ok, (fs.message, rp.message)
    assert [s.stable for s in fs.steps] == [True, True, False]
    assert [s.stable for s in rp.steps] == [True, True, False]
    assert rp.extras["probes"][-1]["verdict"] == "departed"
    assert abs(rp.steps[-1].outputs["tip.ux"]) < 1e-9  # settled on the (unstable) straight state
    assert "unstable" in rp.message and rp.extras["reference_usable"] is False
    # the thesis's probe: a lateral nodal impulse at the tip instead of the modal kick
    rn = held(probe_node="B", probe_impulse=(1e-3, 0.0))
    assert [s.stable for s in rn.steps] == [True, True, False]


def test_ramp_leaves_a_saddle_onto_the_fe_switched_branch(pick_a_mirror_branch):
    """The default ramp past the perfect column's Euler load: the straight state it is held
    at is a saddle, so it is displaced along the unstable mode (the FE's switch rule) and
    settles on the buckled branch -- the FE's, switched by its bifurcation watch, on the same
    mesh -- stable and usable, with the bifurcation located and classified as the FE does."""
    sc = cases.loads(COLUMN)
    fs, rp = FEM(8).solve(sc), Replay(8).solve(sc)
    assert fs.ok and rp.ok, (fs.message, rp.message)
    assert [s.stable for s in rp.steps] == [True, True, True]
    assert rp.extras.get("reference_usable", True) is not False
    tip, fe_tip = rp.steps[-1].outputs, fs.steps[-1].outputs
    assert abs(fe_tip["tip.ux"]) > 0.3  # buckled (P = 1.2 P_cr)
    for k in ("tip.ux", "tip.uy", "tip.rot"):
        assert tip[k] == pytest.approx(fe_tip[k], abs=1e-7), k
    (cp,) = rp.extras["critical_points"]  # supercritical: a bifurcation, not a snap
    (fe_cp,) = [p for p in fs.extras["critical_points"] if p["kind"] == "bifurcation"]
    assert cp["kind"] == "bifurcation" and cp["switched"] is True
    assert cp["factor"] == pytest.approx(fe_cp["factor"], rel=1e-8)


def test_ramp_leaves_the_two_link_saddle_for_its_exact_buckled_state(pick_a_mirror_branch):
    """Two-link column at lam = 0.6 (straight state unstable past 0.382): the default ramp
    settles on the exact buckled equilibrium Ks th = lam P l sin(th), which is stable."""
    col = TwoLinkColumn()
    sol = replay_system(col, np.array([0.0, 0.3, 0.6]))
    assert sol.ok, sol.message
    th = np.array([sol.steps[-1].outputs["th1"], sol.steps[-1].outputs["th2"]])
    assert np.max(np.abs(th)) > 0.1
    assert np.max(np.abs(col.residual(th, 0.6))) < 1e-10
    exact = so.fsolve(lambda u: col.residual(u, 0.6), th, xtol=1e-14)
    assert th == pytest.approx(exact, abs=1e-9)
    eig = np.linalg.eigvalsh(col.residual_and_tangent(th, 0.6)[1].toarray())
    assert eig[0] > 0.0 and sol.steps[-1].stable is True


def test_cantilever_settles_to_static_fe_reference():
    """Every settled state within 1e-6 L of the static FE at the same mesh (PL^2/EI to 10)."""
    sc = cases.load("cantilever-tip-load")
    fs = FEM(16).solve(sc)
    rp = Replay(16, probe="last").solve(sc)
    assert fs.ok and rp.ok, (fs.message, rp.message)
    assert len(rp.steps) == len(fs.steps) == 21
    for a, b in zip(fs.steps, rp.steps):
        assert a.factor == pytest.approx(b.factor)
        for k in ("tip.x", "tip.y", "tip.ux", "tip.uy", "tip.rot"):
            assert abs(a.outputs[k] - b.outputs[k]) < 1e-6, (b.factor, k)
        assert b.info["distance"] < 1e-7 and np.isfinite(b.info["residual"])
    assert rp.steps[-1].stable is True and rp.extras["jumps"] == []
    assert abs(rp.extras["settle"]["energy_balance_error"]) < 1e-3
    h = rp.extras["history"]
    assert len(h["t"]) <= 2000 and np.all(np.diff(h["t"]) > 0)
    assert {"factor", "kinetic", "strain", "dissipated", "external_work", "tip.uy"} <= set(h)
    assert (
        h["factor"][-1] == pytest.approx(1.0) and h["tip.uy"][-1] == rp.steps[-1].outputs["tip.uy"]
    )


def test_truss_snap_lands_on_exact_far_branch():
    tr = VonMisesTruss()
    yl, lcr = truss_limit(tr)
    factors = np.linspace(0.0, 1.3 * lcr, 11)
    sol = replay_system(tr, factors, options=ReplayOptions(probe="none"))
    assert sol.ok, sol.message
    (j,) = sol.extras["jumps"]
    assert j["from_factor"] < lcr < j["to_factor"]
    assert j["factor_equilibrium"] == pytest.approx(lcr, rel=1e-3)  # onset = limit point
    assert j["before"]["apex.y"] == pytest.approx(yl, abs=0.01 * tr.a)
    for st in sol.steps:
        far = st.factor > lcr
        lo, hi = (-3.0 * tr.h, -yl) if far else (yl, tr.h + 1e-9)
        assert abs(st.outputs["apex.y"] - truss_branch(tr, st.factor, lo, hi)) < 1e-6 * tr.a


def test_bistable_toggle_snap_matches_fe_far_branch():
    """The catalog bistable scene: one jump across the FE limit point, onto the far branch
    of the FE arc-length path (refined by FE Newton at the replay's load factors)."""
    sc = cases.load("bistable-toggle")
    rp = Replay(16, probe="none").solve(sc)
    assert rp.ok, rp.message
    path = replace(sc.analysis, kind="path", stop_output="apex.uy", stop_value=-0.3)
    runner, status, msg = FEM(16).runner(replace(sc, analysis=path))
    assert status == "converged", msg
    lam_max = max(lp["factor"] for lp in runner.extras["limit_points"] if lp["kind"] == "max")
    (j,) = rp.extras["jumps"]
    # the dynamic trajectory lags the ramp, so it leaves the stable region after lam_max;
    # the jump is reported where the static path loses stability: the FE path's asymmetric
    # bifurcation, just before its symmetric limit point
    assert j["from_factor"] < lam_max <= j["factor_dynamic"] <= j["to_factor"]
    (cp,) = runner.extras["critical_points"]
    assert cp["kind"] == "bifurcation" and cp["factor"] < lam_max
    assert j["factor"] == j["factor_static"] == pytest.approx(cp["factor"], rel=1e-6)
    assert j["after"]["apex.uy"] < -0.2 < j["before"]["apex.uy"]
    lam_min = min(lp["factor"] for lp in runner.extras["limit_points"] if lp["kind"] == "min")
    assert lam_min < 0.0  # bistable: the far branch is stable unloaded
    far = [s for s in runner.states if s.lam > 0.5 and runner.system.outputs(s.u)["apex.uy"] < -0.2]
    for st in rp.steps:
        if st.factor < j["to_factor"] - 1e-12:
            continue
        start = min(far, key=lambda s: abs(s.lam - st.factor))
        ref = static.newton(runner.system, start.u, st.factor, static.Options())
        out = runner.system.outputs(ref.u)
        for k in ("apex.x", "apex.y"):
            assert abs(st.outputs[k] - out[k]) < 1e-6, (st.factor, k)


BOOM = """
[case]
name = "boom-lock"
title = "Cantilever pushed by a tape-spring boom that locks at 0.15 m"
units = "m-N-Pa"
[[nodes]]
id = "O"
x = 0.0
y = 0.0
[[nodes]]
id = "A"
x = 0.2
y = 0.0
[[members]]
id = "leaf"
from = "O"
to = "A"
kind = "flexible"
E = 70.0e9
width = 0.01
thickness = 0.001
[[supports]]
node = "O"
type = "clamp"
[[loads]]
node = "A"
fy = -1.0
[analysis]
kind = "load"
steps = 2
[[outputs]]
name = "A"
node = "A"
[[models]]
name = "replay"
[models.options]
probe = "none"
events = [{kind = "lock-length", a = [0.2, -0.1], b = "A", length = 0.15, force = 20.0}]
"""


def test_boom_lock_is_an_exact_event():
    """Boom pushes (20 N) until |A - P| = 0.15 m, then is a bar: located exactly, no chatter."""
    sc = cases.loads(BOOM)
    rp = Replay(4, **sc.model_options("replay")).solve(sc)
    assert rp.ok, rp.message
    (ev,) = rp.extras["events"]
    assert ev["kind"] == "lock" and abs(ev["gap"]) < 1e-12 * 0.2 and ev["lost"] > 0.0
    P = np.array([0.2, -0.1])
    for st in rp.steps:  # the locked length holds exactly while the load changes
        A = np.array([st.outputs["A.x"], st.outputs["A.y"]])
        assert abs(np.linalg.norm(A - P) - 0.15) < 1e-9
        assert st.info["distance"] < 1e-7
    fr = rp.extras["frames"]
    system = build(sc, 4)
    after = [q for t, q in zip(fr["t"], fr["q"]) if t > ev["t"]]
    gaps = [
        np.linalg.norm(system.outputs(q)["A.x"] - P[0] + 1j * (system.outputs(q)["A.y"] - P[1]))
        - 0.15
        for q in after
    ]
    assert len(after) > 5 and max(abs(g) for g in gaps) < 1e-9  # no BISTOP-style oscillation
    # the load moves the locked tip: A rotates about P, not along the bar
    assert rp.steps[0].outputs["A.x"] != rp.steps[-1].outputs["A.x"]


def test_model_interface_and_writers(tmp_path):
    sc = cases.load("cantilever-tip-load")
    assert Replay().applies_to(replace(sc, analysis=replace(sc.analysis, kind="path"))) is None
    kin = replace(sc, analysis=replace(sc.analysis, kind="kinematics"))
    assert Replay().applies_to(kin).startswith("kinematics analyses: ")
    assert Replay.card.name == "replay" and any(
        "10.1115/1.2900803" in r for r in Replay.card.references
    )
    small = replace(sc, analysis=replace(sc.analysis, steps=2))
    rp = Replay(4, probe="none", frames=8).solve(small)
    assert rp.ok and [s.factor for s in rp.steps] == [0.0, 0.5, 1.0]
    gif = write_animation(rp, small, str(tmp_path / "replay.gif"))
    assert (tmp_path / "replay.gif").stat().st_size > 1000 and gif.endswith(".gif")
    xdmf = write_vtu_series(rp, small, str(tmp_path / "vtu"))
    assert xdmf is not None and len(list((tmp_path / "vtu").glob("*.vtu"))) == 8
    with pytest.raises(ValueError):
        Replay(bogus=1)
