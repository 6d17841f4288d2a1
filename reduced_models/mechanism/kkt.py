"""Fused assembly of a mechanism's KKT system, dense or sparse.

One evaluation at ``(q, lam, mu)`` gives the residual ``R = [grad Pi + J^T mu; c]`` (N = nf + m
entries) and the KKT matrix ``K = [[W, J^T], [J, 0]]`` with ``W = Hess Pi + sum mu_k Hess c_k``
(``newton`` module doc).  Every contribution -- the terms' local Hessians, the load Hessian
times ``lam``, the constraint curvature, the Jacobian entries in both off-diagonal blocks -- is
an array of values whose destinations depend only on the unknowns' layout and the number of
constraint rows.  Those destinations are computed once (a *plan*); an evaluation concatenates
the values and sums them into place with one ``bincount`` for the matrix and one for the
residual, so it costs the member laws plus a fixed handful of numpy calls, whatever the number
of members.

* dense (below ``SPARSE_FROM`` KKT unknowns): the flat (N + 1)^2 array, fixed unknowns landing
  in a dump row/column that is sliced off; LAPACK beats SuperLU up to a few hundred unknowns.
* sparse: the CSC data array of the pattern, built once per plan (``np.unique`` of the
  destinations, so duplicates are summed by the same bincount); ``kkt_sparse`` factorises it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

if TYPE_CHECKING:
    from reduced_models.mechanism.system import MechanismSystem

#: KKT size (free unknowns + constraint rows) from which the sparse path is used: measured on
#: the 26-DOF guide (20-step load analysis, CPU, BLAS on one thread; ``reports.bench --mech``):
#: cbcm-16 (258 unknowns) dense 44 ms / sparse 74 ms, cbcm-24 (386) 95 / 85, prb-fsm-96
#: (402) 61 / 88, cbcm-32 (514) 197 / 125, prb-fsm-128 (530) 136 / 120
SPARSE_FROM = 400


class Assembly:
    """KKT evaluations of one system (module doc).

    Parameters
    ----------
    sysm : the assembled system (``finish()`` called).
    sparse : force the sparse (True) or dense (False) path; None: by size (``SPARSE_FROM``).
    """

    def __init__(self, sysm: MechanismSystem, sparse: bool | None = None) -> None:
        self.s = sysm
        self.force = sparse
        self.nf = len(sysm.free)
        self._refs: list | None = None
        self.loads_local = len(sysm.loads.dofs) > 0  # forces on rigid links (angle-dependent)
        self.linf = sysm.loads.lin[sysm.free]

    # -- plan ------------------------------------------------------------------------------------
    def _build(self, refs: list, load_col: int | None) -> None:
        """Destinations of every value array of an evaluation (module doc)."""
        s, nf = self.s, self.nf
        m = s.m
        N = nf + m
        self.N, self.m = N, m
        self._sparse = N >= SPARSE_FROM if self.force is None else self.force
        w = N + 1  # row length of the flat array with the dump row/column N
        red = np.full(s.n, N, dtype=np.int64)
        red[s.free] = np.arange(nf)
        gidx, hidx, jr, jc, jrows = [], [], [], [], []
        for kind, idx, r0 in refs:
            if kind == "jac":  # idx = (rows, cols) of the constraint block from row r0
                jr.append(nf + r0 + idx[0])
                jc.append(red[idx[1]])
                jrows.append(r0 + idx[0])
                continue
            r = red[idx]
            hidx.append((r[:, :, None] * w + r[:, None, :]).ravel())
            if kind == "term":
                gidx.append(r.ravel())
        z = np.zeros(0, np.int64)
        jr, jc = np.concatenate(jr or [z]), np.concatenate(jc or [z])
        jt = jc * w + jr
        if load_col is not None:  # that column holds d r / d lam instead of J^T (driver row)
            jt[jr == load_col] = N * w + N
        hidx += [jr * w + jc, jt]  # J, then J^T (values: the same array twice)
        gidx.append(jc)  # J^T mu
        self.jrows = np.concatenate(jrows or [z])
        if load_col is not None:  # distance solves: d r / d lam in the driver's column
            hidx.append(np.arange(nf) * w + load_col)
        self.gidx = np.concatenate(gidx)
        self.hidx = np.concatenate(hidx)
        self.load_col = load_col
        cs = s.cscale()
        self.isc = np.concatenate([1.0 / s.rscale[s.free], 1.0 / cs])
        if self._sparse:
            self._pattern(w)

    def _pattern(self, w: int) -> None:
        """CSC pattern of the kept destinations and the map of each value into its data."""
        N = self.N
        r, c = np.divmod(self.hidx, w)
        keep = (r < N) & (c < N)
        self.keep = np.flatnonzero(keep)
        uniq, inv = np.unique(c[keep] * N + r[keep], return_inverse=True)
        self.inv, self.nnz = inv.ravel(), len(uniq)
        cols, self.indices = np.divmod(uniq, N)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=N))])

    # -- evaluation ------------------------------------------------------------------------------
    def evaluate(
        self, q: np.ndarray, lam: float, mu: np.ndarray, load_col: int | None = None
    ) -> tuple[np.ndarray, np.ndarray | sp.csc_matrix]:
        """Residual (N,) and KKT matrix (N, N) at a state; ``load_col``: put the reduced load
        gradient d r / d lam into that column (the load factor is the driver row's unknown)."""
        s = self.s
        refs, gv, hv = [], [], []
        for t in s.terms:
            idx, g, H = t.local(q)
            if len(idx):
                refs.append(("term", idx, 0))
                gv.append(g.ravel())
                hv.append(H.ravel())
        if self.loads_local:
            idx, g, H = s.loads.local(q)
            refs.append(("term", idx, 0))
            gv.append(lam * g.ravel())
            hv.append(lam * H.ravel())
        cvals, jvs, r0 = [], [], 0
        for c in s.constraints:
            if not c.m:
                continue
            cvals.append(c.values(q))
            rows, cols, jv = c.jacobian(q)
            jvs.append(jv)
            idx, H = c.curvature(q, mu[r0 : r0 + c.m])
            if len(idx):
                refs.append(("curv", idx, r0))
                hv.append(H.ravel())
            refs.append(("jac", (rows, cols), r0))
            r0 += c.m
        if self._stale(refs, load_col):
            self._build(refs, load_col)
            self._refs = refs
        N = self.N
        jv = np.concatenate(jvs) if jvs else np.zeros(0)
        gv.append(jv * mu[self.jrows])
        hv += [jv, jv]  # J and J^T (``_build``)
        if load_col is not None:
            hv.append(self.s.reduced_load(q))
        R = np.bincount(self.gidx, np.concatenate(gv), minlength=N + 1)[:N]
        R = R.astype(float, copy=False)
        if lam != 0.0:
            R[: self.nf] += lam * self.linf
        if cvals:
            R[self.nf :] = np.concatenate(cvals)
        vals = np.concatenate(hv)
        if self._sparse:
            data = np.bincount(self.inv, vals[self.keep], minlength=self.nnz)
            K = sp.csc_matrix((data, self.indices, self.indptr), shape=(N, N))
        else:
            K = np.bincount(self.hidx, vals, minlength=(N + 1) * (N + 1))
            K = K.astype(float, copy=False).reshape(N + 1, N + 1)[:N, :N]
        return R, K

    def _stale(self, refs: list, load_col: int | None) -> bool:
        old = self._refs
        if old is None or len(old) != len(refs) or load_col != self.load_col:
            return True
        if self.m != self.s.m:
            return True
        for a, b in zip(old, refs):
            if a[0] == "jac":
                if b[0] != "jac" or a[1][0] is not b[1][0] or a[1][1] is not b[1][1]:
                    return True
            elif a[1] is not b[1]:
                return True
        return False


def bordered_solve(
    K: np.ndarray | sp.csc_matrix, col: np.ndarray, row: np.ndarray, rhs: np.ndarray
) -> np.ndarray:
    """Solve ``[[K, col], [row]] z = rhs`` (``row``: n + 1 entries, the last the corner), dense
    or sparse like K; raises numpy.linalg.LinAlgError when singular."""
    n = K.shape[0]
    if not sp.issparse(K):
        B = np.zeros((n + 1, n + 1))
        B[:n, :n] = K
        B[:n, n] = col
        B[n, :] = row
        return np.linalg.solve(B, rhs)
    from scipy.sparse.linalg import splu

    corner = np.array([[row[n]]])
    B = sp.bmat([[K, sp.csc_matrix(col[:, None])], [sp.csr_matrix(row[None, :n]), corner]])
    try:
        return splu(B.tocsc()).solve(rhs)
    except RuntimeError as err:
        raise np.linalg.LinAlgError(str(err)) from None
