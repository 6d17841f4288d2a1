"""The replay on mechanisms: distance and path analyses (servo-held coordinate), driver
analyses, declines.  Checked against closed forms, published numbers and the static FE of the
same mesh (an independent solver: Newton with displacement control), never against the
replay's own numbers.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import cases
import reports
from fem_reference.assembly import build
from fem_reference.models import FEM
from fem_reference.replay import servo as replay_servo
from fem_reference.replay.model import Replay
from fem_reference.statics import static as S
from tests.scene_transforms import Encoding


def _scene(name: str, **analysis: object) -> cases.Scene:
    sc = cases.load(name)
    return dataclasses.replace(sc, analysis=dataclasses.replace(sc.analysis, **analysis))


def _static_at(scene: cases.Scene, n: int, key: str, values: np.ndarray) -> list[float]:
    """Load factors of the static FE (n elements) holding output ``key`` at ``values``:
    Newton with displacement control, stepping from the unloaded state."""
    system = build(scene, n)
    func = system.output_functional(key)
    opts = S.Options()
    st = S.newton(system, np.zeros(system.ndof), 0.0, opts)
    out, prev = [], func[2]
    for v in values:
        st = S.displacement_control(system, st, func, float(v), abs(float(v) - prev) / 8, opts)
        out.append(float(st.lam))
        prev = float(v)
    return out


def test_path_servo_lands_on_the_closed_form_snap_factor():
    """Shallow arch (Williams-type two-bar arch, closed form 1.8302512025 at apex.uy = -0.25):
    the settled factor at the stop output, and the symmetric apex (ux = 0)."""
    sol = Replay(n_elements=16, probe="none").solve(_scene("shallow-arch-snap", steps=4))
    assert sol.status == "converged", sol.message
    last = sol.steps[-1]
    assert last.outputs["apex.uy"] == pytest.approx(-0.25, abs=1e-6)
    assert last.factor == pytest.approx(1.8302512025074982, rel=1e-6)
    assert abs(last.outputs["apex.ux"]) < 1e-9
    # the falling branch between the limit points was settled too (load control cannot)
    assert min(s.factor for s in sol.steps) < 0.0


def test_lee_frame_path_equals_static_fe_and_published_limit():
    """Lee's frame, servo on corner.uy with the load elsewhere (held at the load point, the
    target landed by secant): every settled factor equals the static FE of the same mesh at
    the same corner.uy to the settling tolerance; the largest is near Lee's published 18.5."""
    scene = _scene("lee-frame", steps=20)
    sol = Replay(n_elements=16, probe="none").solve(scene)
    assert sol.status == "converged", sol.message
    uy = np.array([s.outputs["corner.uy"] for s in sol.steps[1:]])
    full = build(scene, 1)
    aim = replay_servo.aim_tolerance(np.array([0.0, -100.0]), (0, 1.0, 0.0), 1e-7, full)
    np.testing.assert_allclose(uy, np.linspace(-5.0, -100.0, 20), rtol=0, atol=aim)
    fe = _static_at(scene, 16, "corner.uy", uy)
    got = [s.factor for s in sol.steps[1:]]
    np.testing.assert_allclose(got, fe, rtol=1e-5, atol=1e-5 * max(map(abs, fe)))
    assert max(got) == pytest.approx(18.5, rel=5e-3)  # grid max on a 16-element mesh


