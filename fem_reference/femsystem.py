"""The discretised scene (``FEMSystem``): residual, tangent, mass and result recovery.

``assembly.build(scene, n_elements)`` creates it (meshes, DOF maps, supports, joints, springs,
loads; the modelling choices are in the docstring of ``assembly``).  Two ways to evaluate it:

* the ``DiscreteSystem`` protocol (``system.py``): ``residual``, ``residual_and_tangent`` (csr),
  ``mass``, ... used by the replay, the tests and any generic solver;
* the fast path of the static solvers: ``evaluate(u, lam)`` returns an ``Evaluation`` (the
  residual plus the element state it was computed from) and ``factor(ev)`` factorises the
  tangent at that point, assembled straight into LAPACK band storage.  Convergence can thus be
  checked on the residual before any tangent is formed, and the element kinematics are not
  recomputed for the tangent.

Element data are gathered entry-major (``(6, ne)``: one contiguous row per element DOF) so the
corotational kernel works on unit-stride vectors; see ``scatter.BandScatter``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from cases.node_rotation import no_own_rotation
from cases.schema import Scene
from fem_reference import corotational as cr
from fem_reference import rigid
from fem_reference.banded import BAND_MAX, BandedLU, SingularTangent
from fem_reference.scatter import BandScatter, Scatter, family_key, kept
from reduced_models.base import Step


class ModelError(ValueError):
    """The scene cannot be represented (message names the member/node and the reason)."""


@dataclass(slots=True)
class Evaluation:
    """Residual at ``(u, lam)`` and what the tangent there needs (fast path).

    Attributes
    ----------
    u : (ndof,) state; lam : load factor; r : (ndof,) residual ``f_int - f_ext``.
    st : element chord states (``corotational.LocalState``), or None without beams.
    d : (nfull + 1,) full DOF vector when springs or follower loads need it, else None.
    """

    u: np.ndarray
    lam: float
    r: np.ndarray
    st: cr.LocalState | None
    d: np.ndarray | None


@dataclass
class MemberMesh:
    """Mesh bookkeeping of one member: its points (node a ... node b) and element range."""

    id: str
    kind: str
    points: np.ndarray  # (n_pts,) point indices from node a to node b
    elements: slice  # slice into the beam element arrays (empty for springs)
    s: np.ndarray  # (n_pts,) arc-length coordinates
    thickness: float | None = None
    E: float | None = None
    I: float | None = None


@dataclass
class FEMSystem:
    """Discretised scene; see the docstring of ``assembly`` for the modelling choices.

    Public attributes used by the solvers: ``ndof``, ``weights`` (ndof,) arc-length metric
    (1/Lref^2 for translations, 1 for rotations, divided by ndof: an RMS norm, so arc-length
    steps mean the same on every mesh), ``is_rotation`` (ndof,) bool,
    ``preload`` (scale of spring preloads, 1.0 = as specified), ``const_factor`` (load factor
    of the ``constant`` load group, used by energy analyses), ``is_multiplier`` (ndof,) bool
    (the Lagrange multipliers of exact rigid links, ``rigid.py``; weight 0 in the metric).
    """

    scene: Scene
    n_elements: int
    ndof: int
    free: np.ndarray
    coef: np.ndarray
    points: np.ndarray
    trans: np.ndarray
    beams: cr.BeamSet
    beam_dofs: np.ndarray
    members: list[MemberMesh]
    spring_dofs: np.ndarray
    spring_k: np.ndarray
    spring_l0: np.ndarray
    spring_X: np.ndarray
    spring_L: np.ndarray
    tors_dofs: np.ndarray
    tors_k: np.ndarray
    tors_phi: np.ndarray
    fol_dofs: np.ndarray
    fol_f0: np.ndarray
    fol_group: np.ndarray
    dead: np.ndarray
    dead_const: np.ndarray
    out_rot: dict  # name -> rotation DOFs, rot is their mean (beam_mesh.node_rotation)
    out_point: dict
    scatter: Scatter
    weights: np.ndarray
    is_rotation: np.ndarray
    mass_blocks: tuple
    Lref: float
    fscale: float
    bandwidth: int = 0
    preload: float = 1.0
    const_factor: float = 0.0
    con_dofs: np.ndarray = field(default_factory=lambda: np.zeros((0, 7), dtype=np.int64))
    con_X: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    con_kappa: float = 1.0
    is_multiplier: np.ndarray | None = None
    stab_mode: bool = False  # tangents are the stability blocks (``rigid.stability_view``)
    extra: dict = field(default_factory=dict)

    # -- state helpers ---------------------------------------------------------------------
    def full(self, u: np.ndarray) -> np.ndarray:
        """Full DOF displacement vector (nfull + 1,) (last entry: ground, always 0)."""
        m, fm, cm = self._full_map
        d = np.zeros(self.free.shape[0])
        d[m] = cm * u[fm]
        return d

    @cached_property
    def _full_map(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(full DOFs that are free, their free DOFs, their coefficients) for ``full``."""
        m = np.flatnonzero(self.free >= 0)
        return m, self.free[m], self.coef[m]

    def _follower_forces(self, d: np.ndarray, group: int) -> tuple[np.ndarray, np.ndarray]:
        sel = self.fol_group == group
        th = d[self.fol_dofs[sel, 2]]
        c, s = np.cos(th), np.sin(th)
        fx, fy = self.fol_f0[sel, 0], self.fol_f0[sel, 1]
        f = np.zeros((sel.sum(), 3))
        f[:, 0], f[:, 1] = c * fx - s * fy, s * fx + c * fy
        dfdth = np.stack([-s * fx - c * fy, c * fx - s * fy], axis=1)
        return f, dfdth

    def _load_blocks(self, d: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """Follower blocks of the residual's external part and their stiffness (nf, 3, 3)."""
        nf = self.fol_dofs.shape[0]
        fb = np.zeros((nf, 3))
        kb = np.zeros((nf, 3, 3))
        for group, scale in ((0, lam), (1, self.const_factor)):
            sel = self.fol_group == group
            if sel.any() and scale != 0.0:
                f, dfdth = self._follower_forces(d, group)
                fb[sel] = scale * f
                kb[sel, 0:2, 2] = -scale * dfdth
        return fb, kb

    def _springs(self, d: np.ndarray, tangent: bool) -> tuple:
        ns = self.spring_dofs.shape[0]
        if ns == 0:
            return np.zeros((0, 4)), np.zeros((0, 4, 4)), 0.0
        dd = d[self.spring_dofs]
        x = self.spring_X + dd[:, 2:4] - dd[:, 0:2]
        ln = np.hypot(x[:, 0], x[:, 1])
        n = x / ln[:, None]
        l0 = self.spring_L + self.preload * (self.spring_l0 - self.spring_L)
        T = self.spring_k * (ln - l0)
        f = np.concatenate([-n * T[:, None], n * T[:, None]], axis=1)
        e = float(np.sum(0.5 * self.spring_k * (ln - l0) ** 2))
        if not tangent:
            return f, None, e
        nn = n[:, :, None] * n[:, None, :]
        k2 = self.spring_k[:, None, None] * nn + (T / ln)[:, None, None] * (np.eye(2) - nn)
        K = np.zeros((ns, 4, 4))
        K[:, :2, :2] = K[:, 2:, 2:] = k2
        K[:, :2, 2:] = K[:, 2:, :2] = -k2
        return f, K, e

    def _constraints(self, d: np.ndarray, tangent: bool) -> np.ndarray:
        """Rigid-link constraint blocks: residual (nc, 7) or tangent (nc, 7, 7); in
        ``stab_mode`` the stability blocks (``rigid.py``)."""
        dd = d[self.con_dofs]
        if not tangent:
            return rigid.forces(dd, self.con_X, self.con_kappa)
        if self.stab_mode:
            rho = rigid.RHO_FACTOR * self.con_kappa
            return rigid.stability_blocks(dd, self.con_X, self.con_kappa, rho)
        return rigid.tangent(dd, self.con_X, self.con_kappa)

    def max_link_error(self, u: np.ndarray) -> float:
        """Largest constraint violation |c| of the exact rigid links at state u (length)."""
        if not self.con_dofs.shape[0]:
            return 0.0
        c = rigid.violation(self.full(u)[self.con_dofs], self.con_X)
        return float(np.max(np.hypot(c[:, 0], c[:, 1])))

    def _torsion(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        nt = self.tors_dofs.shape[0]
        if nt == 0:
            return np.zeros((0, 2)), np.zeros((0, 2, 2)), 0.0
        rel = d[self.tors_dofs[:, 0]] - d[self.tors_dofs[:, 1]] - self.preload * self.tors_phi
        T = self.tors_k * rel
        f = np.stack([T, -T], axis=1)
        K = self.tors_k[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]])
        return f, K, float(np.sum(0.5 * self.tors_k * rel**2))

    # -- DiscreteSystem protocol -----------------------------------------------------------
    def external(self, u: np.ndarray) -> np.ndarray:
        """f_ext(u) at load factor 1 (the lam-scaled group only), (ndof,)."""
        if not self.fast.follow:  # dead loads only: a constant vector
            return self.fast.dead.copy()
        d = self.full(u)
        f = self.dead.copy()
        if self.fol_dofs.shape[0]:
            ff, _ = self._follower_forces(d, 0)
            np.add.at(f, self.fol_dofs[self.fol_group == 0, 0], ff[:, 0])
            np.add.at(f, self.fol_dofs[self.fol_group == 0, 1], ff[:, 1])
        return self._full_to_free(f)

    def _full_to_free(self, f: np.ndarray) -> np.ndarray:
        m = (self.free >= 0) & (self.coef != 0.0)
        return np.bincount(self.free[m], f[m] * self.coef[m], minlength=self.ndof)

    # -- fast path of the static solvers -----------------------------------------------------
    @cached_property
    def fast(self) -> SimpleNamespace:
        """Index maps of the fast path, built once (``assembly.build`` builds them eagerly).

        ``uidx`` (6, ne): free DOF of every element entry (``ndof`` = fixed, reads a 0);
        ``ucoef`` (6, ne) slider coefficients or None; ``scatter``: ``BandScatter`` over the
        families (beams, springs, torsion springs, followers), with band maps when the
        half-bandwidth is at most ``banded.BAND_MAX``; ``dead``/``dead_const`` on free DOFs
        (``dead`` and ``dead_const`` are constants of the built system); ``follow``: some
        follower force scales with lam; ``uext`` (ndof + 1,) the gather buffer of
        ``evaluate`` (last entry 0, read by the fixed DOFs).
        """
        n = self.ndof
        fi = self.free[self.beam_dofs].T
        w = self.coef[self.beam_dofs].T
        ok = (fi >= 0) & (w != 0.0)
        fams = [self.beam_dofs, self.spring_dofs, self.tors_dofs, self.fol_dofs, self.con_dofs]
        bw = self.bandwidth if self.bandwidth <= BAND_MAX else None
        return SimpleNamespace(
            uidx=np.ascontiguousarray(np.where(ok, fi, n)),
            ucoef=None if np.all(w[ok] == 1.0) else np.where(ok, w, 0.0),
            scatter=kept(
                ("band", n, bw, *family_key(self.free, self.coef, fams)),
                lambda: BandScatter(self.free, self.coef, fams, n, bw),
            ),
            others=bool(self.spring_dofs.shape[0] or self.tors_dofs.shape[0])
            or bool(self.fol_dofs.shape[0] or self.con_dofs.shape[0]),
            follow=bool(np.any(self.fol_group == 0)),
            dead=self._full_to_free(self.dead),
            dead_const=self._full_to_free(self.dead_const),
            uext=np.zeros(n + 1),
        )

    def evaluate(self, u: np.ndarray, lam: float) -> Evaluation:
        """Residual ``r(u, lam)`` and the element state behind it (no tangent work)."""
        fx = self.fast
        uext = fx.uext  # (ndof + 1,) whose last entry stays 0: the fixed DOFs read it
        uext[: self.ndof] = u
        dT = uext[fx.uidx]  # a new array: the buffer is free again
        if fx.ucoef is not None:
            dT *= fx.ucoef
        fT, st = cr.kernel_forces(self.beams, dT)
        if not fx.others:  # beams alone: one scatter, no full vector
            r = fx.scatter.vector([fT])
            d = None
        else:
            d = self.full(u)
            r = self._other_blocks(fT, d, lam)
        r -= lam * fx.dead
        if self.const_factor != 0.0:
            r -= self.const_factor * fx.dead_const
        return Evaluation(u, lam, r, st, d)

    def _other_blocks(self, fT: np.ndarray, d: np.ndarray, lam: float) -> np.ndarray:
        """Internal forces of beams (``fT``), springs, followers and rigid links on the free
        DOFs at the full state ``d``."""
        fx = self.fast
        blocks = {0: fT}
        if self.spring_dofs.shape[0]:
            blocks[1] = self._springs(d, False)[0].T
        if self.tors_dofs.shape[0]:
            blocks[2] = self._torsion(d)[0].T
        if self.fol_dofs.shape[0]:
            blocks[3] = -self._load_blocks(d, lam)[0].T
        if self.con_dofs.shape[0]:
            blocks[4] = self._constraints(d, False).T
        return fx.scatter.vector([blocks[i] for i in fx.scatter.active])

    def _tangent_blocks(self, ev: Evaluation) -> dict[int, np.ndarray]:
        """Entry-major tangent blocks {family: (k*k, nb)} at the evaluated point."""
        mats = {0: cr.kernel_tangent(self.beams, ev.st)}
        if ev.d is not None:
            if self.spring_dofs.shape[0]:
                Ks = self._springs(ev.d, True)[1]
                mats[1] = Ks.reshape(Ks.shape[0], 16).T
            if self.tors_dofs.shape[0]:
                Kt = self._torsion(ev.d)[1]
                mats[2] = Kt.reshape(Kt.shape[0], 4).T
            if self.fol_dofs.shape[0]:
                Kl = self._load_blocks(ev.d, ev.lam)[1]
                mats[3] = Kl.reshape(Kl.shape[0], 9).T
            if self.con_dofs.shape[0]:
                Kc = self._constraints(ev.d, True)
                mats[4] = Kc.reshape(Kc.shape[0], 49).T
        return mats

    def tangent_band(self, ev: Evaluation) -> np.ndarray:
        """Tangent at the evaluated point in ``dgbtrf`` band storage (3 bw + 1, ndof),
        Fortran order (only when ``bandwidth <= banded.BAND_MAX``)."""
        sc = self.fast.scatter
        if ev.d is None:  # beams alone
            return sc.band([cr.kernel_tangent(self.beams, ev.st)])
        mats = self._tangent_blocks(ev)
        return sc.band([mats[i] for i in sc.active])

    def tangent_csr(self, ev: Evaluation) -> sp.csr_matrix:
        """Tangent at the evaluated point as csr (ndof, ndof)."""
        mats = self._tangent_blocks(ev)
        sizes = (6, 4, 2, 3, 7)
        fams = (self.beam_dofs, self.spring_dofs, self.tors_dofs, self.fol_dofs, self.con_dofs)
        blocks = []
        for i, (k, f) in enumerate(zip(sizes, fams)):
            m = mats.get(i)
            blocks.append(np.zeros((f.shape[0], k, k)) if m is None else m.T.reshape(-1, k, k))
        return self.scatter.matrix(blocks)

    def factor(self, ev: Evaluation) -> object:
        """Factorised tangent at the evaluated point (``solve(b)`` method): LAPACK banded LU
        for narrow bands, else SuperLU.  Raises ``banded.SingularTangent``."""
        if self.fast.scatter.bw is not None:
            return BandedLU(self.tangent_band(ev), self.bandwidth)
        try:
            return spla.splu(self.tangent_csr(ev).tocsc())
        except RuntimeError as e:  # exactly singular
            raise SingularTangent(f"singular tangent ({e})") from None

    # -- DiscreteSystem protocol (continued) ------------------------------------------------
    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """r(u, lam) = f_int(u) - f_const(u) - lam f_ext(u), (ndof,)."""
        return self.evaluate(u, lam).r

    def residual_and_tangent(self, u: np.ndarray, lam: float) -> tuple[np.ndarray, sp.csr_matrix]:
        """r(u, lam) and K = dr/du (material + geometric + follower-load stiffness), csr."""
        ev = self.evaluate(u, lam)
        return ev.r, self.tangent_csr(ev)

    def mass(self) -> sp.csr_matrix:
        """Consistent mass matrix on the free DOFs (see module docstring), (ndof, ndof)."""
        return self.scatter.matrix(list(self.mass_blocks))

    def strain_energy(self, u: np.ndarray) -> float:
        """Elastic energy in beams, linear springs and torsion springs."""
        d = self.full(u)
        return self._strain_energy(d, cr.local_state(self.beams, d[self.beam_dofs]))

    def _strain_energy(self, d: np.ndarray, st: cr.LocalState) -> float:
        # np.add.reduce: np.sum's pairwise sum without its wrapper (a tenth of a step record)
        e = np.add.reduce(cr.energy(self.beams, st))
        e += self._springs(d, False)[2] if self.spring_dofs.shape[0] else 0.0
        return float(e + (self._torsion(d)[2] if self.tors_dofs.shape[0] else 0.0))

    def length_scale(self) -> float:
        """Largest member length."""
        return self.Lref

    def residual_floor(self, centred: bool = False) -> float:
        """Round-off level of the scaled residual norm, ``10 eps |x| max(k_a sqrt(ndof), k_b)``
        (``centred``: |x| the largest distance from the nodes' centroid, the same however the
        scene is drawn -- moved or turned -- for decisions that must not move with the drawing).

        The axial part (stiffest EA / L0 or spring, summed over the DOFs in quadrature) is the
        floor the FE always had.  The backward error of the Newton solve adds eps times the
        stiffest bending entry 12 EI / L0^3, which dominates at fine meshes: measured on the
        tip-loaded cantilever (EA L^2/EI = 1e4), Newton stalls at |r| = 3.6e-6 (1024
        elements) and 2.4e-4 (4096), 16x and 15x below this floor; with the axial part alone
        the floor sat below the stall and those meshes could never converge.  Convergence
        still needs the correction's energy at round-off (``newton.converged``)."""
        b = self.beams
        k = max(float(np.max(b.ka, initial=0.0)), float(np.max(self.spring_k, initial=0.0)))
        k *= math.sqrt(max(self.ndof, 1))
        if b.L0.size:
            k = max(k, float(np.max(12.0 * b.EI / b.L0**3)))
        pts = np.asarray(self.points, dtype=float)
        if centred and pts.size:  # distances from the centroid
            pts = np.hypot(*(pts - pts.mean(axis=0)).T)
        xmax = float(np.max(np.abs(pts), initial=0.0)) + self.Lref
        return 10.0 * np.finfo(float).eps * k * xmax

    def force_scale(self) -> float:
        """A force magnitude for residual tolerances (loads, preloads or stiffness based)."""
        return self.fscale

    def output_functional(self, key: str) -> tuple[int, float, float]:
        """Output ``name.q`` as ``offset + coef * u[index]`` (index -1: fixed value)."""
        name, q = key.rsplit(".", 1)
        if name not in self.out_point:
            raise KeyError(key)
        p = self.out_point[name]
        if q in ("x", "y", "ux", "uy"):
            f = self.trans[p, 0 if q in ("x", "ux") else 1]
            off = self.points[p, 0 if q == "x" else 1] if q in ("x", "y") else 0.0
        elif q == "rot":
            rs, off = self.out_rot[name], 0.0
            if not rs:
                return -1, 0.0, 0.0
            if len(rs) > 1:  # a mean: the controls take one unknown (the loader refuses it)
                raise ModelError(no_own_rotation(key))
            f = rs[0]
        else:
            raise KeyError(key)
        return int(self.free[f]), float(self.coef[f]), float(off)

    def node_dofs(self, node_id: str) -> tuple[int | None, int | None, int | None]:
        """Free DOF indices (ux, uy, rot) of a scene node; None where fixed or absent.

        For a slider both translations may map to the same free DOF (with coefficients); a
        node whose member ends are all pinned has no rotation of its own (None)."""
        p = self.extra["nodes"][node_id]
        rs = self.extra["node_rot"](node_id)
        r = rs[0] if len(rs) == 1 else None
        out = []
        for f in (self.trans[p, 0], self.trans[p, 1], r):
            ok = f is not None and self.free[f] >= 0 and self.coef[f] != 0.0
            out.append(int(self.free[f]) if ok else None)
        return tuple(out)

    def driver_functional(self) -> tuple[int, float, float]:
        """Driver coordinate (driver units: length or degrees) as ``scale * coef * u[index]``;
        returns (index, coef * scale, 0.0); index -1 if a support fixes it."""
        f = self.extra["driver_dof"]
        if f is None:
            raise ModelError("scene has no driver")
        return int(self.free[f]), float(self.coef[f] * self.extra["driver_scale"]), 0.0

    def outputs(self, u: np.ndarray) -> dict[str, float]:
        """All node outputs of the scene at state u."""
        return self._outputs(self.full(u))

    def _outputs(self, d: np.ndarray) -> dict[str, float]:
        out: dict[str, float] = {}
        for name, p in self.out_point.items():
            ux, uy = d[self.trans[p, 0]], d[self.trans[p, 1]]
            rs = list(self.out_rot[name])  # mean of pinned member ends (cases.node_rotation)
            out[f"{name}.x"] = float(self.points[p, 0] + ux)
            out[f"{name}.y"] = float(self.points[p, 1] + uy)
            out[f"{name}.ux"] = float(ux)
            out[f"{name}.uy"] = float(uy)
            out[f"{name}.rot"] = float(np.mean(d[rs])) if rs else 0.0
        return out

    def shapes(self, u: np.ndarray) -> dict[str, np.ndarray]:
        """Deformed points of every member, {id: (n, 2)} from node a to node b."""
        return self._shapes(self.full(u))

    def _shapes(self, d: np.ndarray) -> dict[str, np.ndarray]:
        disp = d[self.trans]
        return {m.id: self.points[m.points] + disp[m.points] for m in self.members}

    def max_stress(self, u: np.ndarray) -> float | None:
        """max |E t kappa / 2| over flexible members with a thickness, or None."""
        return self._max_stress(self.full(u), None)

    def _max_stress(self, d: np.ndarray, st: cr.LocalState | None) -> float | None:
        ms = [
            m
            for m in self.members
            if m.kind == "flexible" and m.thickness is not None and m.E is not None
        ]
        if not ms:
            return None
        if st is None:
            st = cr.local_state(self.beams, d[self.beam_dofs])
        kap = cr.end_curvatures(self.beams, st)
        return max(m.E * m.thickness * float(np.max(kap[m.elements])) / 2.0 for m in ms)

    def step(
        self,
        u: np.ndarray,
        lam: float,
        iterations: int,
        stable: bool | None,
        local: cr.LocalState | None = None,
        extra_out: dict | None = None,
        info: dict | None = None,
    ) -> Step:
        """Outputs (and ``extra_out``), shapes, strain energy and max stress of state u as a
        ``Step`` with factor ``lam`` and ``info`` (``local``: the element state of u when the
        solver has it, ``Evaluation.st``)."""
        d = self.full(u)  # one full vector and one element state for every quantity
        st = local if local is not None else cr.local_state(self.beams, d[self.beam_dofs])
        outputs = self._outputs(d)
        outputs.update(extra_out or {})
        return Step(
            factor=float(lam),
            outputs=outputs,
            energy=self._strain_energy(d, st),
            iterations=int(iterations),
            stable=stable,
            shapes=self._shapes(d),
            max_stress=self._max_stress(d, st),
            info=info or {},
        )
