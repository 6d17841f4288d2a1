"""The assembled mechanism: energy terms + load term + constraints, and their evaluation.

``builder.build(scene, spec_of)`` returns a ``MechanismSystem``.

Total potential ``Pi(q; lam) = sum terms.energy(q) + lam * loads.energy(q)``; equilibrium is
stationarity of ``Pi + mu . c(q)`` (``newton.py``).  The dense Hessian fits these systems
(tens to a few hundred unknowns); every term is vectorised over its items.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from reduced_models.mechanism.constraints import Linear
from reduced_models.mechanism.elastica_member import ElasticaTerm
from reduced_models.mechanism.members import (
    ChainTerm,
    JointTerm,
    LoadTerm,
    TorsionTerm,
)
from reduced_models.mechanism.topology import (
    Layout,
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
        self.origin = (0.0, 0.0)  # where the scene's (centred) frame sits in the case's frame

    # -- sizes and scaling -------------------------------------------------------------------
    def finish(self) -> None:
        """Freeze sizes (call after every term/constraint is added)."""
        lay = self.lay
        self.q0 = np.array(lay.q0)
        self.n = lay.n
        self.free = lay.free()
        self.constraints = [c for c in self.constraints if c.m] + [self.linear]
        self._m_fixed = sum(c.m for c in self.constraints[:-1])
        kind = np.array(lay.kind)
        Lref = lay.Lref
        k = [abs(t.stiffness) for t in self.scene.torsion_springs]
        k += [ch.EI.max() / Lref for ch in self.chains]
        # exact (elastica) members likewise: without them a driven elastica scene's force
        # scale ignored its EI, and Newton's tolerance was in the scene's units (Ex. 6 with
        # EI x 4.5 stalled at a residual of 3e-10 above it)
        k += [t.EI / Lref for t in self.terms if isinstance(t, ElasticaTerm)]
        k += [abs(m.k or 0.0) * Lref**2 for m in self.scene.members if m.kind == "spring"]
        # joint springs: the torsion springs only.  A PRB axial spring (force / length, EA/L)
        # is a near-rigid link: counted in moment units (K Lref^2) it sets a force scale
        # (L/t)^2 too coarse for the bending the scene loads (Ex. 3's snap descent stopped
        # short); counted raw it mixes units (the answer depended on the length unit)
        for t in self.terms:
            if isinstance(t, JointTerm) and t.K.size:
                axial = kind[t.dofs[:, 0]] == "t"
                k.append(float(np.max(np.where(axial, 0.0, t.K), initial=0.0)))
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
        self._m_fixed = sum(c.m for c in self.constraints[:-1])

    @property
    def m(self) -> int:
        """Number of constraint rows (closures + linear rows, drivers included)."""
        return self._m_fixed + len(self.linear.rows)

    # -- evaluation --------------------------------------------------------------------------
    def strain_energy(self, q: np.ndarray) -> float:
        """Elastic energy of members and springs (force * length)."""
        e = sum(t.energy(q) for t in self.terms if not isinstance(t, ChainTerm))
        return float(e + sum(float(ch.strain(q).sum()) for ch in self.chains))

    def max_stress(self, q: np.ndarray) -> float | None:
        """Largest bending stress over flexible members (chained segments: curvature at the
        segment ends; PRB: joint moments), None when no thickness is known."""
        vals = [t.max_stress(q) for t in self.terms if hasattr(t, "max_stress")]
        vals = [v for v in vals if np.isfinite(v)]
        return max(vals) if vals else None

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
            r = list(self.lay.node_rot[o.node])  # their mean (cases.node_rotation)
            out[f"{o.name}.x"] = float(q[i]) + self.origin[0]
            out[f"{o.name}.y"] = float(q[i + 1]) + self.origin[1]
            out[f"{o.name}.ux"] = float(q[i] - n.x)
            out[f"{o.name}.uy"] = float(q[i + 1] - n.y)
            out[f"{o.name}.rot"] = float(np.mean(q[r])) if r else 0.0
        return out

    def shapes(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Member id -> (k, 2) polyline of the deformed member (rigid: its two nodes)."""
        o = np.array(self.origin)
        return {mid: f(q) + o for mid, f in self.shape_of.items()}
