"""Hostile scenes of the outside review (issue 23), each with its own truth (a judge).

Every builder returns ``(scene dict, judge, models)``; ``judge(sol) -> list[str]`` lists what is
wrong with a converged solution (empty: right).  Not collected by pytest.
"""

from __future__ import annotations

import math
import re

import numpy as np

from tests.hostile_review_lib import buckled_column, elastica_path, natural_path

BEAM_MODELS = [
    "elastica",
    "elastica-bvp",
    "linear-auto",
    "prb-1r",
    "prb-3r",
    "prb-fsm-auto",
    "bcm",
    "cbcm-auto",
    "fem-8",
    "fem-auto",
    "replay",
]
MECH_MODELS = ["kinetostatic", "fem-8", "fem-auto", "replay", "elastica", "cbcm-8"]
EXACT = {"elastica": 1e-4, "elastica-bvp": 1e-4, "fem-8": 5e-2, "replay": 2e-2}


def _node(i, x, y):
    return {"id": i, "x": float(x), "y": float(y)}


def _case(name, units, title):
    name = re.sub("-+", "-", re.sub("[^a-z0-9-]", "-", name.lower())).strip("-")
    return {"case": {"name": name, "title": title, "units": units}}


def _tol(model, sol, scale):
    """Relative tolerance a converged answer of ``model`` must meet (gross for reduced
    models: three times their own predicted error, at least 5 %)."""
    if model == "fem-auto":
        est = sol.extras.get("error_estimate") or {}
        e = max([abs(v) for v in est.values() if np.isfinite(v)] or [0.0])
        return 3 * e / scale + 1e-5
    if model in EXACT:
        return EXACT[model]
    pe = sol.extras.get("predicted_error")
    if isinstance(pe, dict):
        pe = max([v for v in pe.values() if isinstance(v, (int, float))] or [0.0])
    pe = pe if isinstance(pe, (int, float)) and np.isfinite(pe) else 0.0
    return max(3 * pe, 0.05)


def _tip_judge(truths, model, p="tip", mirror_ok=False):
    """Judge tip.x/y against one of several truth functions factor -> (x, y, th)."""

    def judge(sol):
        fs = [s.factor for s in sol.steps]
        best = None
        for tr in truths:
            ref = tr(fs)
            x0, y0 = ref[0][0], ref[0][1]
            scale = max(math.hypot(r[0] - x0, r[1] - y0) for r in ref) or 1.0
            tol = _tol(model, sol, scale)
            worst, at = 0.0, None
            blind = set(sol.extras.get("unpredicted_factors") or ())
            for i, (s, r) in enumerate(zip(sol.steps, ref)):
                if s.stable is False:
                    continue  # flagged unstable: an honest equilibrium off the natural path
                if s.factor in blind and sol.extras.get("validity_warning"):
                    continue  # a reduced model's state outside its range, without a prediction
                x, y = s.outputs[f"{p}.x"], s.outputs[f"{p}.y"]
                if mirror_ok:
                    x = x0 + math.copysign(abs(x - x0), r[0] - x0)
                # fem-auto's estimate is for the last step; elsewhere a gross 1e-3
                t = tol if model != "fem-auto" or i == len(ref) - 1 else max(tol, 1e-3)
                e = math.hypot(x - r[0], y - r[1]) / scale / t
                if not e <= worst:
                    worst, at = e, s.factor
            if best is None or worst < best[0]:
                best = (worst, at, tol)
        if best[0] > 1.0:
            return [
                f"tip off the truth by {best[0]:.3g} times its tolerance at factor {best[1]:.4g} "
                f"(tol {best[2]:.2g} of the excursion)"
            ]
        return []

    return judge


