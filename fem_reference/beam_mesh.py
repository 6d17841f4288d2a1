"""Beam members of the FE system: stations, points, elements, exact rigid-link constraints.

The first step of ``assembly.build`` (see its module docstring for the modelling choices):
``BeamMeshing`` numbers the scene's DOFs (``dofs.number_dofs``), meshes every flexible or
rigid member on a scikit-fem ``MeshLine1`` in its arc-length coordinate, and keeps what the
later steps (springs, loads, supports) add to.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from cases.arc import arc_points
from cases.node_rotation import pinned_ends
from cases.schema import Member, Scene
from fem_reference import corotational as cr
from fem_reference.dofs import number_dofs
from fem_reference.femsystem import MemberMesh, ModelError

# steel, 7850 kg/m^3, in force s^2 / length^4 of each system (in-lbf-psi: lbf s^2/in^4)
DEFAULT_DENSITY = {
    "m-N-Pa": 7850.0,
    "mm-N-MPa": 7.85e-9,
    "in-lbf-psi": 7850.0 * 0.0254**4 / 4.4482216152605,
}


def section(scene: Scene, m: Member, L: float) -> tuple[float, float]:
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


def density(scene: Scene, m: Member) -> float:
    """Mass density of member ``m``: its own, else the default of the scene's units."""
    if m.density is not None:
        return float(m.density)
    return DEFAULT_DENSITY.get(scene.units, 1.0)


def node_rotation(
    weld_rot: dict[str, int], beams_m: list[Member], end_rot: dict, nid: str
) -> tuple[int, ...]:
    """Rotation DOFs whose mean is node ``nid``'s output rotation (and which share a moment
    applied there equally): its welded rotation, else every member end pinned there
    (``cases.node_rotation``); ``()`` where no member end is there."""
    if nid in weld_rot:
        return (weld_rot[nid],)
    return tuple(end_rot[k] for k in pinned_ends(beams_m, nid))