def test_distance_servo_settles_on_the_stable_asymmetric_branch(monkeypatch):
    """DAS-2D Ex. 3 without its shuttle guide: where the FE's symmetric path is stable (its
    own tangent test) the replay's factors equal the FE's; beyond, the FE's symmetric path is
    unstable (its own tangent test) and the replay settles on a tilted branch of static
    equilibria which the static FE confirms: Newton from those states stays there."""
    settled = []
    make = replay_servo._probe_under_load

    def capture(servo, options, scene):
        inner = make(servo, options, scene)

        def stab(run, s, chk, want, sc):
            settled.append(servo.full_state(s.q, s.lam))
            return inner(run, s, chk, want, sc)

        return stab

    monkeypatch.setattr(replay_servo, "_probe_under_load", capture)
    guided = _scene("das2d-ex3-bistable-switch", steps=12)
    unguided = tuple(s for s in guided.supports if s.node not in ("S1", "S2"))
    assert len(unguided) == len(guided.supports) - 2
    scene = dataclasses.replace(guided, supports=unguided)
    sol = Replay(n_elements=8, probe="none").solve(scene)
    assert sol.status == "converged", sol.message
    x = np.array([s.outputs["shuttle_top.ux"] for s in sol.steps])
    targets = np.linspace(0.0, 17.397238, 13)
    aim = replay_servo.aim_tolerance(targets, (0, 1.0, 0.0), 1e-7, build(scene, 1))
    np.testing.assert_allclose(x, targets, rtol=0, atol=aim)
    fem = FEM(8).solve(scene)  # the FE's symmetric path and its own stability verdicts
    stable = [k for k, s in enumerate(fem.steps) if s.stable]
    assert len(stable) >= 2
    for k in stable:  # where the FE's path is stable the replay is on it
        assert sol.steps[k].factor == pytest.approx(fem.steps[k].factor, rel=1e-5, abs=1e-9)
    tilted = [k for k, s in enumerate(sol.steps) if abs(s.outputs["shuttle_top.rot"]) > 1e-3]
    assert tilted, "expected the shuttle to tilt past the bifurcation"
    assert all(fem.steps[k].stable is False for k in tilted)
    system = build(scene, 8)
    func = system.output_functional("shuttle_top.ux")
    for k in tilted[:3]:  # Newton from the replay's state, coordinate held: stays there
        q, lam = settled[k]
        got = S.displacement_control(system, S.State(q, lam), func, x[k], 1e-9, S.Options())
        assert got.lam == pytest.approx(lam, rel=1e-5)
        assert np.max(np.abs(got.u - q)) < 1e-5 * system.length_scale()


def test_toggle_clamp_driver_force_and_ma_against_closed_form():
    """Toggle clamp (rigid links + springs; a 6-DOF system, narrower than its band storage):
    the replayed driver force equals the closed form to 1e-6 (a residual force of the stiff
    rigid-link elements at the Newton-finished state: ~1e-7 off; a state only settled to
    1e-11 L put it 9e-6 .. 3e-5 off) and the MA (finite differences over the 1 mm steps,
    second order) to 3e-4."""
    sol = Replay(probe="none").solve(cases.load("toggle-clamp-ma"))
    assert sol.status == "converged", sol.message
    at = {round(s.factor, 9): s.outputs for s in sol.steps}
    for x, force, ma in (
        (0.0, -11.547005383792516, None),
        (-0.02, -6.28970902033151, -1.5898986690282428),
        (-0.04, -2.0100756305184246, -4.974937185533099),
    ):
        assert at[x]["driver.force"] == pytest.approx(force, rel=1e-6)
        if ma is not None:
            assert at[x]["ma"] == pytest.approx(ma, rel=3e-4)


@pytest.mark.parametrize(
    "units", [("m-N-Pa", 1.0, 1.0), ("mm-N-MPa", 1e3, 1.0), ("in-lbf-psi", 1 / 0.0254, 0.2248)]
)
def test_toggle_clamp_rigid_links_as_stiff_in_any_units(units):
    """Toggle clamp (rigid links only, no elastic part) in other units: the stiff elements
    that stand for the rigid links keep the slider at the closed form x_C = 2 sqrt(L^2 - y_B^2)
    to 1e-6 L in every unit system (their stiffness scale came from "1" in the scene's units:
    in mm the links stretched 1.3e-4 L under the 10 N workpiece force)."""
    scene = cases.load("toggle-clamp-ma")
    enc = Encoding("units", units={"m-N-Pa": units}).for_scene(scene)
    sol = Replay(probe="none").solve(enc.scene(scene))
    assert sol.status == "converged", sol.message
    L = 0.1
    for s in sol.steps:
        x = enc.outputs_back(scene, dict(s.outputs))["slider.x"]
        y_b = 0.05 + enc.factor_back(scene, s.factor)
        assert abs(x - 2 * math.sqrt(L**2 - y_b**2)) < 1e-6 * L