def column(P_mult, eps, A, units="nondim"):
    """Vertical cantilever column, axial P = P_mult * Pcr, transverse eps * P at the tip."""
    L, EI = 1.0, 1.0
    P = P_mult * math.pi**2 * EI / (4 * L**2)
    name = f"col-{P_mult:g}x-eps{eps:g}-A{A:g}"
    sc = _case(name, units, f"cantilever column {P_mult}x Euler, imperfection {eps}")
    sc["nodes"] = [_node("A", 0, 0), _node("B", 0, L)]
    sc["members"] = [
        {"id": "col", "from": "A", "to": "B", "kind": "flexible", "E": 1.0, "I": 1.0, "A": A}
    ]
    sc["supports"] = [{"node": "A", "type": "clamp"}]
    sc["loads"] = [{"node": "B", "fx": eps * P, "fy": -P}]
    sc["analysis"] = {"kind": "load", "steps": 24}
    sc["outputs"] = [{"name": "tip", "node": "B"}]
    cache = {}

    def truth(EA):
        def tr(fs):
            key = (EA, tuple(fs))
            if key not in cache:
                if eps > 0:
                    cache[key] = natural_path(fs, L, EI, EA, math.pi / 2, (eps * P, -P))
                    # the natural path leans the way the imperfection pushes
                    assert all(r[0] >= -1e-12 for r in cache[key]), "truth left its branch"
                else:  # perfect: straight below Euler, buckled branch above it
                    pc = math.pi**2 * EI / (4 * L**2)
                    cache[key] = [
                        buckled_column(f * P, L, EI, EA)
                        if f * P > pc * 1.0001
                        else (0.0, L * (1 - f * P / EA), math.pi / 2)
                        for f in fs
                    ]
            return cache[key]

        return tr

    def judges(model):
        return _tip_judge([truth(A), truth(1e30)], model, mirror_ok=eps == 0)

    return sc, judges, BEAM_MODELS


def pinned_root(fx, fy, units="nondim", A=1e4, k_root=0.0):
    """A beam pinned (not clamped) at its root: hangs along the force (a weak root spring
    k_root, if any, holds it back by about k_root * angle / (F L) rad)."""
    name = f"pinned-root-{fx:g}-{fy:g}-k{k_root:g}-{units}"
    sc = _case(name, units, "beam pinned at the root, tip force")
    sc["nodes"] = [_node("A", 0, 0), _node("B", 1.0, 0)]
    sc["members"] = [
        {"id": "beam", "from": "A", "to": "B", "kind": "flexible", "E": 1.0, "I": 1.0, "A": A}
    ]
    sc["supports"] = [{"node": "A", "type": "pin"}]
    if k_root:  # the loader refuses a bare mechanism: a weak spring to ground keeps it a scene
        sc["torsion_springs"] = [{"id": "k", "node": "A", "member_a": "beam", "stiffness": k_root}]
    sc["loads"] = [{"node": "B", "fx": fx, "fy": fy}]
    sc["analysis"] = {"kind": "load", "steps": 10}
    sc["outputs"] = [{"name": "tip", "node": "B"}]
    ang = math.atan2(fy, fx)
    F = math.hypot(fx, fy)

    def judges(model):
        def judge(sol):
            bad = []
            prev = 0.0
            for s in sol.steps:
                r = s.outputs["tip.rot"]
                if abs(r - prev) > math.pi:
                    bad.append(f"rotation jumps {r - prev:.4g} rad at factor {s.factor:.3g}")
                    break
                prev = r
            s = sol.steps[-1]
            ln = 1.0 + s.factor * F / A
            ex, ey = ln * math.cos(ang), ln * math.sin(ang)
            e = math.hypot(s.outputs["tip.x"] - ex, s.outputs["tip.y"] - ey)
            er = abs(s.outputs["tip.rot"] - ang)
            lim = 1e-3 + 3 * k_root * abs(ang) / (s.factor * F)
            if e > lim or er > lim:
                bad.append(
                    f"final state not the hanging one: tip off by {e:.3g} L, "
                    f"rot {s.outputs['tip.rot']:.6g} vs {ang:.6g}"
                )
            return bad

        return judge

    return sc, judges, BEAM_MODELS