class BeamMeshing:
    """The first step of ``assembly.build``: the scene's DOF numbering and reference scales,
    then every flexible or rigid member meshed (``mesh_member``: arc-length stations, points
    with their DOFs, element stiffness, mass and DOF arrays) or, for an exact rigid link, its
    constraints; ``finish_beams`` gathers the arrays."""

    def __init__(
        self,
        scene: Scene,
        per: dict[str, int],
        n_default: int,
        rigid_factor: float,
        exact_rigid: bool,
        check_only: bool,
    ) -> None:
        self.scene, self.per, self.n_default = scene, per, n_default
        self.rigid_factor, self.exact_rigid, self.check_only = (
            rigid_factor,
            exact_rigid,
            check_only,
        )
        self.nodes = {n.id: i for i, n in enumerate(scene.nodes)}
        self.pts = [[n.x, n.y] for n in scene.nodes]
        self.beams_m = [m for m in scene.members if m.kind in ("flexible", "rigid")]
        self.springs_m = [m for m in scene.members if m.kind == "spring"]
        self.Lref = max([scene.member_length(m.id) for m in scene.members] or [1.0])
        self.flex = [m for m in self.beams_m if m.kind == "flexible"]
        self.sec = {m.id: section(scene, m, scene.member_length(m.id)) for m in self.flex}
        self.Kref = self._reference_stiffness()
        self.trans, self.weld_rot, self.end_rot, self.nfull = number_dofs(
            scene, self.beams_m, exact_rigid
        )
        self.load_points: dict[tuple[str, float], tuple[int, int]] = {}
        self.members: list[MemberMesh] = []
        # element arrays per beam member (concatenated by ``finish_beams``)
        self.X21, self.L0, self.ka, self.kb, self.EI_e = [], [], [], [], []
        self.edofs, self.mA, self.mR = [], [], []
        self.ne_total = 0
        self.rot_of_point: dict[int, int] = {}
        # exact rigid links: constraint blocks [ua, va, ub, vb, theta, mu_x, mu_y] and chords;
        # a segment whose ends one body already joins (a welded rigid loop) adds no constraint
        self.con: list[list[int]] = []
        self.con_X: list[np.ndarray] = []
        self.link_parent: dict[tuple, tuple] = {}
        self.mean_A = np.mean([m.A for m in self.flex if m.A is not None] or [1.0])

    def _reference_stiffness(self) -> float:
        """K_ref: the largest rotational stiffness scale (flexible EI/L, springs); in a scene
        of rigid links alone, the loads' moment scale (force x longest member, moment), so that
        the links' relative compliance does not depend on the units; 1 if there is neither."""
        scene = self.scene
        kref = [self.sec[m.id][0] / scene.member_length(m.id) for m in self.flex]
        kref += [abs(t.stiffness) for t in scene.torsion_springs]
        kref += [abs(m.k or 0.0) * scene.member_length(m.id) ** 2 for m in self.springs_m]
        if not kref or max(kref) <= 0:
            kref = [np.hypot(ld.fx, ld.fy) * self.Lref + abs(ld.moment) for ld in scene.loads]
        return max(kref) if kref and max(kref) > 0 else 1.0

    def _link_root(self, k: tuple) -> tuple:
        while self.link_parent.get(k, k) != k:
            k = self.link_parent[k]
        return k

    # -- beam members (scikit-fem MeshLine1 in arc length) ----------------------------------
    def _stations(self, m: Member, L: float) -> tuple[list[float], np.ndarray]:
        """Break fractions (ends and load points) and arc-length stations of member ``m``."""
        fr = sorted(
            {0.0, 1.0}
            | {float(ld.fraction) for ld in self.scene.loads if ld.member == m.id and ld.fraction}
        )
        s = [0.0]
        for f0, f1 in zip(fr[:-1], fr[1:]):
            n_m = self.per.get(m.id, self.n_default)
            k = 1 if m.kind == "rigid" else max(1, round(n_m * (f1 - f0)))
            s.extend(np.linspace(f0 * L, f1 * L, k + 1)[1:].tolist())
        return fr, np.array(s)

    def _points(self, m: Member, xy: np.ndarray, exact: bool) -> np.ndarray:
        """Point ids along member ``m`` (new interior points get their DOFs)."""
        p_ids = [self.nodes[m.a]]
        for si in xy[1:-1]:
            p_ids.append(len(self.pts))
            self.pts.append([float(si[0]), float(si[1])])
            self.trans.append([self.nfull, self.nfull + 1])
            # a point along an exact rigid link turns with the link (its body rotation)
            self.rot_of_point[p_ids[-1]] = self.end_rot[(m.id, "a")] if exact else self.nfull + 2
            self.nfull += 2 if exact else 3
        p_ids.append(self.nodes[m.b])
        return np.array(p_ids)

    def _link_constraints(self, m: Member, p_ids: np.ndarray, s: np.ndarray) -> None:
        """An exact rigid link, never meshed: one constraint per segment, unless implied."""
        for i, j in zip(p_ids[:-1], p_ids[1:]):
            body = self.end_rot[(m.id, "a")]  # the link's rotation DOF names its body
            if self._link_root((body, i)) != self._link_root((body, j)):
                self.link_parent[self._link_root((body, i))] = self._link_root((body, j))
                self.con.append([*self.trans[i], *self.trans[j], body, self.nfull, self.nfull + 1])
                self.con_X.append(np.subtract(self.pts[j], self.pts[i]))
                self.nfull += 2
        self.members.append(MemberMesh(m.id, m.kind, p_ids, slice(self.ne_total, self.ne_total), s))

    def mesh_member(self, m: Member) -> None:
        """Mesh one flexible or rigid member (or add its exact link constraints)."""
        scene = self.scene
        a, b = scene.node(m.a), scene.node(m.b)
        L = scene.member_length(m.id)  # arc length of a curved member
        if L <= 0:
            raise ModelError(f"member {m.id!r} has zero length")
        fr, s = self._stations(m, L)
        # nodes on the exact member line (straight or circular arc, ``cases.arc``); the
        # straight elements between them are its chords, and the mesh coordinate is the
        # accumulated chord length, so every element is stress-free as drawn (the polygon
        # converges to the arc at O(h^2), the element's own order)
        xy = arc_points((a.x, a.y), (b.x, b.y), m.sweep_deg, s)
        xy[-1] = (b.x, b.y)
        dxy = np.diff(xy, axis=0)
        s_arc, s = s, np.concatenate([[0.0], np.cumsum(np.hypot(dxy[:, 0], dxy[:, 1]))])
        exact = self.exact_rigid and m.kind == "rigid"
        p_ids = self._points(m, xy, exact)
        for f in fr[1:-1]:
            self.load_points[(m.id, f)] = (int(p_ids[np.argmin(np.abs(s_arc - f * L))]), 0)
        if exact:
            self._link_constraints(m, p_ids, s)
            return
        mesh = cr.line_mesh(s)
        rots = [self.end_rot[(m.id, "a")]] + [self.rot_of_point[p] for p in p_ids[1:-1]]
        rots.append(self.end_rot[(m.id, "b")])
        if m.kind == "flexible":
            EI, EA = self.sec[m.id]
        else:
            EI = self.rigid_factor * self.Kref * L
            EA = 12.0 * EI / L**2
        if self.check_only:  # element matrices cannot fail: skip scikit-fem
            return
        self._elements(m, mesh, p_ids, np.array(rots), s, dxy, L, EI, EA)

    def _elements(
        self,
        m: Member,
        mesh: object,
        p_ids: np.ndarray,
        rots: np.ndarray,
        s: np.ndarray,
        dxy: np.ndarray,
        L: float,
        EI: float,
        EA: float,
    ) -> None:
        """Element stiffness, mass and DOF arrays of one meshed member."""
        k_a, k_b, l0 = cr.local_matrices(mesh, EA, EI)
        rho = density(self.scene, m)
        A = (
            m.A
            if m.A is not None
            else (m.width * m.thickness if m.width and m.thickness else self.mean_A)
        )
        Iy = (
            m.I
            if m.I is not None
            else (m.width * m.thickness**3 / 12.0 if m.width and m.thickness else None)
        )
        rot_line = rho * Iy if Iy is not None else 1e-3 * rho * A * L**2
        self.mA.append(cr.local_mass(mesh, rho * A))
        self.mR.append(cr.local_mass(mesh, rot_line))
        ne = l0.size
        self.X21.append(dxy)
        self.L0.append(l0)
        self.ka.append(k_a)
        self.kb.append(k_b)
        self.EI_e.append(np.full(ne, EI))
        i0, i1 = mesh.t[0], mesh.t[1]
        tr = np.array(self.trans)
        self.edofs.append(
            np.column_stack(
                [tr[p_ids[i0], 0], tr[p_ids[i0], 1], rots[i0]]
                + [tr[p_ids[i1], 0], tr[p_ids[i1], 1], rots[i1]]
            )
        )
        self.members.append(
            MemberMesh(
                m.id,
                m.kind,
                p_ids,
                slice(self.ne_total, self.ne_total + ne),
                s,
                m.thickness,
                m.E,
                m.I,
            )  # fmt: skip
        )
        self.ne_total += ne

    def finish_beams(self) -> None:
        """Point and DOF arrays, the ``BeamSet`` and the beam element DOFs."""
        self.trans = np.array(self.trans, dtype=np.int64).reshape(-1, 2)
        self.ground = self.nfull
        self.points = np.array(self.pts, dtype=float)
        cat = np.concatenate
        self.beams = cr.BeamSet(
            X21=cat(self.X21) if self.X21 else np.zeros((0, 2)),
            L0=cat(self.L0) if self.L0 else np.zeros(0),
            ka=cat(self.ka) if self.ka else np.zeros(0),
            kb=cat(self.kb) if self.kb else np.zeros((0, 2, 2)),
            EI=cat(self.EI_e) if self.EI_e else np.zeros(0),
        )
        self.beam_dofs = cat(self.edofs).astype(np.int64) if self.edofs else np.zeros((0, 6), int)
        self.node_rot = partial(node_rotation, self.weld_rot, self.beams_m, self.end_rot)
