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
  dead or follower in 2-D.  At a node whose member ends are all pinned a moment is shared
  equally among them (``cases.node_rotation``) and a follower force declines (which end
  would it turn with?): it is given on one member's end instead.
* Mass (for the dynamic replay): consistent P1 mass ``rho A`` on translations and ``rho I`` on
  rotations (scikit-fem forms), constant and frame invariant.  ``rho`` = ``Member.density``
  or, if absent, steel in the scene's units (``beam_mesh.DEFAULT_DENSITY``), 1.0 in
  ``nondim``.  Springs are massless; rigid links get ``rho A`` with A from the member or the
  mean flexible A (else 1), and a small rotary inertia ``1e-3 rho A L^2`` per length when I
  is absent.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from cases.orient import root_at_b
from cases.schema import Scene
from fem_reference.beam_mesh import BeamMeshing
from fem_reference.femsystem import Evaluation, FEMSystem, MemberMesh, ModelError
from fem_reference.scatter import BandScatter, Scatter, family_key, kept

__all__ = [
    "BandScatter",
    "Evaluation",
    "FEMSystem",
    "MemberMesh",
    "ModelError",
    "Scatter",
    "build",
    "representable",
]


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
    b = _Parts(scene, per, n_default, rigid_factor, exact_rigid, check_only)
    for m in b.beams_m:
        b.mesh_member(m)
    b.finish_beams()
    b.add_springs()
    b.add_torsion_springs()
    b.add_loads(driver_load)
    b.add_driver(driver_load)
    if check_only:
        return None
    b.number_free_dofs()
    system = b.system()
    system.fast  # noqa: B018 - build the fast-path index maps now, not inside a timed solve
    return system


# ``representable``'s verdict per scene object (a weak reference tells a reused id apart):
# every model instance of a run asks again, and the check builds the scene's topology
_VERDICTS: dict[tuple, tuple[weakref.ref, str | None]] = {}


def representable(scene: Scene, **build_options: bool) -> str | None:
    """None, or why ``build(scene, 1, **build_options)`` refuses ``scene`` ("not
    representable: ..."), asked once per scene object (scenes are frozen: same answer)."""
    key = (id(scene), *sorted(build_options.items()))
    got = _VERDICTS.get(key)
    if got is not None and got[0]() is scene:
        return got[1]
    try:
        build(scene, 1, **build_options)
        reason = None
    except (ModelError, KeyError) as err:
        reason = f"not representable: {err}"
    if len(_VERDICTS) >= 256:
        del _VERDICTS[next(iter(_VERDICTS))]  # the oldest
    _VERDICTS[key] = (weakref.ref(scene), reason)
    return reason


def _renumber(
    free: np.ndarray, coef: np.ndarray, fam: list[np.ndarray], ndof: int
) -> tuple[np.ndarray, Scatter, int]:
    """Free DOF map (nfull + 1,) of ``ndof`` free DOFs renumbered by reverse Cuthill-McKee
    (member chains become narrow bands, so the Newton solves can use a banded LU,
    ``banded.factor``), its csr scatter and its half-bandwidth."""
    scatter = Scatter(free, coef, fam, ndof)
    pattern = sp.csr_matrix(
        (np.ones(scatter.nnz), scatter.indices, scatter.indptr), shape=(ndof, ndof)
    )
    # no free DOF (a member clamped at both ends): nothing to renumber, and csgraph's
    # reordering fails on an empty graph
    perm = reverse_cuthill_mckee(pattern, symmetric_mode=True) if ndof else np.arange(0)
    new_of_old = np.empty(ndof, dtype=np.int64)
    new_of_old[perm] = np.arange(ndof)
    new = np.where(free >= 0, new_of_old[np.maximum(free, 0)] if ndof else 0, -1)
    new.setflags(write=False)
    scatter = Scatter(new, coef, fam, ndof)
    return new, scatter, scatter.bandwidth()