def test_spring_truss_gets_point_masses_and_matches_closed_form():
    """Von Mises truss of two springs (no member mass at all: the replay adds point masses):
    driving force F = -2 k (L0 - L)(h - w) / L, energy k (L - L0)^2, barrier k (a - L0)^2."""
    sol = Replay(probe="none").solve(cases.load("von-mises-spring-truss"))
    assert sol.status == "converged", sol.message
    assert sol.extras["settle"]["point_masses_added"] > 0
    k, a, h = 2.0e4, 0.1, 0.02
    L0 = math.hypot(a, h)
    for s in sol.steps:
        w = -s.factor
        L = math.hypot(a, h - w)
        F = -2.0 * k * (L0 - L) * (h - w) / L
        assert s.outputs["driver.force"] == pytest.approx(F, rel=1e-9, abs=1e-9 * 6.04)
        assert s.energy == pytest.approx(k * (L - L0) ** 2, rel=1e-9, abs=1e-12)
    assert sol.extras["barrier"] == pytest.approx(k * (a - L0) ** 2, rel=1e-9)


def test_parallelogram_dy_at_30N_within_the_stated_mesh_error():
    """DAS-2D Ex. 2, coupler dy at 30 N against fem-auto's 25.346995 mm (the case reference):
    the replay's own mesh-error estimate (stated in its message) must cover its error."""
    sol = Replay(probe="none").solve(_scene("das2d-ex2-parallelogram", steps=4))
    assert sol.status == "converged", sol.message
    got = sol.steps[-1].outputs["coupler_low.uy"]
    est = sol.extras["mesh_error_estimate"]["coupler_low.uy"]
    assert abs(got - 25.346995) <= 2.0 * est + 1e-6 * 25.35
    assert abs(got - 25.346995) < 1e-3 * 25.35  # and the estimate is not vacuous


@pytest.mark.parametrize(
    "case, why",
    [
        ("das2d-ex1-peaucellier", "kinematics analyses: a linkage without flexible members"),
        ("das2d-ex6-bistable-synthesis", "synthesis analyses: the replay replays a given"),
    ],
)
def test_remaining_declines_name_their_reason(case, why):
    sol = Replay().solve(cases.load(case))
    assert sol.status == "not-applicable"
    assert sol.message.startswith(why)


@pytest.mark.parametrize("kind", ["load", "distance"])
def test_a_mechanism_without_flexible_members_is_declined_with_the_reason(kind):
    """A rigid bar pinned at its root on a torsion spring, a tip load: only beam elements
    carry mass in the replay, so there is nothing to integrate (ramped, it 'did not settle
    within 400 T1'; driven, its time step underflowed).  Declined with the reason; the
    kinetostatic model solves it (lam = theta / sin theta for the driven bar)."""
    from cases.schema import Driver

    text = "\n".join(
        [
            '[case]\nname = "bar-on-a-spring"\ntitle = "rigid bar on a spring"',
            'units = "nondim"',
            '[[nodes]]\nid = "A"\nx = 0.0\ny = 0.0',
            '[[nodes]]\nid = "B"\nx = 0.0\ny = 1.0',
            '[[members]]\nid = "bar"\nfrom = "A"\nto = "B"\nkind = "rigid"',
            '[[supports]]\nnode = "A"\ntype = "pin"',
            '[[loads]]\nnode = "B"\nfx = 0.3\nfy = -0.5',
            '[[torsion_springs]]\nid = "ts"\nnode = "A"\nmember_a = "bar"\nstiffness = 1.0',
            '[analysis]\nkind = "load"\nsteps = 4',
            '[[outputs]]\nname = "tip"\nnode = "B"',
        ]
    )
    scene = cases.loads(text)
    if kind == "distance":
        drive = Driver("rotation", 0.0, -60.0, member="bar")
        scene = dataclasses.replace(
            scene, analysis=dataclasses.replace(scene.analysis, kind="distance", driver=drive)
        )
    sol = reports.solve(scene, "replay")
    assert sol.status == "not-applicable" and "no flexible member" in sol.message
    assert reports.solve(scene, "kinetostatic").status == "converged"