def follower(Pn, steps=30, units="nondim"):
    """Cantilever with a follower tip force normal to the tip, up to Pn EI/L^2."""
    name = f"follower-{Pn:g}"
    sc = _case(name, units, "cantilever, follower tip force to a large factor")
    sc["nodes"] = [_node("A", 0, 0), _node("B", 1.0, 0)]
    sc["members"] = [
        {"id": "beam", "from": "A", "to": "B", "kind": "flexible", "E": 1.0, "I": 1.0, "A": 1e4}
    ]
    sc["supports"] = [{"node": "A", "type": "clamp"}]
    sc["loads"] = [{"node": "B", "fy": -Pn, "follower": True}]
    sc["analysis"] = {"kind": "load", "steps": steps}
    sc["outputs"] = [{"name": "tip", "node": "B"}]
    cache = {}

    def truth(EA):
        def tr(fs):
            key = (EA, tuple(fs))
            if key not in cache:
                cache[key] = elastica_path(fs, 1.0, 1.0, EA, 0.0, (0.0, -Pn), follower=True)
            return cache[key]

        return tr

    def judges(model):
        tj = _tip_judge([truth(1e4), truth(1e30)], model)

        def judge(sol):
            bad = tj(sol)
            st = [s.factor for s in sol.steps if s.stable is not None]
            if st:
                bad.append(f"static stability verdict under a follower load at {len(st)} steps")
            return bad

        return judge

    return sc, judges, BEAM_MODELS


def _link_judge(links, reach):
    """Rigid links (pairs of output points or a fixed point, length) keep their length; no
    converged step past ``reach`` (a predicate on the factor)."""

    def judges(model):
        def judge(sol):
            bad = []
            for s in sol.steps:
                o = s.outputs
                for a, b, ln in links:
                    pa = a if isinstance(a, tuple) else (o[f"{a}.x"], o[f"{a}.y"])
                    pb = (o[f"{b}.x"], o[f"{b}.y"])
                    d = math.hypot(pa[0] - pb[0], pa[1] - pb[1])
                    if abs(d - ln) > 1e-6 * ln:
                        bad.append(
                            f"rigid link {a}-{b} {d:.6g} long instead of {ln:.6g} "
                            f"at factor {s.factor:.4g}"
                        )
                        return bad
                if not reach(s.factor):
                    bad.append(f"converged step at driver {s.factor:.4g}, past the reach")
                    return bad
            return bad

        return judge

    return judges


def slider_crank_past_reach():
    """Slider-crank (m-N-Pa): crank 50 mm at 60 deg, coupler 120 mm; slider driven +60 mm,
    the farthest it can go is r + l = 170 mm from the pivot (33.1 mm of travel)."""
    r, l = 0.05, 0.12
    bx, by = r * math.cos(math.radians(60)), r * math.sin(math.radians(60))
    cx = bx + math.sqrt(l**2 - by**2)
    sc = _case("slider-crank-past-reach", "m-N-Pa", "slider-crank driven past its reach")
    sc["nodes"] = [_node("O", 0, 0), _node("B", bx, by), _node("C", cx, 0)]
    sc["members"] = [
        {"id": "crank", "from": "O", "to": "B", "kind": "rigid", "end_b": "pin"},
        {"id": "coupler", "from": "B", "to": "C", "kind": "rigid", "end_a": "pin", "end_b": "pin"},
    ]
    sc["supports"] = [
        {"node": "O", "type": "pin"},
        {"node": "C", "type": "slider", "angle_deg": 0.0},
    ]
    sc["torsion_springs"] = [{"id": "k1", "node": "O", "member_a": "crank", "stiffness": 2.0}]
    sc["analysis"] = {
        "kind": "energy",
        "steps": 30,
        "driver": {
            "kind": "displacement",
            "node": "C",
            "direction": "x",
            "start": 0.0,
            "stop": 0.06,
        },
    }
    sc["outputs"] = [{"name": "crank_tip", "node": "B"}, {"name": "slider", "node": "C"}]
    reach = r + l - cx
    judges = _link_judge(
        [((0.0, 0.0), "crank_tip", r), ("crank_tip", "slider", l)], lambda f: f <= reach + 1e-9
    )
    return sc, judges, ["kinetostatic", "fem-8", "fem-auto", "replay", "thesis-force-method"]


