"""Scene -> ``MechanismSystem``: member laws, rigid links, springs, loads, supports, driver.

``build(scene, spec_of)``: ``spec_of(member)`` gives the member law of a flexible member,
``("chain", SegmentLaw, N, extensible)`` or ``("prb", matrix)`` (``model.py`` maps model names
to these).  Rigid links are closure constraints (never stiff beams); supports fix unknowns;
sliders are linear constraints.  A chain is laid out from the end ``orient.root_at_b`` picks
(the answer does not depend on the member's drawn direction); a PRB chain with a rigid first
link from its firmer end, ends held alike by the same rule (``_root_at_b``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from cases.orient import fixity, root_at_b
from cases.schema import Member, Scene
from reduced_models.mechanism import elastica_member
from reduced_models.mechanism.constraints import Closure
from reduced_models.mechanism.members import (
    ChainTerm,
    JointTerm,
    LoadTerm,
    SpringTerm,
    TorsionTerm,
)
from reduced_models.mechanism.system import MechanismSystem, SceneError
from reduced_models.mechanism.topology import (
    Layout,
    layout,
    member_frame,
    slider_rows,
    split_member_loads,
)


def build(scene: Scene, spec_of: Callable[[Member], tuple]) -> MechanismSystem:
    """Assemble ``scene`` with the member laws given by ``spec_of`` (module doc)."""
    if any(ld.follower and (ld.fx or ld.fy) for ld in scene.loads):
        raise SceneError(
            "follower loads are non-conservative: the energy-based assembler takes dead loads"
        )
    scene, origin = _centred(split_member_loads(scene))
    lay = layout(scene)
    sysm = MechanismSystem(lay)
    sysm.origin = origin
    closure: list = [[], [], [], [], [], []]  # ends, chain, len, ang, u, alpha
    chain_rows: dict[int, list] = {}
    joints: list[list] = [[], [], [], []]
    for m in scene.members:
        L, alpha = member_frame(scene, m)
        xa, xb = lay.node_dof[m.a], lay.node_dof[m.b]
        if m.kind == "spring":
            continue
        ra, rb = lay.end_rot[(m.id, "a")], lay.end_rot[(m.id, "b")]
        if m.kind == "rigid":
            c = len(closure[0])
            closure[0].append((xa, xb))
            for lst, v in zip(closure[1:], (c, L, ra, -1, alpha)):
                lst.append(v)
            sysm.shape_of[m.id] = _line(xa, xb)
            continue
        spec = spec_of(m)
        if spec[0] == "chain" and root_at_b(scene, m):  # laid out from its firmer end
            _add_chain(sysm, m, spec, L, alpha + math.pi, (m.b, xb, rb), (xa, ra), chain_rows)
        elif spec[0] == "chain":
            _add_chain(sysm, m, spec, L, alpha, (m.a, xa, ra), (xb, rb), chain_rows)
        elif spec[0] == "elastica":  # exact member law (mechanism/elastica_member.py)
            if m.A is None:
                raise SceneError(
                    f"elastica member {m.id!r} needs its cross-section (width, thickness) for "
                    "the axial compliance that makes the member law regular"
                )
            elastica_member.add(sysm, m, L, alpha, xa, xb, ra, rb)
        elif _root_at_b(scene, m, spec[1]):  # the PRB root (rigid first link) at end b
            _add_prb(sysm, m, spec[1], L, alpha + math.pi, xb, xa, rb, ra, closure, joints)
        else:
            _add_prb(sysm, m, spec[1], L, alpha, xa, xb, ra, rb, closure, joints)
    for rows in chain_rows.values():
        law = rows[0][0]
        arr = list(zip(*[r[1:] for r in rows]))
        term = ChainTerm(law, *[np.concatenate(a) for a in arr])
        sysm.terms.append(term)
        sysm.chains.append(term)
    if joints[0]:
        sysm.terms.append(JointTerm(*joints))
    _add_springs(sysm, scene, lay)
    sysm.constraints.append(Closure(*closure) if closure[0] else _empty_closure())
    for i, cx, cy, b in slider_rows(scene, lay):
        sysm.linear.add([i, i + 1], [cx, cy], b, "slider")
    sysm.loads = _loads(scene, lay)
    _driver(sysm, scene, lay)
    sysm.finish()
    return sysm


def _root_at_b(scene: Scene, m: Member, matrix: np.ndarray) -> bool:
    """PRB matrices are cantilever models: rigid root link at the held end, pivots placed
    from there (prb-1r: pivot at (1 - gamma) L from the root).  A member drawn from its free
    or pinned end towards its clamped end is laid out from end b; between ends held alike
    (a parallel guide's leg, welded at both) the chains' rule decides (``orient.root_at_b``:
    the grounded end, ...), so the answer does not depend on the drawing direction.  Only a
    matrix with a rigid first link can be turned."""
    if math.isfinite(matrix[0, 0]):
        return False
    fa, fb = fixity(scene, m, "a"), fixity(scene, m, "b")
    return fb > fa if fb != fa else root_at_b(scene, m)


def _centred(scene: Scene) -> tuple[Scene, tuple[float, float]]:
    """The scene moved so that its bounding box is centred on the origin, and the shift.

    Node unknowns are absolute positions: far from the origin (a layout drawn at x = 1000 L)
    the segment chords ``x_b - x_a`` lose digits to cancellation and the axial rows can no
    longer meet their tolerance.  Solving about the centre makes the result independent of
    where the scene is drawn; outputs and shapes add the shift back.
    """
    xs = [n.x for n in scene.nodes]
    ys = [n.y for n in scene.nodes]
    ox, oy = 0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys))
    nodes = tuple(replace(n, x=n.x - ox, y=n.y - oy) for n in scene.nodes)
    return replace(scene, nodes=nodes), (ox, oy)


def _empty_closure() -> Closure:
    z = np.zeros(0)
    return Closure(np.zeros((0, 2)), z, z, z, z, z)


def _line(xa: int, xb: int) -> Callable[[np.ndarray], np.ndarray]:
    return lambda q: np.array([[q[xa], q[xa + 1]], [q[xb], q[xb + 1]]])


def _add_chain(
    sysm: MechanismSystem,
    m: Member,
    spec: tuple,
    L: float,
    alpha: float,
    root: tuple[str, int, int],
    tip: tuple[int, int],
    chain_rows: dict,
) -> None:
    """N chained segments from the root end (node id, position and rotation unknowns) to the
    tip end (position and rotation unknowns) along the direction ``alpha``: internal nodes
    (X, Y, phi) and one axial force per segment.  ``root`` is end a or b (``orient``); the
    member's shape is listed from end a."""
    _, law, N, extensible = spec
    lay = sysm.lay
    h = L / N
    c, s = math.cos(alpha), math.sin(alpha)
    a = lay.scene.node(root[0])
    nodes_x = [root[1]]
    nodes_r = [root[2]]
    for i in range(1, N):
        idx = lay.add([a.x + c * h * i, a.y + s * h * i, 0.0], "t")
        lay.kind[idx[2]] = "r"
        nodes_x.append(int(idx[0]))
        nodes_r.append(int(idx[2]))
    nodes_x.append(tip[0])
    nodes_r.append(tip[1])
    p = lay.add([0.0] * N, "p")
    dofs = np.array(
        [
            [nodes_x[i], nodes_x[i] + 1, nodes_r[i], nodes_x[i + 1], nodes_x[i + 1] + 1]
            + [nodes_r[i + 1], p[i]]
            for i in range(N)
        ]
    )
    EI = m.E * m.I
    k = EI / (m.E * m.A * h * h) if extensible and m.A is not None else 0.0
    key = id(law)
    chain_rows.setdefault(key, [])
    sfac = m.E * m.thickness / 2.0 if m.thickness is not None else np.nan
    chain_rows[key].append(
        (
            law,
            dofs,
            np.full(N, h),
            np.full(N, EI),
            np.full(N, k),
            np.full(N, alpha),
            np.full(N, sfac),
        )
    )
    xs = np.array(nodes_x if root[0] == m.a else nodes_x[::-1])
    sysm.shape_of[m.id] = lambda q: np.column_stack([q[xs], q[xs + 1]])


def _add_prb(
    sysm: MechanismSystem,
    m: Member,
    matrix: np.ndarray,
    L: float,
    alpha: float,
    xa: int,
    xb: int,
    ra: int,
    rb: int,
    closure: list,
    joints: list,
) -> None:
    """PRB chain: joint angles psi_p (the last one is the end-b rotation), stretches, closure."""
    lay = sysm.lay
    S = len(matrix)
    jrows = [i for i in range(S) if math.isfinite(matrix[i, 0])]
    EI = m.E * m.I
    EA = m.E * m.A if m.A is not None else math.inf
    psi = [int(v) for v in lay.add([0.0] * (len(jrows) - 1), "r")] + [rb]
    c = len(closure[0])
    closure[0].append((xa, xb))
    owner = ra
    prev = ra
    for i in range(S):
        if i in jrows:
            p = jrows.index(i)
            owner = psi[p]
            joints[0].append(owner)
            joints[1].append(prev)
            joints[2].append(matrix[i, 0] * EI / L)
            joints[3].append(m.thickness / (2.0 * m.I) if m.thickness is not None else np.nan)
            prev = owner
        u = -1
        if math.isfinite(matrix[i, 1]) and math.isfinite(EA):
            u = int(lay.add([0.0], "u")[0])
            lay.kind[u] = "t"
            joints[0].append(u)
            joints[1].append(lay.ground)  # held at 0: 1/2 K u^2
            joints[2].append(matrix[i, 1] * EA / L)
            joints[3].append(np.nan)
        for lst, v in zip(closure[1:], (c, matrix[i, 2] * L, owner, u, alpha)):
            lst.append(v)
    seg = np.flatnonzero(np.array(closure[1]) == c)
    ang = np.array(closure[3])[seg]
    uu = np.array(closure[4])[seg]
    ln = np.array(closure[2])[seg]

    def shape(q: np.ndarray) -> np.ndarray:
        ell = ln + np.where(uu >= 0, q[np.maximum(uu, 0)], 0.0)
        z = np.cumsum(ell * np.exp(1j * (alpha + q[ang])))
        pts = q[xa] + 1j * q[xa + 1] + np.concatenate([[0.0], z])
        return np.column_stack([pts.real, pts.imag])

    sysm.shape_of[m.id] = shape
    sysm.prb_members.append((m.id, ang))


def _add_springs(sysm: MechanismSystem, scene: Scene, lay: Layout) -> None:
    ta, tb, tk, tp = [], [], [], []
    for t in scene.torsion_springs:
        ma = lay.piece(t.member_a, t.node)
        if ma.kind == "spring":
            raise SceneError(f"torsion spring {t.id!r} on linear spring {t.member_a!r}")
        a = lay.end_rot[(ma.id, "a" if ma.a == t.node else "b")]
        if t.member_b is None:
            b = lay.ground
        else:
            mb = lay.piece(t.member_b, t.node)
            if mb.kind == "spring":
                raise SceneError(f"torsion spring {t.id!r} on linear spring {t.member_b!r}")
            b = lay.end_rot[(mb.id, "a" if mb.a == t.node else "b")]
        if a == b:
            raise SceneError(f"torsion spring {t.id!r} joins two welded ends (no effect)")
        ta.append(a)
        tb.append(b)
        tk.append(t.stiffness)
        tp.append(math.radians(t.free_angle_deg))
    if ta:
        sysm.terms.append(TorsionTerm(ta, tb, tk, tp))
    sp = [m for m in scene.members if m.kind == "spring"]
    if sp:
        xa = [lay.node_dof[m.a] for m in sp]
        xb = [lay.node_dof[m.b] for m in sp]
        l0 = [m.free_length if m.free_length is not None else scene.member_length(m.id) for m in sp]
        sysm.terms.append(SpringTerm(xa, xb, [m.k for m in sp], l0))
        for m, a, b in zip(sp, xa, xb):
            sysm.shape_of[m.id] = _line(a, b)


def _loads(scene: Scene, lay: Layout) -> LoadTerm:
    lin = np.zeros(lay.n)
    rigid = []
    for ld in scene.loads:
        if ld.node is not None:
            nid = ld.node
        else:
            m = scene.member(ld.member)
            f = float(ld.fraction)
            if m.kind == "spring" and 0.0 < f < 1.0:
                raise SceneError(f"load {ld.id!r} along linear spring {m.id!r}")
            if 0.0 < f < 1.0:  # a rigid link (flexible members were split)
                L, alpha = member_frame(scene, m)
                xa, th = lay.node_dof[m.a], lay.end_rot[(m.id, "a")]
                lin[xa] -= ld.fx
                lin[xa + 1] -= ld.fy
                lin[th] -= ld.moment
                rigid.append((xa, th, f * L, alpha - 0.0, ld.fx, ld.fy))
                continue
            nid = m.a if f <= 0.0 else m.b
        i = lay.node_dof[nid]
        lin[i] -= ld.fx
        lin[i + 1] -= ld.fy
        if ld.moment:
            r = lay.node_rot[nid]
            if ld.node is None and m.kind != "spring":  # that member's end, as in the FE
                p = lay.piece(m.id, nid)
                r = (lay.end_rot[(p.id, "a" if p.a == nid else "b")],)
            if not r:
                raise SceneError(f"load {ld.id!r}: moment at a node without rotation")
            np.subtract.at(lin, list(r), ld.moment / len(r))  # shared (cases.node_rotation)
    # rigid-link forces: lever term measured from the drawn angle (q is the rotation)
    return LoadTerm(lin, rigid)


def _driver(sysm: MechanismSystem, scene: Scene, lay: Layout) -> None:
    drv = scene.analysis.driver
    if drv is None:
        return
    if drv.kind == "displacement":
        i = lay.node_dof[drv.node] + (0 if drv.direction == "x" else 1)
        sysm.driver_dof = i
        sysm.driver_scale = 1.0
    else:
        m = lay.piece(drv.member, scene.member(drv.member).a)
        if m.kind == "spring":
            raise SceneError("a rotation driver needs a beam or rigid member")
        sysm.driver_dof = lay.end_rot[(m.id, "a")]
        sysm.driver_scale = math.pi / 180.0
    if sysm.driver_dof in lay.fixed:
        raise SceneError("the driver coordinate is fixed by a support")