class _Parts(BeamMeshing):
    """The pieces of a ``FEMSystem`` as ``build`` assembles them, one named step a method:
    the beam members (``BeamMeshing``), springs, torsion springs, loads, driver, the free DOF
    map with its RCM renumbering (``number_free_dofs``), then the system (``system``)."""

    # -- springs, loads, driver -------------------------------------------------------------
    def add_springs(self) -> None:
        """Linear springs: DOFs, stiffness, free length, chord."""
        self.sd, self.sk, self.sl0, self.sX = [], [], [], []
        trans, points = self.trans, self.points
        for m in self.springs_m:
            if m.k is None:
                raise ModelError(f"spring {m.id!r} needs k")
            pa, pb = self.nodes[m.a], self.nodes[m.b]
            self.sd.append([trans[pa, 0], trans[pa, 1], trans[pb, 0], trans[pb, 1]])
            self.sk.append(m.k)
            self.sX.append(points[pb] - points[pa])
            X = self.sX[-1]
            self.sl0.append(m.free_length if m.free_length is not None else np.hypot(*X))
            ends = np.array([0.0, np.hypot(*X)])
            self.members.append(MemberMesh(m.id, "spring", np.array([pa, pb]), slice(0, 0), ends))
        self.spring_X = np.array(self.sX, dtype=float).reshape(-1, 2)

    def _end_dof(self, member_id: str, node_id: str) -> int:
        m = self.scene.member(member_id)
        if m.kind == "spring":
            raise ModelError(f"torsion spring on linear spring {member_id!r}")
        if m.a == node_id:
            return self.end_rot[(m.id, "a")]
        if m.b == node_id:
            return self.end_rot[(m.id, "b")]
        raise ModelError(f"member {member_id!r} does not end at node {node_id!r}")

    def add_torsion_springs(self) -> None:
        """Torsion springs between two member ends at a node (or one end and ground)."""
        self.td, self.tk, self.tp = [], [], []
        for t in self.scene.torsion_springs:
            da = self._end_dof(t.member_a, t.node)
            db = self._end_dof(t.member_b, t.node) if t.member_b else self.ground
            if da == db:
                raise ModelError(f"torsion spring {t.id!r} joins two welded ends (no effect)")
            self.td.append([da, db])
            self.tk.append(t.stiffness)
            self.tp.append(math.radians(t.free_angle_deg))

    def _load_point(self, ld: object) -> tuple[int, tuple[int, ...]]:
        """(point id, rotation DOFs) a load acts on: a moment is shared equally among the
        DOFs (``cases.node_rotation``), a follower force needs exactly one."""
        if ld.node is not None:
            return self.nodes[ld.node], self.node_rot(ld.node)
        m = self.scene.member(ld.member)
        f = float(ld.fraction or 0.0)
        if f <= 0.0 or f >= 1.0:
            nid = m.a if f <= 0.0 else m.b
            k = (m.id, "a" if f <= 0.0 else "b")
            return self.nodes[nid], (self.end_rot[k],) if k in self.end_rot else self.node_rot(nid)
        if m.kind == "spring":
            raise ModelError(f"load {ld.id!r} along linear spring {m.id!r}")
        p = self.load_points[(m.id, f)][0]
        return p, (self.rot_of_point[p],)

    def add_loads(self, driver_load: bool) -> None:
        """Dead load vectors (lam-scaled and constant) and follower forces."""
        self.dead = np.zeros(self.nfull + 1)
        self.dead_c = np.zeros(self.nfull + 1)
        self.fd, self.ff, self.fg = [], [], []
        trans = self.trans
        for ld in self.scene.loads:
            p, r = self._load_point(ld)
            target = self.dead_c if driver_load else self.dead
            if ld.moment:
                if not r:
                    raise ModelError(f"load {ld.id!r}: moment at a point without rotation DOF")
                np.add.at(target, list(r), ld.moment / len(r))
            if ld.follower and (ld.fx or ld.fy):
                if not r:
                    raise ModelError(f"load {ld.id!r}: follower force needs a member end")
                if len(r) > 1:  # which end it turns with would depend on the listing order
                    raise ModelError(
                        f"load {ld.id!r}: a follower force turns with one member end, and the "
                        f"{len(r)} at node {ld.node!r} are all pinned; give it as member = "
                        "..., fraction = 0 or 1"
                    )
                self.fd.append([trans[p, 0], trans[p, 1], r[0]])
                self.ff.append([ld.fx, ld.fy])
                self.fg.append(1 if driver_load else 0)
            else:
                target[trans[p, 0]] += ld.fx
                target[trans[p, 1]] += ld.fy

    def add_driver(self, driver_load: bool) -> None:
        """The driver coordinate of distance / energy analyses (DOF and output scale)."""
        drv = self.scene.analysis.driver
        self.driver_dof, self.driver_scale = None, 1.0
        if drv is None:
            if driver_load:
                raise ModelError("driver_load needs analysis.driver")
            return
        if drv.kind == "displacement":
            if drv.node is None or drv.direction not in ("x", "y"):
                raise ModelError("displacement driver needs node and direction x|y")
            self.driver_dof = int(
                self.trans[self.nodes[drv.node], 0 if drv.direction == "x" else 1]
            )
        elif drv.kind == "rotation":
            if drv.member is None or (drv.member, "a") not in self.end_rot:
                raise ModelError("rotation driver needs a beam or rigid member")
            self.driver_dof = self.end_rot[(drv.member, self._driven_end(drv.member))]
            self.driver_scale = 180.0 / math.pi
        else:
            raise ModelError(f"unknown driver kind {drv.kind!r}")
        if driver_load:
            self.dead[self.driver_dof] += 1.0

    def _driven_end(self, member_id: str) -> str:
        """The end of a driven member whose rotation DOF the driver holds: end a, or for a
        rigid link meshed as a stiff element the end the chains' rule roots it at
        (``orient.root_at_b``: grounded, firmer, nearer the ground), so the link's ~1 /
        rigid_factor bending does not depend on the direction it is drawn in.  Driven at its
        drawn end a, DAS-2D Ex. 4's crank drawn from its pinned coupler end turned 1.6e-7 rad
        away from the crank drawn from its ground pin (exactly 1 / rigid_factor scaled)."""
        m = self.scene.member(member_id)
        return "b" if m.kind == "rigid" and root_at_b(self.scene, m) else "a"

    # -- free DOFs, numbering, the system ---------------------------------------------------
    def _free_map(self) -> tuple[np.ndarray, np.ndarray, int]:
        """Supports -> (free index of every full DOF (-1: fixed), its coefficient, count);
        a slider's x and y share one free DOF along its line."""
        fixed: set[int] = set()
        slider: dict[int, tuple[int, float, float]] = {}
        for sup in self.scene.supports:
            tx, ty = self.trans[self.nodes[sup.node]]
            if sup.type in ("clamp", "pin"):
                fixed |= {int(tx), int(ty)}
            if sup.type in ("clamp", "guided") and sup.node in self.weld_rot:
                fixed.add(self.weld_rot[sup.node])
            if sup.type == "slider":
                a = math.radians(sup.angle_deg)
                slider[int(tx)] = (int(ty), math.cos(a), math.sin(a))
        nfull = self.nfull
        free = -np.ones(nfull + 1, dtype=np.int64)
        coef = np.ones(nfull + 1)
        coef[self.ground] = 0.0
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
        return free, coef, k

    def number_free_dofs(self) -> None:
        """Free DOF map, element families, RCM renumbering and the scatter."""
        free, self.coef, ndof = self._free_map()
        self.ndof = ndof
        self.con_dofs = np.array(self.con, dtype=np.int64).reshape(-1, 7)
        nfull = self.nfull
        self.is_rot_full = np.ones(nfull + 1, dtype=bool)
        self.is_rot_full[self.trans.ravel()] = False
        is_mult_full = np.zeros(nfull + 1, dtype=bool)
        is_mult_full[self.con_dofs[:, 5:].ravel()] = True
        self.is_rot_full[is_mult_full] = False
        # families: beams (6), springs (4), torsion (2), followers (3), rigid links (7)
        self.fam = [
            self.beam_dofs,
            np.array(self.sd, dtype=np.int64).reshape(-1, 4),
            np.array(self.td, dtype=np.int64).reshape(-1, 2),
            np.array(self.fd, dtype=np.int64).reshape(-1, 3),
            self.con_dofs,
        ]
        key = ("numbering", ndof, *family_key(free, self.coef, self.fam))
        fam, coef = self.fam, self.coef
        self.free, self.scatter, self.bw = kept(key, lambda: _renumber(free, coef, fam, ndof))
        self.is_rotation = np.ones(ndof, dtype=bool)
        m_ = self.free >= 0
        self.is_rotation[self.free[m_][~self.is_rot_full[m_]]] = False
        self.is_multiplier = np.zeros(ndof, dtype=bool)
        self.is_multiplier[self.free[m_][is_mult_full[m_]]] = True

    def _mass_blocks(self) -> tuple[np.ndarray, ...]:
        """Element mass blocks per family (only beams carry mass)."""
        Mb = np.zeros((self.ne_total, 6, 6))
        if self.ne_total:
            MA, MR = np.concatenate(self.mA), np.concatenate(self.mR)
            for i, j in ((0, 3), (1, 4)):
                Mb[:, [i, i, j, j], [i, j, i, j]] = MA.reshape(-1, 4)
            Mb[:, [2, 2, 5, 5], [2, 5, 2, 5]] = MR.reshape(-1, 4)
        fam = self.fam
        return (
            Mb,
            np.zeros((fam[1].shape[0], 4, 4)),
            np.zeros((fam[2].shape[0], 2, 2)),
            np.zeros((fam[3].shape[0], 3, 3)),
            np.zeros((fam[4].shape[0], 7, 7)),
        )

    def _force_scale(self) -> float:
        """Force scale of the residual test: loads, spring preloads, else K_ref / L_ref."""
        Lref = self.Lref
        rs = np.where(self.is_rot_full, 1.0 / Lref, 1.0)  # moments -> force units
        fscale = float(np.linalg.norm(self.dead * rs) + np.linalg.norm(self.dead_c * rs))
        fscale += float(np.linalg.norm(self.ff or [0.0]))
        pre = [abs(kk * ph) / Lref for kk, ph in zip(self.tk, self.tp)]
        pre += [abs(kk * (l0 - np.hypot(*x))) for kk, l0, x in zip(self.sk, self.sl0, self.sX)]
        fscale = max(fscale, max(pre or [0.0]))
        if fscale == 0.0:
            fscale = self.Kref / Lref
        return fscale

    def system(self) -> FEMSystem:
        """The assembled ``FEMSystem``."""
        scene, fam, Lref, ndof = self.scene, self.fam, self.Lref, self.ndof
        spring_X = self.spring_X
        return FEMSystem(
            scene=scene,
            n_elements=self.n_default,
            ndof=ndof,
            free=self.free,
            coef=self.coef,
            points=self.points,
            trans=self.trans,
            beams=self.beams,
            beam_dofs=self.beam_dofs,
            members=self.members,
            spring_dofs=fam[1],
            spring_k=np.array(self.sk, float),
            spring_l0=np.array(self.sl0, float),
            spring_X=spring_X,
            spring_L=np.hypot(spring_X[:, 0], spring_X[:, 1]),
            tors_dofs=fam[2],
            tors_k=np.array(self.tk, float),
            tors_phi=np.array(self.tp, float),
            fol_dofs=fam[3],
            fol_f0=np.array(self.ff, float).reshape(-1, 2),
            fol_group=np.array(self.fg, dtype=np.int64),
            dead=self.dead,
            dead_const=self.dead_c,
            out_rot={o.name: self.node_rot(o.node) for o in scene.outputs},
            out_point={o.name: self.nodes[o.node] for o in scene.outputs},
            scatter=self.scatter,
            weights=np.where(
                self.is_multiplier, 0.0, np.where(self.is_rotation, 1.0, 1.0 / Lref**2)
            )
            / max(ndof, 1),
            is_rotation=self.is_rotation,
            mass_blocks=self._mass_blocks(),
            Lref=float(Lref),
            fscale=self._force_scale(),
            bandwidth=self.bw,
            con_dofs=self.con_dofs,
            con_X=np.array(self.con_X, dtype=float).reshape(-1, 2),
            con_kappa=self.Kref / Lref**2,
            is_multiplier=self.is_multiplier,
            extra={
                "Kref": self.Kref,
                "end_rot": self.end_rot,
                "weld_rot": self.weld_rot,
                "node_rot": self.node_rot,
                "nodes": self.nodes,
                "ground": self.ground,
                "driver_dof": self.driver_dof,
                "driver_scale": self.driver_scale,
            },
        )