def rigid_triangle_driven():
    """Two rigid links pinned to ground and to each other: a structure; its apex driven."""
    sc = _case("rigid-triangle-driven", "mm-N-MPa", "rigid triangle whose apex is driven")
    sc["nodes"] = [_node("A", 0, 0), _node("B", 100, 0), _node("C", 50, 80)]
    sc["members"] = [
        {"id": "ac", "from": "A", "to": "C", "kind": "rigid", "end_a": "pin", "end_b": "pin"},
        {"id": "bc", "from": "B", "to": "C", "kind": "rigid", "end_a": "pin", "end_b": "pin"},
    ]
    sc["supports"] = [{"node": "A", "type": "pin"}, {"node": "B", "type": "pin"}]
    sc["torsion_springs"] = [{"id": "k", "node": "A", "member_a": "ac", "stiffness": 100.0}]
    sc["analysis"] = {
        "kind": "energy",
        "steps": 10,
        "driver": {
            "kind": "displacement",
            "node": "C",
            "direction": "x",
            "start": 0.0,
            "stop": 5.0,
        },
    }
    sc["outputs"] = [{"name": "apex", "node": "C"}]
    ln = math.hypot(50, 80)
    judges = _link_judge(
        [((0.0, 0.0), "apex", ln), ((100.0, 0.0), "apex", ln)], lambda f: abs(f) < 1e-9
    )
    return sc, judges, ["kinetostatic", "fem-8", "fem-auto", "replay", "thesis-force-method"]


def fourbar_past_dead_point():
    """Non-Grashof four-bar (ground 1, crank 0.6, coupler 0.5, rocker 0.6, m): crank
    rotation driven 0..200 deg from 60 deg; it locks where |B - D| reaches 1.1."""
    a, b, c = 0.6, 0.5, 0.6
    th = math.radians(60)
    B = (a * math.cos(th), a * math.sin(th))
    D = (1.0, 0.0)
    d = math.hypot(D[0] - B[0], D[1] - B[1])
    # circle intersection, the upper one
    al = (b**2 - c**2 + d**2) / (2 * d)
    h = math.sqrt(b**2 - al**2)
    ex, ey = (D[0] - B[0]) / d, (D[1] - B[1]) / d
    C = (B[0] + al * ex - h * ey, B[1] + al * ey + h * ex)
    sc = _case("fourbar-past-dead-point", "m-N-Pa", "non-Grashof four-bar, crank driven too far")
    sc["nodes"] = [_node("A", 0, 0), _node("B", *B), _node("C", *C), _node("D", *D)]
    sc["members"] = [
        {"id": "crank", "from": "A", "to": "B", "kind": "rigid", "end_b": "pin"},
        {"id": "coupler", "from": "B", "to": "C", "kind": "rigid", "end_a": "pin", "end_b": "pin"},
        {"id": "rocker", "from": "D", "to": "C", "kind": "rigid", "end_b": "pin"},
    ]
    sc["supports"] = [{"node": "A", "type": "pin"}, {"node": "D", "type": "pin"}]
    sc["torsion_springs"] = [{"id": "k", "node": "D", "member_a": "rocker", "stiffness": 1.0}]
    sc["analysis"] = {
        "kind": "energy",
        "steps": 40,
        "driver": {"kind": "rotation", "member": "crank", "start": 0.0, "stop": 200.0},
    }
    sc["outputs"] = [{"name": "b", "node": "B"}, {"name": "c", "node": "C"}]
    lim = math.degrees(math.acos((a**2 + 1 - 1.1**2) / (2 * a))) - 60.0  # |B-D| = 1.1

    judges = _link_judge(
        [((0.0, 0.0), "b", a), ("b", "c", b), ((1.0, 0.0), "c", c)], lambda f: f <= lim + 1e-6
    )
    return sc, judges, ["kinetostatic", "fem-8", "fem-auto", "replay", "thesis-force-method"]


