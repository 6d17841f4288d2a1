"""Assembly: a scene and a model per flexible member -> energy terms + constraints.

``build(scene, spec_of)`` returns a ``MechanismSystem``.  ``spec_of(member)`` gives the member
law of a flexible member: ``("chain", SegmentLaw, N, extensible)`` or ``("prb", matrix)``
(``model.py`` maps model names to these).  Rigid links are closure constraints (never stiff
beams); supports fix unknowns; sliders are linear constraints.

Total potential ``Pi(q; lam) = sum terms.energy(q) + lam * loads.energy(q)``; equilibrium is
stationarity of ``Pi + mu . c(q)`` (``newton.py``).  The dense Hessian fits these systems
(tens to a few hundred unknowns); every term is vectorised over its items.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from cases.schema import Member, Scene
from reduced_models.mechanism.constraints import Closure, Linear
from reduced_models.mechanism.members import (
    ChainTerm,
    JointTerm,
    LoadTerm,
    SpringTerm,
    TorsionTerm,
)
from reduced_models.mechanism.topology import (
    Layout,
    layout,
    member_frame,
    slider_rows,
    split_member_loads,
)


class SceneError(ValueError):
    """The scene uses something the assembler cannot represent (message = the reason)."""


def _scatter(
    n: int, idx: np.ndarray, g: np.ndarray, H: np.ndarray, gout: np.ndarray, Hout: np.ndarray
) -> None:
    """Add local gradient/Hessian blocks into dense arrays (one bincount each)."""
    k = idx.shape[1]
    gout += np.bincount(idx.ravel(), g.ravel(), minlength=n)
    flat = (idx[:, :, None] * n + idx[:, None, :]).reshape(-1, k * k)
    Hout += np.bincount(flat.ravel(), H.reshape(-1, k * k).ravel(), minlength=n * n).reshape(n, n)


class MechanismSystem:
    """Energy terms, load term and constraints of one scene (see module doc)."""

    def __init__(self, lay: Layout) -> None:
        self.lay = lay
        self.scene = lay.scene
        self.terms: list = []
        self.loads: LoadTerm | None = None
        self.constraints: list = []
        self.linear = Linear()
        self.chains: list[ChainTerm] = []
        self.prb_members: list[tuple[str, np.ndarray]] = []  # (member id, joint/point info)
        self.shape_of: dict[str, Callable[[np.ndarray], np.ndarray]] = {}
        self.driver_row: int | None = None
        self.driver_dof: int | None = None
        self.driver_scale = 1.0

    # -- sizes and scaling -------------------------------------------------------------------
    def finish(self) -> None:
        """Freeze sizes (call after every term/constraint is added)."""
        lay = self.lay
        self.q0 = np.array(lay.q0)
        self.n = lay.n
        self.free = lay.free()
        self.constraints = [c for c in self.constraints if c.m] + [self.linear]
        kind = np.array(lay.kind)
        Lref = lay.Lref
        k = [abs(t.stiffness) for t in self.scene.torsion_springs]
        k += [ch.EI.max() / Lref for ch in self.chains]
        k += [abs(m.k or 0.0) * Lref**2 for m in self.scene.members if m.kind == "spring"]
        k += [float(np.max(t.K)) for t in self.terms if isinstance(t, JointTerm) and t.K.size]
        self.Kref = max(k or [1.0])
        fl = 0.0
        for ld in self.scene.loads:
            fl = max(fl, math.hypot(ld.fx, ld.fy), abs(ld.moment) / Lref)
        for t in self.terms:  # preloaded torsion springs
            if isinstance(t, TorsionTerm) and t.K.size:
                fl = max(fl, float(np.max(np.abs(t.K * t.offset))) / Lref)
        # driven or unloaded scenes: the force of the driver travel (at least a 1e-3 rad
        # turn) against the stiffest part
        drv, travel = self.scene.analysis.driver, 1e-3
        if drv is not None:
            span = abs(drv.stop - drv.start)
            travel = max(travel, math.radians(span) if drv.kind == "rotation" else span / Lref)
        self.fscale = max(fl, travel * self.Kref / Lref)
        # residual scale per unknown: forces, moments, and the p rows (EI/h x relation)
        rs = np.where(kind == "r", self.fscale * Lref, self.fscale)
        for ch in self.chains:
            rs[ch.dofs[:, 6]] = ch.w * 1e-3
        self.rscale = rs
        # global -> reduced index (fixed unknowns -> a dump slot nf): flat scatter maps of
        # every term are built once, so a Newton iteration is bincounts and matmuls only
        nf = len(self.free)
        self.nf = nf
        self.red = np.full(self.n, nf, dtype=np.int64)
        self.red[self.free] = np.arange(nf)
        self._maps: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._cmap: tuple | None = None

    @property
    def m(self) -> int:
        return sum(c.m for c in self.constraints)

    # -- evaluation --------------------------------------------------------------------------
    def strain_energy(self, q: np.ndarray) -> float:
        """Elastic energy of members and springs (force * length)."""
        e = sum(t.energy(q) for t in self.terms if not isinstance(t, ChainTerm))
        return float(e + sum(float(ch.strain(q).sum()) for ch in self.chains))

    def potential(self, q: np.ndarray, lam: float) -> float:
        """Total potential Pi(q; lam) (mixed Lagrangian value for chained segments)."""
        e = sum(t.energy(q) for t in self.terms)
        return float(e + lam * self.loads.energy(q))

    def grad_hess(self, q: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """Gradient (n,) and Hessian (n, n) of Pi in every unknown."""
        n = self.n
        g, H = np.zeros(n), np.zeros((n, n))
        for t in self.terms:
            idx, gl, Hl = t.local(q)
            if len(idx):
                _scatter(n, idx, gl, Hl, g, H)
        if lam != 0.0:
            gl_, Hl_ = self.load_grad_hess(q)
            g += lam * gl_
            H += lam * Hl_
        return g, H

    def load_grad_hess(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gradient and Hessian of minus the load work at factor 1."""
        n = self.n
        g, H = self.loads.lin.copy(), np.zeros((n, n))
        idx, gl, Hl = self.loads.local(q)
        if len(idx):
            _scatter(n, idx, gl, Hl, g, H)
        return g, H

    def cons(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Constraint values (m,) and dense Jacobian (m, n)."""
        vals, J = [], np.zeros((self.m, self.n))
        r0 = 0
        for c in self.constraints:
            vals.append(c.values(q))
            rows, cols, v = c.jacobian(q)
            np.add.at(J, (rows + r0, cols), v)
            r0 += c.m
        return (np.concatenate(vals) if vals else np.zeros(0)), J

    def curvature(self, q: np.ndarray, mu: np.ndarray) -> np.ndarray:
        """Hessian of mu . c(q), (n, n)."""
        n = self.n
        H, g = np.zeros((n, n)), np.zeros(n)
        r0 = 0
        for c in self.constraints:
            idx, Hl = c.curvature(q, mu[r0 : r0 + c.m])
            if len(idx):
                _scatter(n, idx, np.zeros(idx.shape), Hl, g, H)
            r0 += c.m
        return H

    def cscale(self) -> np.ndarray:
        """Scale of each constraint row (length, or 1 for angle rows of drivers)."""
        out = [np.full(c.m, self.lay.Lref) for c in self.constraints]
        s = np.concatenate(out) if out else np.zeros(0)
        if self.driver_row is not None and self.lay.kind[self.driver_dof] == "r":
            s[self.m - self.linear.m + self.driver_row] = 1.0
        return s

    # -- fast path: the reduced KKT blocks ---------------------------------------------------
    def _map(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = id(idx)
        hit = self._maps.get(key)
        if hit is None or hit[0] is not idx:
            N = self.nf + 1
            r = self.red[idx]
            hit = (idx, r.ravel(), (r[:, :, None] * N + r[:, None, :]).ravel())
            self._maps[key] = hit
        return hit[1], hit[2]

    def reduced(
        self, q: np.ndarray, lam: float, mu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Reduced gradient (nf,), W = Hess(Pi + mu.c) (nf, nf), c (m,), J (m, nf)."""
        N = self.nf + 1
        parts = [(t, 1.0) for t in self.terms] + [(self.loads, lam)] * int(lam != 0.0)
        gis, his, gvs, hvs = [], [], [], []
        for t, w in parts:
            idx, gl, Hl = t.local(q)
            if len(idx):
                gi, hi = self._map(idx)
                gis.append(gi)
                his.append(hi)
                gvs.append(gl.ravel() * w if w != 1.0 else gl.ravel())
                hvs.append(Hl.ravel() * w if w != 1.0 else Hl.ravel())
        # constraint curvature joins the same scatter
        r0 = 0
        for c in self.constraints:
            idx, Hl = c.curvature(q, mu[r0 : r0 + c.m])
            if len(idx):
                his.append(self._map(idx)[1])
                hvs.append(Hl.ravel())
            r0 += c.m
        key = tuple(id(a) for a in gis + his)
        if getattr(self, "_cat_key", None) != key:
            self._cat_key = key
            z = [np.zeros(0, np.int64)]
            self._cat = (np.concatenate(gis or z), np.concatenate(his or z))
        g = np.bincount(self._cat[0], np.concatenate(gvs or [np.zeros(0)]), minlength=N)
        H = np.bincount(self._cat[1], np.concatenate(hvs or [np.zeros(0)]), minlength=N * N)
        g, H = g.astype(float, copy=False), H.astype(float, copy=False)  # empty -> int
        if lam != 0.0:
            g[self.red] += lam * self.loads.lin  # fixed entries land in the dump slot
        vals, r0 = [], 0
        m = self.m
        if self._cmap is None or self._cmap[0] != m:
            rows, cols = [], []
            for c in self.constraints:
                rr, cc, _ = c.jacobian(q)
                rows.append(rr + r0)
                cols.append(self.red[cc])
                r0 += c.m
            fl = np.concatenate(rows) * N + np.concatenate(cols) if rows else np.zeros(0, int)
            self._cmap = (m, fl)
        jv = []
        for c in self.constraints:
            vals.append(c.values(q))
            jv.append(c.jacobian(q)[2])
        J = np.bincount(self._cmap[1], np.concatenate(jv), minlength=m * N).reshape(m, N)
        J = J[:, : self.nf]
        cv = np.concatenate(vals) if vals else np.zeros(0)
        return g[: self.nf], H.reshape(N, N)[: self.nf, : self.nf], cv, J

    def reduced_load(self, q: np.ndarray) -> np.ndarray:
        """Reduced gradient of minus the load work at factor 1, (nf,)."""
        N = self.nf + 1
        g = np.zeros(N)
        g[self.red] += self.loads.lin
        idx, gl, _ = self.loads.local(q)
        if len(idx):
            gi, _ = self._map(idx)
            g += np.bincount(gi, gl.ravel(), minlength=N)
        return g[: self.nf]

    # -- outputs -------------------------------------------------------------------------------
    def outputs(self, q: np.ndarray) -> dict[str, float]:
        """Scene outputs ``name.x/.y/.ux/.uy/.rot`` of a state."""
        out = {}
        for o in self.scene.outputs:
            n = self.scene.node(o.node)
            i = self.lay.node_dof[o.node]
            r = self.lay.node_rot.get(o.node)
            out[f"{o.name}.x"] = float(q[i])
            out[f"{o.name}.y"] = float(q[i + 1])
            out[f"{o.name}.ux"] = float(q[i] - n.x)
            out[f"{o.name}.uy"] = float(q[i + 1] - n.y)
            out[f"{o.name}.rot"] = float(q[r]) if r is not None else 0.0
        return out

    def shapes(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Member id -> (k, 2) polyline of the deformed member (rigid: its two nodes)."""
        return {mid: f(q) for mid, f in self.shape_of.items()}


# -- builder -----------------------------------------------------------------------------------


def build(scene: Scene, spec_of: Callable[[Member], tuple]) -> MechanismSystem:
    """Assemble ``scene`` with the member laws given by ``spec_of`` (module doc)."""
    if any(ld.follower and (ld.fx or ld.fy) for ld in scene.loads):
        raise SceneError(
            "follower loads are non-conservative: the energy-based assembler takes dead loads"
        )
    scene = split_member_loads(scene)
    lay = layout(scene)
    sysm = MechanismSystem(lay)
    closure: list = [[], [], [], [], [], []]  # ends, chain, len, ang, u, alpha
    chain_rows: dict[int, list] = {}
    joints: list[list] = [[], [], []]
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
        if spec[0] == "chain":
            _add_chain(sysm, m, spec, L, alpha, xa, xb, ra, rb, chain_rows)
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
    xa: int,
    xb: int,
    ra: int,
    rb: int,
    chain_rows: dict,
) -> None:
    """N chained segments: internal nodes (X, Y, phi) and one axial force per segment."""
    _, law, N, extensible = spec
    lay = sysm.lay
    h = L / N
    c, s = math.cos(alpha), math.sin(alpha)
    a = lay.scene.node(m.a)
    nodes_x = [xa]
    nodes_r = [ra]
    for i in range(1, N):
        idx = lay.add([a.x + c * h * i, a.y + s * h * i, 0.0], "t")
        lay.kind[idx[2]] = "r"
        nodes_x.append(int(idx[0]))
        nodes_r.append(int(idx[2]))
    nodes_x.append(xb)
    nodes_r.append(rb)
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
    mi = len(sysm.shape_of)
    chain_rows[key].append(
        (law, dofs, np.full(N, h), np.full(N, EI), np.full(N, k), np.full(N, alpha), np.full(N, mi))
    )
    xs = np.array(nodes_x)
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
            prev = owner
        u = -1
        if math.isfinite(matrix[i, 1]) and math.isfinite(EA):
            u = int(lay.add([0.0], "u")[0])
            lay.kind[u] = "t"
            joints[0].append(u)
            joints[1].append(lay.ground)  # held at 0: 1/2 K u^2
            joints[2].append(matrix[i, 1] * EA / L)
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
            r = lay.node_rot.get(nid)
            if r is None:
                raise SceneError(f"load {ld.id!r}: moment at a node without rotation")
            lin[r] -= ld.moment
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
