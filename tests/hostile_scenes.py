"""Hostile mechanism scenes (tests/test_mechanism_hostile.py): base geometry in mm-N-MPa,
transformed (rotation, translation, units, node order) and emitted as TOML."""

import math


def toml(name, nodes, members, supports, loads, outputs, springs=(), steps=10, units="mm-N-MPa"):
    out = [f'[case]\nname = "{name}"\ntitle = "hostile"\nunits = "{units}"\n']
    for n in nodes:
        out.append(f'[[nodes]]\nid = "{n[0]}"\nx = {n[1]!r}\ny = {n[2]!r}\n')
    for m in members:
        s = "[[members]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in m.items())
        out.append(s)
    for s in supports:
        out.append(
            "[[supports]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in s.items())
        )
    for t in springs:
        out.append(
            "[[torsion_springs]]\n"
            + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in t.items())
        )
    for l in loads:
        out.append(
            "[[loads]]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in l.items())
        )
    out.append(f'[analysis]\nkind = "load"\nsteps = {steps}\n')
    for o in outputs:
        out.append(f'[[outputs]]\nname = "{o[0]}"\nnode = "{o[1]}"\n')
    return "\n".join(out)


def transform(sc, phi=0.0, dx=0.0, dy=0.0, meters=False, reverse=False):
    """sc: dict(nodes, members, supports, loads, springs, outputs). Returns new dict."""
    c, s = math.cos(math.radians(phi)), math.sin(math.radians(phi))
    L = 1e-3 if meters else 1.0
    nodes = [(i, L * (c * x - s * y + dx), L * (s * x + c * y + dy)) for i, x, y in sc["nodes"]]
    members = []
    for m in sc["members"]:
        m = dict(m)
        if "E" in m and meters:
            m["E"] = m["E"] * 1e6
        for k in ("width", "thickness", "free_length"):
            if k in m:
                m[k] = m[k] * L
        if "k" in m and meters:
            m["k"] = m["k"] * 1e3
        if reverse:
            m["from"], m["to"] = m["to"], m["from"]
            ea, eb = m.pop("end_a", None), m.pop("end_b", None)
            if eb:
                m["end_a"] = eb
            if ea:
                m["end_b"] = ea
        members.append(m)
    if reverse:
        members = members[::-1]
        nodes = nodes[::-1]
    sups = []
    for sp in sc["supports"]:
        sp = dict(sp)
        if sp["type"] == "slider":
            sp["angle_deg"] = sp.get("angle_deg", 0.0) + phi
        sups.append(sp)
    loads = []
    for l in sc["loads"]:
        l = dict(l)
        fx, fy = l.pop("fx", 0.0), l.pop("fy", 0.0)
        l["fx"], l["fy"] = c * fx - s * fy, s * fx + c * fy
        if "moment" in l and meters:
            l["moment"] *= 1e-3
        if reverse and "fraction" in l:
            l["fraction"] = 1.0 - l["fraction"]
        loads.append(l)
    springs = []
    for t in sc.get("springs", ()):
        t = dict(t)
        if meters:
            t["stiffness"] *= 1e-3
        springs.append(t)
    return dict(
        nodes=nodes,
        members=members,
        supports=sups,
        loads=loads,
        springs=springs,
        outputs=sc["outputs"],
        units="m-N-Pa" if meters else "mm-N-MPa",
        phi=phi,
        L=L,
        steps=sc.get("steps", 10),
    )


def emit(name, t):
    return toml(
        name,
        t["nodes"],
        t["members"],
        t["supports"],
        t["loads"],
        t["outputs"],
        t["springs"],
        t["steps"],
        t["units"],
    )


F = dict(kind="flexible", E=2300.0, width=10.0, thickness=1.0)