def overstretch(direction, stop, units="nondim"):
    """Cantilever tip driven far: past a 20 % strain every model must decline."""
    if units == "nondim":
        L, mem = 1.0, {"E": 1.0, "I": 1.0, "A": 1e4}
    else:  # steel flexure in mm-N-MPa: 50 x 10 x 0.5 mm
        L, mem = 50.0, {"E": 2.0e5, "width": 10.0, "thickness": 0.5}
    sc = _case(f"overstretch-{direction}-{units}", units, "cantilever tip driven far")
    sc["nodes"] = [_node("A", 0, 0), _node("B", L, 0)]
    sc["members"] = [{"id": "beam", "from": "A", "to": "B", "kind": "flexible", **mem}]
    sc["supports"] = [{"node": "A", "type": "clamp"}]
    sc["analysis"] = {
        "kind": "energy",
        "steps": 20,
        "driver": {
            "kind": "displacement",
            "node": "B",
            "direction": direction,
            "start": 0.0,
            "stop": stop * L,
        },
    }
    sc["outputs"] = [{"name": "tip", "node": "B"}]

    def judges(model):
        def judge(sol):
            for s in sol.steps:
                ch = math.hypot(s.outputs["tip.x"], s.outputs["tip.y"]) / L - 1.0
                if ch > 0.21:
                    return [f"converged at a mean axial strain >= {ch:.3g} (factor {s.factor:.4g})"]
            return []

        return judge

    return sc, judges, BEAM_MODELS


def bistable(variant="sym", units="m-N-Pa"):
    """A bistable switch of my own proportions (legs of a soft long and a stiff short part,
    shuttle between them, pinned feet), pushed sideways at the shuttle's middle."""
    s = 1e-3 if units == "m-N-Pa" else 1.0
    Em = 1e6 if units == "m-N-Pa" else 1.0
    # own geometry: feet at +-32, knees at (-13, +-12), shuttle ends at (-16, +-6) (mm)
    nodes = [
        _node("F1", 0, -32 * s),
        _node("K1", -13 * s, -12 * s),
        _node("S1", -16 * s, -6 * s),
        _node("S2", -16 * s, 6 * s),
        _node("K2", -13 * s, 12 * s),
        _node("F2", 0, 32 * s),
    ]
    tb = 6.0 * (1.03 if variant == "asym" else 1.0)
    shuttle = {"id": "shuttle", "from": "S1", "to": "S2", "kind": "rigid"}
    if variant == "flexshuttle":
        shuttle = {
            "id": "shuttle",
            "from": "S1",
            "to": "S2",
            "kind": "flexible",
            "E": 2550.0 * Em,
            "width": 5 * s,
            "thickness": 4 * s,
        }
    sc = _case(f"bistable-{variant}-{units}", units, "bistable switch ramped past its snap")
    sc["nodes"] = nodes
    sc["members"] = [
        {
            "id": "long_b",
            "from": "F1",
            "to": "K1",
            "kind": "flexible",
            "E": 6.1 * Em,
            "width": 5 * s,
            "thickness": tb * s,
        },
        {
            "id": "short_b",
            "from": "K1",
            "to": "S1",
            "kind": "flexible",
            "E": 2550.0 * Em,
            "width": 5 * s,
            "thickness": 3 * s,
        },
        shuttle,
        {
            "id": "short_t",
            "from": "S2",
            "to": "K2",
            "kind": "flexible",
            "E": 2550.0 * Em,
            "width": 5 * s,
            "thickness": 3 * s,
        },
        {
            "id": "long_t",
            "from": "K2",
            "to": "F2",
            "kind": "flexible",
            "E": 6.1 * Em,
            "width": 5 * s,
            "thickness": 6 * s,
        },
    ]
    sc["supports"] = [{"node": "F1", "type": "pin"}, {"node": "F2", "type": "pin"}]
    frac = 0.6 if variant == "offload" else 0.5  # off-centre push: an imperfect bifurcation
    sc["loads"] = [{"id": "push", "member": "shuttle", "fraction": frac, "fx": 30.0}]
    sc["analysis"] = {"kind": "load", "steps": 20}
    sc["outputs"] = [{"name": "sh", "node": "S2"}, {"name": "kn", "node": "K2"}]
    state = {}

    def judges(model):
        def judge(sol):
            bad = []
            cps = sol.extras.get("critical_points") or []
            if not any(c.get("kind") == "snap" for c in cps):
                # a jump of the shuttle travel between two steps is a snap that must be said
                ux = [st.outputs["sh.ux"] for st in sol.steps]
                jumps = np.diff(ux)
                if len(jumps) and max(jumps) > 5 * np.median(np.abs(jumps)) + 1e-12:
                    k = int(np.argmax(jumps))
                    bad.append(
                        f"unreported jump of sh.ux {ux[k]:.4g} -> {ux[k + 1]:.4g} "
                        f"after factor {sol.steps[k].factor:.4g}"
                    )
            ref = state.get("elastica")
            if ref is not None and model != "elastica":
                scale = max(abs(v) for v in ref) or 1.0
                ux = [st.outputs["sh.ux"] for st in sol.steps]
                if len(ux) == len(ref):
                    tol = _tol(model, sol, scale)
                    e = max(abs(a - b) for a, b in zip(ux, ref)) / scale
                    if e > tol:
                        bad.append(
                            f"shuttle travel off elastica by {e:.3g} of its excursion "
                            f"(tol {tol:.2g}); "
                            f"final {ux[-1]:.6g} vs {ref[-1]:.6g}"
                        )
            if model == "elastica" and sol.status == "converged":
                state["elastica"] = [st.outputs["sh.ux"] for st in sol.steps]
            return bad

        return judge

    return sc, judges, ["elastica", "fem-8", "fem-auto", "cbcm-8", "replay"]


