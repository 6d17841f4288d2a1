"""Scene -> discrete corotational system: meshes, DOF maps, supports, joints, springs, loads.

``build(scene, n_elements)`` returns a ``FEMSystem`` (``femsystem.py``; satisfies
``system.DiscreteSystem``).  ``FEMSystem``, ``MemberMesh``, ``ModelError`` (``femsystem``) and
``Scatter`` (``scatter``) are re-exported here.

Modelling choices (what the scene format means here)
----------------------------------------------------
* Every flexible member is meshed on a scikit-fem ``MeshLine1`` in its arc-length coordinate
  with ``n_elements`` corotational elements; break points are inserted where loads act at a
  fraction along the member (segments get elements in proportion to their length).
* Rigid members are exact constraints with ``exact_rigid`` (what ``fem-N``/``fem-auto`` use,
  ``rigid.py``): never meshed, the link's two end rotations are one rotation DOF, each
  segment keeps its chord rotated by it (Lagrange multipliers).  Otherwise (the replay, the
  deploy analysis, option ``rigid_links = "stiff"``) they are *one stiff corotational element*
  per segment: ``EI_r = rigid_factor * K_ref * L`` and ``EA_r = 12 EI_r / L^2`` where
  ``K_ref`` is the largest rotational stiffness scale of the scene (flexible ``EI/L``,
  torsion-spring and linear-spring stiffnesses); with the default ``rigid_factor = 1e6``
  the link compliance perturbs outputs by ~1e-6 relative.
* Welded member ends at a node share one rotation DOF; every pinned end has its own.
  Translations are always shared at a node.
* Supports: ``clamp`` fixes x, y and the welded rotation; ``pin`` x, y; ``slider`` keeps the
  node on the line at ``angle_deg`` (one free DOF t: ux = t cos a, uy = t sin a); ``guided``
  fixes the welded rotation only.
* Torsion springs act between the rotation DOFs of two member ends at a node (or one end and
  ground) with energy ``k/2 (rot_a - rot_b - free_angle)^2``; linear springs (member kind
  ``spring``) have energy ``k/2 (l - free_length)^2`` and no rotation DOFs.
* Follower forces turn with the rotation DOF of the point they act on; moments are the same
  dead or follower in 2-D.
* Mass (for the dynamic replay): consistent P1 mass ``rho A`` on translations and ``rho I`` on
  rotations (scikit-fem forms), constant and frame invariant.  ``rho`` = ``Member.density``
  or, if absent, 7850 (``m-N-Pa``), 7.85e-9 (``mm-N-MPa``), 1.0 otherwise.  Springs are
  massless; rigid links get ``rho A`` with A from the member or the mean flexible A (else 1),
  and a small rotary inertia ``1e-3 rho A L^2`` per length when I is absent.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from cases.arc import arc_points
from cases.schema import Member, Scene
from fem_reference import corotational as cr
from fem_reference.dofs import number_dofs
from fem_reference.femsystem import Evaluation, FEMSystem, MemberMesh, ModelError
from fem_reference.scatter import BandScatter, Scatter

__all__ = [
    "DEFAULT_DENSITY",
    "BandScatter",
    "Evaluation",
    "FEMSystem",
    "MemberMesh",
    "ModelError",
    "Scatter",
    "build",
]

DEFAULT_DENSITY = {"m-N-Pa": 7850.0, "mm-N-MPa": 7.85e-9}


# -- builder -----------------------------------------------------------------------------------


def _section(scene: Scene, m: Member, L: float) -> tuple[float, float]:
    """(EI, EA) of a flexible member; A or width*thickness; EA defaults to 1e6 EI / L^2."""
    I, A = m.I, m.A
    if I is None and m.width is not None and m.thickness is not None:
        I = m.width * m.thickness**3 / 12.0
    if A is None and m.width is not None and m.thickness is not None:
        A = m.width * m.thickness
    if m.E is None or I is None:
        raise ModelError(f"member {m.id!r}: flexible members need E and I (or width+thickness)")
    EI = m.E * I
    EA = m.E * A if A is not None else 1e6 * EI / L**2
    return float(EI), float(EA)


def _density(scene: Scene, m: Member) -> float:
    if m.density is not None:
        return float(m.density)
    return DEFAULT_DENSITY.get(scene.units, 1.0)


def build(
    scene: Scene,
    n_elements: int | dict[str, int],
    *,
    rigid_factor: float = 1e6,
    driver_load: bool = False,
    check_only: bool = False,
    exact_rigid: bool = False,
) -> FEMSystem | None:
    """Discretise ``scene`` with ``n_elements`` corotational elements per flexible member.

    Parameters
    ----------
    scene : the validated scene.
    n_elements : elements per flexible member (>= 1), or ``{member id: elements}`` for every
        flexible member (per-member refinement); rigid members get one per segment.
    rigid_factor : stiffness ratio of rigid links to the scene's stiffest flexible part
        (stiff-element rigid links only).
    exact_rigid : rigid links are exact constraints (``rigid.py``: one rotation DOF per link,
        Lagrange multipliers), not stiff elements.  The static solvers use this; the replay
        and the deploy analysis keep the stiff elements (they need a mass on every DOF).
    driver_load : energy analyses: the scene loads form the *constant* group (applied at
        ``system.const_factor``) and a unit force/torque at the driver coordinate is the
        lam-scaled load, so lam is the driver reaction.
    check_only : only check that the scene is representable (raise ``ModelError`` or return
        None); skips the scikit-fem element matrices, DOF numbering and scatters.

    Raises
    ------
    ModelError : the scene uses something this discretisation cannot represent.
    """
    per = n_elements if isinstance(n_elements, dict) else {}
    n_default = max(per.values(), default=1) if per else int(n_elements)
    if n_default < 1 or any(v < 1 for v in per.values()):
        raise ModelError("n_elements must be >= 1")
    nodes = {n.id: i for i, n in enumerate(scene.nodes)}
    pts = [[n.x, n.y] for n in scene.nodes]
    beams_m = [m for m in scene.members if m.kind in ("flexible", "rigid")]
    springs_m = [m for m in scene.members if m.kind == "spring"]
    Lref = max([scene.member_length(m.id) for m in scene.members] or [1.0])
    flex = [m for m in beams_m if m.kind == "flexible"]
    sec = {m.id: _section(scene, m, scene.member_length(m.id)) for m in flex}
    kref = [sec[m.id][0] / scene.member_length(m.id) for m in flex]
    kref += [abs(t.stiffness) for t in scene.torsion_springs]
    kref += [abs(m.k or 0.0) * scene.member_length(m.id) ** 2 for m in springs_m]
    Kref = max(kref) if kref and max(kref) > 0 else 1.0

    trans, weld_rot, end_rot, nfull = number_dofs(scene, beams_m, exact_rigid)
    # -- mesh beam members (scikit-fem MeshLine1 in arc length)
    load_points: dict[tuple[str, float], tuple[int, int]] = {}
    members: list[MemberMesh] = []
    X21, L0, ka, kb, EI_e, edofs, mA, mR = [], [], [], [], [], [], [], []
    ne_total = 0
    rot_of_point: dict[int, int] = {}
    # exact rigid links: constraint blocks [ua, va, ub, vb, theta, mu_x, mu_y] and chords; a
    # segment whose ends one body already joins (a welded rigid loop) adds no constraint
    con: list[list[int]] = []
    con_X: list[np.ndarray] = []
    link_parent: dict[tuple, tuple] = {}

    def link_root(k: tuple) -> tuple:
        while link_parent.get(k, k) != k:
            k = link_parent[k]
        return k

    mean_A = np.mean([m.A for m in flex if m.A is not None] or [1.0])
    for m in beams_m:
        a, b = scene.node(m.a), scene.node(m.b)
        L = scene.member_length(m.id)  # arc length of a curved member
        if L <= 0:
            raise ModelError(f"member {m.id!r} has zero length")
        fr = sorted(
            {0.0, 1.0}
            | {float(ld.fraction) for ld in scene.loads if ld.member == m.id and ld.fraction}
        )
        s = [0.0]
        for f0, f1 in zip(fr[:-1], fr[1:]):
            n_m = per.get(m.id, n_default)
            k = 1 if m.kind == "rigid" else max(1, round(n_m * (f1 - f0)))
            s.extend(np.linspace(f0 * L, f1 * L, k + 1)[1:].tolist())
        s = np.array(s)
        # nodes on the exact member line (straight or circular arc, ``cases.arc``); the
        # straight elements between them are its chords, and the mesh coordinate is the
        # accumulated chord length, so every element is stress-free as drawn (the polygon
        # converges to the arc at O(h^2), the element's own order)
        xy = arc_points((a.x, a.y), (b.x, b.y), m.sweep_deg, s)
        xy[-1] = (b.x, b.y)
        dxy = np.diff(xy, axis=0)
        s_arc, s = s, np.concatenate([[0.0], np.cumsum(np.hypot(dxy[:, 0], dxy[:, 1]))])
        exact = exact_rigid and m.kind == "rigid"
        p_ids = [nodes[m.a]]
        for si in xy[1:-1]:
            p_ids.append(len(pts))
            pts.append([float(si[0]), float(si[1])])
            trans.append([nfull, nfull + 1])
            # a point along an exact rigid link turns with the link (its body rotation)
            rot_of_point[p_ids[-1]] = end_rot[(m.id, "a")] if exact else nfull + 2
            nfull += 2 if exact else 3
        p_ids.append(nodes[m.b])
        p_ids = np.array(p_ids)
        for f in fr[1:-1]:
            load_points[(m.id, f)] = (int(p_ids[np.argmin(np.abs(s_arc - f * L))]), 0)
        if exact:  # never meshed: one constraint per segment, unless already implied
            for i, j in zip(p_ids[:-1], p_ids[1:]):
                body = end_rot[(m.id, "a")]  # the link's rotation DOF names its body
                if link_root((body, i)) != link_root((body, j)):
                    link_parent[link_root((body, i))] = link_root((body, j))
                    con.append([*trans[i], *trans[j], end_rot[(m.id, "a")], nfull, nfull + 1])
                    con_X.append(np.subtract(pts[j], pts[i]))
                    nfull += 2
            members.append(MemberMesh(m.id, m.kind, p_ids, slice(ne_total, ne_total), s))
            continue
        mesh = cr.line_mesh(s)
        rots = [end_rot[(m.id, "a")]] + [rot_of_point[p] for p in p_ids[1:-1]]
        rots.append(end_rot[(m.id, "b")])
        if m.kind == "flexible":
            EI, EA = sec[m.id]
        else:
            EI = rigid_factor * Kref * L
            EA = 12.0 * EI / L**2
        if check_only:  # element matrices cannot fail: skip scikit-fem
            continue
        k_a, k_b, l0 = cr.local_matrices(mesh, EA, EI)
        rho = _density(scene, m)
        A = (
            m.A
            if m.A is not None
            else (m.width * m.thickness if m.width and m.thickness else mean_A)
        )
        Iy = (
            m.I
            if m.I is not None
            else (m.width * m.thickness**3 / 12.0 if m.width and m.thickness else None)
        )
        rot_line = rho * Iy if Iy is not None else 1e-3 * rho * A * L**2
        mA.append(cr.local_mass(mesh, rho * A))
        mR.append(cr.local_mass(mesh, rot_line))
        ne = l0.size
        X21.append(dxy)
        L0.append(l0)
        ka.append(k_a)
        kb.append(k_b)
        EI_e.append(np.full(ne, EI))
        i0, i1 = mesh.t[0], mesh.t[1]
        tr = np.array(trans)
        rots = np.array(rots)
        edofs.append(
            np.column_stack(
                [
                    tr[p_ids[i0], 0],
                    tr[p_ids[i0], 1],
                    rots[i0],
                    tr[p_ids[i1], 0],
                    tr[p_ids[i1], 1],
                    rots[i1],
                ]
            )
        )
        members.append(
            MemberMesh(
                m.id, m.kind, p_ids, slice(ne_total, ne_total + ne), s, m.thickness, m.E, m.I
            )
        )
        ne_total += ne
    trans = np.array(trans, dtype=np.int64).reshape(-1, 2)
    ground = nfull
    points = np.array(pts, dtype=float)
    beams = cr.BeamSet(
        X21=np.concatenate(X21) if X21 else np.zeros((0, 2)),
        L0=np.concatenate(L0) if L0 else np.zeros(0),
        ka=np.concatenate(ka) if ka else np.zeros(0),
        kb=np.concatenate(kb) if kb else np.zeros((0, 2, 2)),
        EI=np.concatenate(EI_e) if EI_e else np.zeros(0),
    )
    beam_dofs = np.concatenate(edofs).astype(np.int64) if edofs else np.zeros((0, 6), int)

    # -- linear springs
    sd, sk, sl0, sX = [], [], [], []
    for m in springs_m:
        if m.k is None:
            raise ModelError(f"spring {m.id!r} needs k")
        pa, pb = nodes[m.a], nodes[m.b]
        sd.append([trans[pa, 0], trans[pa, 1], trans[pb, 0], trans[pb, 1]])
        sk.append(m.k)
        sX.append(points[pb] - points[pa])
        sl0.append(m.free_length if m.free_length is not None else np.hypot(*sX[-1]))
        members.append(
            MemberMesh(
                m.id, "spring", np.array([pa, pb]), slice(0, 0), np.array([0.0, np.hypot(*sX[-1])])
            )
        )
    spring_X = np.array(sX, dtype=float).reshape(-1, 2)

    # -- torsion springs
    def end_dof(member_id: str, node_id: str) -> int:
        m = scene.member(member_id)
        if m.kind == "spring":
            raise ModelError(f"torsion spring on linear spring {member_id!r}")
        if m.a == node_id:
            return end_rot[(m.id, "a")]
        if m.b == node_id:
            return end_rot[(m.id, "b")]
        raise ModelError(f"member {member_id!r} does not end at node {node_id!r}")

    td, tk, tp = [], [], []
    for t in scene.torsion_springs:
        da = end_dof(t.member_a, t.node)
        db = end_dof(t.member_b, t.node) if t.member_b else ground
        if da == db:
            raise ModelError(f"torsion spring {t.id!r} joins two welded ends (no effect)")
        td.append([da, db])
        tk.append(t.stiffness)
        tp.append(math.radians(t.free_angle_deg))

    # -- output / load rotation DOF of a node: welded rotation, else first pinned end
    def node_rot(nid: str) -> int | None:
        if nid in weld_rot:
            return weld_rot[nid]
        for m in beams_m:
            for end, e_n in (("a", m.a), ("b", m.b)):
                if e_n == nid:
                    return end_rot[(m.id, end)]
        return None

    # -- loads
    dead = np.zeros(nfull + 1)
    dead_c = np.zeros(nfull + 1)
    fd, ff, fg = [], [], []
    for ld in scene.loads:
        if ld.node is not None:
            p, r = nodes[ld.node], node_rot(ld.node)
        else:
            m = scene.member(ld.member)
            f = float(ld.fraction or 0.0)
            if f <= 0.0 or f >= 1.0:
                nid = m.a if f <= 0.0 else m.b
                p = nodes[nid]
                r = end_rot.get((m.id, "a" if f <= 0.0 else "b"), node_rot(nid))
            else:
                if m.kind == "spring":
                    raise ModelError(f"load {ld.id!r} along linear spring {m.id!r}")
                p = load_points[(m.id, f)][0]
                r = rot_of_point[p]
        target = dead_c if driver_load else dead
        if ld.moment:
            if r is None:
                raise ModelError(f"load {ld.id!r}: moment at a point without rotation DOF")
            target[r] += ld.moment
        if ld.follower and (ld.fx or ld.fy):
            if r is None:
                raise ModelError(f"load {ld.id!r}: follower force needs a member end")
            fd.append([trans[p, 0], trans[p, 1], r])
            ff.append([ld.fx, ld.fy])
            fg.append(1 if driver_load else 0)
        else:
            target[trans[p, 0]] += ld.fx
            target[trans[p, 1]] += ld.fy

    # -- driver coordinate (distance / energy analyses)
    drv = scene.analysis.driver
    driver_dof, driver_scale = None, 1.0
    if drv is not None:
        if drv.kind == "displacement":
            if drv.node is None or drv.direction not in ("x", "y"):
                raise ModelError("displacement driver needs node and direction x|y")
            driver_dof = int(trans[nodes[drv.node], 0 if drv.direction == "x" else 1])
        elif drv.kind == "rotation":
            if drv.member is None or (drv.member, "a") not in end_rot:
                raise ModelError("rotation driver needs a beam or rigid member")
            driver_dof, driver_scale = end_rot[(drv.member, "a")], 180.0 / math.pi
        else:
            raise ModelError(f"unknown driver kind {drv.kind!r}")
        if driver_load:
            dead[driver_dof] += 1.0
    elif driver_load:
        raise ModelError("driver_load needs analysis.driver")
    if check_only:
        return None

    # -- supports -> free DOF map
    fixed: set[int] = set()
    slider: dict[int, tuple[int, float, float]] = {}
    for sup in scene.supports:
        p = nodes[sup.node]
        tx, ty = trans[p]
        if sup.type in ("clamp", "pin"):
            fixed |= {int(tx), int(ty)}
        if sup.type in ("clamp", "guided") and sup.node in weld_rot:
            fixed.add(weld_rot[sup.node])
        if sup.type == "slider":
            a = math.radians(sup.angle_deg)
            slider[int(tx)] = (int(ty), math.cos(a), math.sin(a))
    free = -np.ones(nfull + 1, dtype=np.int64)
    coef = np.ones(nfull + 1)
    coef[ground] = 0.0
    k = 0
    partner: set[int] = set()
    for f in range(nfull):
        if f in fixed or f in partner:
            continue
        if f in slider:
            fy, ca, sa = slider[f]
            partner.add(fy)
            for ff_, cc in ((f, ca), (fy, sa)):
                if abs(cc) > 1e-13:
                    free[ff_], coef[ff_] = k, cc
            k += 1
            continue
        free[f] = k
        k += 1
    ndof = k
    con_dofs = np.array(con, dtype=np.int64).reshape(-1, 7)
    is_rot_full = np.ones(nfull + 1, dtype=bool)
    is_rot_full[trans.ravel()] = False
    is_mult_full = np.zeros(nfull + 1, dtype=bool)
    is_mult_full[con_dofs[:, 5:].ravel()] = True
    is_rot_full[is_mult_full] = False

    # -- families: beams (6), springs (4), torsion (2), followers (3), rigid links (7)
    fam = [
        beam_dofs,
        np.array(sd, dtype=np.int64).reshape(-1, 4),
        np.array(td, dtype=np.int64).reshape(-1, 2),
        np.array(fd, dtype=np.int64).reshape(-1, 3),
        con_dofs,
    ]
    scatter = Scatter(free, coef, fam, ndof)
    # renumber free DOFs by reverse Cuthill-McKee: member chains become narrow bands, so the
    # Newton solves can use a banded LU (static._factor)
    pattern = sp.csr_matrix(
        (np.ones(scatter.nnz), scatter.indices, scatter.indptr), shape=(ndof, ndof)
    )
    perm = reverse_cuthill_mckee(pattern, symmetric_mode=True)
    new_of_old = np.empty(ndof, dtype=np.int64)
    new_of_old[perm] = np.arange(ndof)
    free = np.where(free >= 0, new_of_old[np.maximum(free, 0)], -1)
    scatter = Scatter(free, coef, fam, ndof)
    bandwidth = scatter.bandwidth()
    is_rotation = np.ones(ndof, dtype=bool)
    m_ = free >= 0
    is_rotation[free[m_][~is_rot_full[m_]]] = False
    is_multiplier = np.zeros(ndof, dtype=bool)
    is_multiplier[free[m_][is_mult_full[m_]]] = True
    Mb = np.zeros((ne_total, 6, 6))
    if ne_total:
        MA, MR = np.concatenate(mA), np.concatenate(mR)
        for i, j in ((0, 3), (1, 4)):
            Mb[:, [i, i, j, j], [i, j, i, j]] = MA.reshape(-1, 4)
        Mb[:, [2, 2, 5, 5], [2, 5, 2, 5]] = MR.reshape(-1, 4)
    mass_blocks = (
        Mb,
        np.zeros((fam[1].shape[0], 4, 4)),
        np.zeros((fam[2].shape[0], 2, 2)),
        np.zeros((fam[3].shape[0], 3, 3)),
        np.zeros((fam[4].shape[0], 7, 7)),
    )

    rs = np.where(is_rot_full, 1.0 / Lref, 1.0)  # moments -> force units
    fscale = float(np.linalg.norm(dead * rs) + np.linalg.norm(dead_c * rs))
    fscale += float(np.linalg.norm(ff or [0.0]))
    pre = [abs(kk * ph) / Lref for kk, ph in zip(tk, tp)]
    pre += [abs(kk * (l0 - np.hypot(*x))) for kk, l0, x in zip(sk, sl0, sX)]
    fscale = max(fscale, max(pre or [0.0]))
    if fscale == 0.0:
        fscale = Kref / Lref
    out_point = {o.name: nodes[o.node] for o in scene.outputs}
    out_rot = {o.name: node_rot(o.node) for o in scene.outputs}
    system = FEMSystem(
        scene=scene,
        n_elements=n_default,
        ndof=ndof,
        free=free,
        coef=coef,
        points=points,
        trans=trans,
        beams=beams,
        beam_dofs=beam_dofs,
        members=members,
        spring_dofs=fam[1],
        spring_k=np.array(sk, float),
        spring_l0=np.array(sl0, float),
        spring_X=spring_X,
        spring_L=np.hypot(spring_X[:, 0], spring_X[:, 1]),
        tors_dofs=fam[2],
        tors_k=np.array(tk, float),
        tors_phi=np.array(tp, float),
        fol_dofs=fam[3],
        fol_f0=np.array(ff, float).reshape(-1, 2),
        fol_group=np.array(fg, dtype=np.int64),
        dead=dead,
        dead_const=dead_c,
        out_rot=out_rot,
        out_point=out_point,
        scatter=scatter,
        weights=np.where(is_multiplier, 0.0, np.where(is_rotation, 1.0, 1.0 / Lref**2))
        / max(ndof, 1),
        is_rotation=is_rotation,
        mass_blocks=mass_blocks,
        Lref=float(Lref),
        fscale=fscale,
        bandwidth=bandwidth,
        con_dofs=con_dofs,
        con_X=np.array(con_X, dtype=float).reshape(-1, 2),
        con_kappa=Kref / Lref**2,
        is_multiplier=is_multiplier,
        extra={
            "Kref": Kref,
            "end_rot": end_rot,
            "weld_rot": weld_rot,
            "node_rot": node_rot,
            "nodes": nodes,
            "ground": ground,
            "driver_dof": driver_dof,
            "driver_scale": driver_scale,
        },
    )
    system.fast  # noqa: B018 - build the fast-path index maps now, not inside a timed solve
    return system