BASE = {}
# 1 parallelogram (Ex2-like), load at 0.5 of rigid coupler
BASE["parallelogram"] = dict(
    nodes=[("G1", 0, 0), ("G2", 0, 30), ("C1", 40, 0), ("C2", 40, 30)],
    members=[
        dict(id="lower", **{"from": "G1", "to": "C1"}, **F),
        dict(id="upper", **{"from": "G2", "to": "C2"}, **F),
        dict(id="coupler", **{"from": "C1", "to": "C2"}, kind="rigid"),
    ],
    supports=[dict(node="G1", type="clamp"), dict(node="G2", type="clamp")],
    loads=[dict(id="p", member="coupler", fraction=0.5, fy=10.0)],
    outputs=[("c", "C1")],
)
# 2 simply supported beam: pin + slider, mid-span load at a fraction (closed form FL^3/48EI small)
BASE["ss-beam-fraction"] = dict(
    nodes=[("A", 0, 0), ("B", 100, 0)],
    members=[dict(id="beam", **{"from": "A", "to": "B"}, **F)],
    supports=[dict(node="A", type="pin"), dict(node="B", type="slider", angle_deg=0.0)],
    loads=[dict(id="p", member="beam", fraction=0.3, fy=-0.2)],
    outputs=[("b", "B")],
)
# 3 L-frame with pinned knee + torsion spring between members, tip load
BASE["pinned-knee"] = dict(
    nodes=[("A", 0, 0), ("K", 0, 50), ("T", 40, 50)],
    members=[
        dict(id="post", **{"from": "A", "to": "K"}, end_b="pin", **F),
        dict(id="arm", **{"from": "K", "to": "T"}, end_a="pin", **F),
    ],
    supports=[dict(node="A", type="clamp")],
    springs=[dict(id="s", node="K", member_a="arm", member_b="post", stiffness=500.0)],
    loads=[dict(id="p", node="T", fy=-1.0, fx=0.5)],
    outputs=[("t", "T"), ("k", "K")],
)
# 4 rigid link with linear spring to ground + torsion spring to ground with preload
BASE["spring-ground"] = dict(
    nodes=[("O", 0, 0), ("P", 50, 0), ("Q", 50, -40)],
    members=[
        dict(id="link", **{"from": "O", "to": "P"}, kind="rigid", end_b="pin"),
        dict(id="spr", **{"from": "P", "to": "Q"}, kind="spring", k=0.5, free_length=30.0),
    ],
    supports=[dict(node="O", type="pin"), dict(node="Q", type="pin")],
    springs=[dict(id="t", node="O", member_a="link", stiffness=200.0, free_angle_deg=10.0)],
    loads=[dict(id="p", node="P", fy=2.0)],
    outputs=[("p", "P")],
)
# 5 clamped beam, other end on slider at 60 deg, tip load
BASE["slider-angle-beam"] = dict(
    nodes=[("A", 0, 0), ("B", 60, 0)],
    members=[dict(id="beam", **{"from": "A", "to": "B"}, **F)],
    supports=[dict(node="A", type="clamp"), dict(node="B", type="slider", angle_deg=60.0)],
    loads=[dict(id="p", node="B", fx=1.0, fy=1.732)],
    outputs=[("b", "B")],
)
# 6 column past buckling, pinned + axial slider, small lateral load at a fraction
BASE["column-postbuckled"] = dict(
    nodes=[("A", 0, 0), ("B", 100, 0)],
    members=[dict(id="col", **{"from": "A", "to": "B"}, **F)],
    supports=[dict(node="A", type="pin"), dict(node="B", type="slider", angle_deg=0.0)],
    loads=[
        dict(id="p", node="B", fx=-1.5 * math.pi**2 * 2300 * 10 / 12 / 100**2),
        dict(id="q", member="col", fraction=0.5, fy=0.01),
    ],
    outputs=[("b", "B")],
    steps=30,
)
# 7 fixed-guided via guided support, load at the guided end
BASE["guided-end"] = dict(
    nodes=[("A", 0, 0), ("B", 50, 0)],
    members=[dict(id="beam", **{"from": "A", "to": "B"}, **F)],
    supports=[dict(node="A", type="clamp"), dict(node="B", type="guided")],
    loads=[dict(id="p", node="B", fy=2.0)],
    outputs=[("b", "B")],
)
# 8 flexible beam welded to a rigid arm; load at a fraction of the arm, end moment
BASE["flex-rigid-arm"] = dict(
    nodes=[("A", 0, 0), ("B", 50, 0), ("C", 80, 20)],
    members=[
        dict(id="flex", **{"from": "A", "to": "B"}, **F),
        dict(id="arm", **{"from": "B", "to": "C"}, kind="rigid"),
    ],
    supports=[dict(node="A", type="clamp")],
    loads=[
        dict(id="p", member="arm", fraction=0.6, fy=-0.8, fx=0.3),
        dict(id="m", node="C", moment=5.0),
    ],
    outputs=[("c", "C"), ("b", "B")],
)
# 9 two flexible beams in series at an angle, welded knee, load at fraction of second beam
BASE["bent-frame-fraction"] = dict(
    nodes=[("A", 0, 0), ("K", 30, 40), ("T", 80, 40)],
    members=[
        dict(id="one", **{"from": "A", "to": "K"}, **F),
        dict(id="two", **{"from": "K", "to": "T"}, **F),
    ],
    supports=[dict(node="A", type="clamp"), dict(node="T", type="pin")],
    loads=[dict(id="p", member="two", fraction=0.25, fy=-3.0)],
    outputs=[("k", "K")],
)
# 10 slider-crank: rigid links, torsion spring at the crank pivot, force on the slider
BASE["slider-crank-angle"] = dict(
    nodes=[("O", 0, 0), ("B", 20, 15), ("S", 70, 0)],
    members=[
        dict(id="crank", **{"from": "O", "to": "B"}, kind="rigid", end_b="pin"),
        dict(id="rod", **{"from": "B", "to": "S"}, kind="rigid", end_a="pin", end_b="pin"),
    ],
    supports=[dict(node="O", type="pin"), dict(node="S", type="slider", angle_deg=0.0)],
    springs=[dict(id="t", node="O", member_a="crank", stiffness=1000.0)],
    loads=[dict(id="p", node="S", fx=-5.0)],
    outputs=[("s", "S"), ("b", "B")],
)
# 11 pinned-pinned flexible member with torsion springs to ground at both ends and an end moment
BASE["moment-pinned"] = dict(
    nodes=[("A", 0, 0), ("B", 80, 0)],
    members=[dict(id="beam", **{"from": "A", "to": "B"}, end_a="pin", end_b="pin", **F)],
    supports=[dict(node="A", type="pin"), dict(node="B", type="slider", angle_deg=30.0)],
    springs=[dict(id="t", node="A", member_a="beam", stiffness=300.0)],
    loads=[dict(id="m", node="B", moment=20.0)],
    outputs=[("b", "B")],
)
# 12 four-bar with compliant rocker, preloaded torsion spring between coupler and crank,
#    slider-free; crank loaded by a moment; mixed per-member models
BASE["fourbar-preload-mixed"] = dict(
    nodes=[("O", 0, 0), ("B", 0, 15), ("C", 35, 23), ("D", 35, -20)],
    members=[
        dict(id="crank", **{"from": "O", "to": "B"}, kind="rigid", end_b="pin"),
        dict(id="coupler", **{"from": "B", "to": "C"}, kind="rigid", end_a="pin", end_b="pin"),
        dict(id="rocker", **{"from": "D", "to": "C"}, end_b="pin", model="prb-3r", **F),
    ],
    supports=[dict(node="O", type="pin"), dict(node="D", type="clamp")],
    springs=[
        dict(
            id="t",
            node="B",
            member_a="coupler",
            member_b="crank",
            stiffness=100.0,
            free_angle_deg=5.0,
        )
    ],
    loads=[dict(id="m", node="O", moment=-30.0)],
    outputs=[("c", "C"), ("b", "B")],
)
# 13 linear spring between two moving nodes (two cantilevers tied by a spring), load on one
BASE["spring-between"] = dict(
    nodes=[("A", 0, 0), ("B", 50, 0), ("C", 0, 20), ("D", 50, 20)],
    members=[
        dict(id="one", **{"from": "A", "to": "B"}, **F),
        dict(id="two", **{"from": "C", "to": "D"}, **F),
        dict(id="tie", **{"from": "B", "to": "D"}, kind="spring", k=0.3),
    ],
    supports=[dict(node="A", type="clamp"), dict(node="C", type="clamp")],
    loads=[dict(id="p", node="D", fy=1.5)],
    outputs=[("b", "B"), ("d", "D")],
)
# 14 flexible von Mises truss (two pinned flexible bars), load past the snap-through limit
BASE["flex-vonmises-past-snap"] = dict(
    nodes=[("L", 0, 0), ("C", 50, 5), ("R", 100, 0)],
    members=[
        dict(
            id="l",
            **{"from": "L", "to": "C"},
            end_a="pin",
            end_b="pin",
            kind="flexible",
            E=2300.0,
            width=10.0,
            thickness=2.0,
        ),
        dict(
            id="r",
            **{"from": "C", "to": "R"},
            end_a="pin",
            end_b="pin",
            kind="flexible",
            E=2300.0,
            width=10.0,
            thickness=2.0,
        ),
    ],
    supports=[dict(node="L", type="pin"), dict(node="R", type="pin")],
    loads=[dict(id="p", node="C", fy=-60.0)],
    outputs=[("c", "C")],
    steps=20,
)
# 15 clamped-clamped beam (both welded), load at a fraction 0.7 (closed-form small-deflection)
BASE["clamped-clamped-fraction"] = dict(
    nodes=[("A", 0, 0), ("B", 100, 0)],
    members=[dict(id="beam", **{"from": "A", "to": "B"}, **F)],
    supports=[dict(node="A", type="clamp"), dict(node="B", type="clamp")],
    loads=[dict(id="p", member="beam", fraction=0.7, fy=-0.05)],
    outputs=[("a", "A")],
)