def lee_follower(units="mm-N-MPa"):
    """Lee's frame proportions (mm) with a follower load to 15 EI/L^2; truth: fem-auto."""
    sc = _case(f"lee-follower-{units}", units, "Lee-style frame, follower load")
    sc["nodes"] = [_node("A", 0, 0), _node("B", 0, 120), _node("D", 24, 120), _node("C", 120, 120)]
    mem = {"kind": "flexible", "E": 720.0, "I": 2.0, "A": 6.0}
    sc["members"] = [
        {"id": "col", "from": "A", "to": "B", **mem},
        {"id": "b1", "from": "B", "to": "D", **mem},
        {"id": "b2", "from": "D", "to": "C", **mem},
    ]
    sc["supports"] = [{"node": "A", "type": "pin"}, {"node": "C", "type": "pin"}]
    sc["loads"] = [{"node": "D", "fy": -1.5, "follower": True}]
    sc["analysis"] = {"kind": "load", "steps": 20}
    sc["outputs"] = [{"name": "load", "node": "D"}]
    state = {}

    def judges(model):
        def judge(sol):
            bad = []
            if any(s.stable is not None for s in sol.steps):
                bad.append("static stability verdict under a follower load")
            if model == "fem-auto" and sol.status == "converged":
                state["ref"] = [(s.outputs["load.ux"], s.outputs["load.uy"]) for s in sol.steps]
            ref = state.get("ref")
            if ref and model != "fem-auto" and len(ref) == len(sol.steps):
                scale = max(math.hypot(*r) for r in ref)
                e = (
                    max(
                        math.hypot(s.outputs["load.ux"] - r[0], s.outputs["load.uy"] - r[1])
                        for s, r in zip(sol.steps, ref)
                    )
                    / scale
                )
                tol = _tol(model, sol, scale)
                if e > tol:
                    bad.append(
                        f"load point off fem-auto by {e:.3g} of its excursion (tol {tol:.2g})"
                    )
            return bad

        return judge

    return sc, judges, ["fem-auto", "fem-8", "replay", "elastica", "cbcm-auto"]


def all_scenes():
    """The review's hostile scenes, in run order."""
    return [
        slider_crank_past_reach(),
        rigid_triangle_driven(),
        fourbar_past_dead_point(),
        bistable("sym"),
        bistable("asym"),
        bistable("flexshuttle"),
        bistable("offload"),
        bistable("sym", units="mm-N-MPa"),
        pinned_root(0.0, -1.0),
        pinned_root(0.0, -1.0, k_root=1e-3),
        pinned_root(1.0, -1.0, k_root=1e-3),
        pinned_root(-3.0, -1.0, k_root=1e-3),
        follower(3.0),
        follower(20.0),
        overstretch("x", 5.0),
        overstretch("y", 3.0, units="mm-N-MPa"),
        column(6.0, 1e-3, 1e4),
        column(3.0, 1e-4, 1e4),
        column(6.0, 1e-2, 1e3),
        column(3.0, 1e-3, 1e5),
        column(6.0, 0.0, 1e4),
        column(1.2, 1e-3, 1e4),
        lee_follower(),
    ]
