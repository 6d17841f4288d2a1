"""Precomputed scatters of element blocks into free-DOF vectors, csr matrices and LAPACK band
storage.

A full DOF ``f`` maps to free DOF ``free[f]`` (-1: fixed) with coefficient ``coef[f]`` (sliders
at an angle map two translations onto one free DOF).  A *family* is an (nb, k) array of full
DOF ids, one row per block (beams k = 6, linear springs 4, torsion springs 2, follower loads 3,
rigid-link constraints 7).
Index maps are built once per system; every assembly is then one gather/multiply and one
``np.bincount``, with no Python loop over elements.

* ``Scatter``: element-major blocks ((nb, k) vectors, (nb, k, k) matrices) into a free vector and
  a ``scipy.sparse.csr_matrix`` (used by the public ``residual_and_tangent`` and the replay).
* ``BandScatter``: *entry-major* blocks ((k, nb) vectors, (k*k, nb) matrices: row ``k a + b``
  holds entry (a, b) of every block, the layout the element kernel produces) into a free vector
  and straight into LAPACK general band storage for ``dgbtrf`` (no csr, no format conversion).
  Entries on fixed DOFs go to one spare bin that is dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.sparse as sp

# index maps kept: two per mesh, so a case's few meshes (a 4096-element mesh's are ~5 MB)
KEPT_MAX = 16
_KEPT: dict[tuple, Any] = {}


def family_key(free: np.ndarray, coef: np.ndarray, families: list[np.ndarray]) -> tuple:
    """Hashable identity of a DOF map and its element families (bytes and shapes)."""
    return (free.tobytes(), coef.tobytes(), *((f.shape, f.tobytes()) for f in families))


def kept(key: tuple, make: Callable[[], Any]) -> Any:
    """``make()`` once per ``key`` (the oldest of ``KEPT_MAX`` dropped): the index maps of a
    mesh are the same on every solve of a case, and building them cost a tenth of a
    16-element solve.  What is kept must not be written to (arrays are made read-only)."""
    got = _KEPT.get(key)
    if got is None:
        if len(_KEPT) >= KEPT_MAX:
            del _KEPT[next(iter(_KEPT))]
        got = _KEPT[key] = make()
    return got


class Scatter:
    """Element-major scatter into free vectors and csr matrices (pattern built once)."""

    def __init__(self, free: np.ndarray, coef: np.ndarray, families: list[np.ndarray], n: int):
        self.n = n
        i0, f0 = np.zeros(0, np.int64), np.zeros(0)  # so that no family at all concatenates
        rows_v, w_v, sel_v, rows_m, cols_m, w_m, sel_m = [i0], [f0], [i0], [i0], [i0], [f0], [i0]
        off_v = off_m = 0
        for edofs in families:
            nb, k = edofs.shape
            if nb == 0:  # contributes nothing (and its offsets do not move)
                continue
            fi, w = free[edofs], coef[edofs]
            ok = (fi >= 0) & (w != 0.0)
            sel_v.append(off_v + np.flatnonzero(ok.ravel()))
            rows_v.append(fi[ok])
            w_v.append(w[ok])
            okm = ok[:, :, None] & ok[:, None, :]
            sel_m.append(off_m + np.flatnonzero(okm.ravel()))
            rows_m.append(np.broadcast_to(fi[:, :, None], (nb, k, k))[okm])
            cols_m.append(np.broadcast_to(fi[:, None, :], (nb, k, k))[okm])
            w_m.append((w[:, :, None] * w[:, None, :])[okm])
            off_v += nb * k
            off_m += nb * k * k
        self.sel_v, self.rows_v = np.concatenate(sel_v), np.concatenate(rows_v)
        self.w_v = np.concatenate(w_v)
        self.sel_m, self.w_m = np.concatenate(sel_m), np.concatenate(w_m)
        rows, cols = np.concatenate(rows_m), np.concatenate(cols_m)
        keys, self.inv = np.unique(rows.astype(np.int64) * n + cols, return_inverse=True)
        self.indices = (keys % n).astype(np.int32)
        self.indptr = np.searchsorted(keys // n, np.arange(n + 1)).astype(np.int32)
        self.nnz = keys.size

    def vector(self, blocks: list[np.ndarray]) -> np.ndarray:
        """Sum of blocks (one (nb, k) array per family) into a free vector (n,)."""
        flat = np.concatenate([b.ravel() for b in blocks])
        return np.bincount(self.rows_v, flat[self.sel_v] * self.w_v, minlength=self.n)

    def matrix(self, mats: list[np.ndarray]) -> sp.csr_matrix:
        """Sum of block matrices (one (nb, k, k) array per family) as csr (n, n)."""
        flat = np.concatenate([m.ravel() for m in mats])
        data = np.bincount(self.inv, flat[self.sel_m] * self.w_m, minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def bandwidth(self) -> int:
        """Half-bandwidth max |i - j| of the assembled pattern."""
        rows = np.repeat(np.arange(self.n), np.diff(self.indptr))
        return int(np.max(np.abs(rows - self.indices), initial=0))


class BandScatter:
    """Entry-major scatter into a free vector and LAPACK general band storage.

    Parameters
    ----------
    free, coef : (nfull + 1,) free-DOF map and coefficients (see module docstring).
    families : list of (nb, k) full-DOF arrays; empty families are skipped (the caller passes
        values only for ``self.active`` families, in order).
    n : number of free DOFs.
    bw : half-bandwidth (kl = ku = bw); the band array has ``3 bw + 1`` rows.  None: vector
        scatter only (a pattern too wide for band storage).

    ``band(values)`` returns an (3 bw + 1, n) Fortran-ordered array with ``A[i, j]`` at row
    ``2 bw + i - j`` (the ``dgbtrf`` layout with room for the fill-in of partial pivoting).
    """

    def __init__(
        self,
        free: np.ndarray,
        coef: np.ndarray,
        families: list[np.ndarray],
        n: int,
        bw: int | None,
    ):
        self.n, self.bw = n, bw
        self.ldab = 3 * bw + 1 if bw is not None else 0
        self.size = self.ldab * n
        self.active = [i for i, f in enumerate(families) if f.shape[0] > 0]
        rv, wv, rm, wm = [], [], [], []
        for i in self.active:
            fi = free[families[i]].T  # (k, nb)
            w = coef[families[i]].T
            ok = (fi >= 0) & (w != 0.0)
            rv.append(np.where(ok, fi, n).ravel())
            wv.append(np.where(ok, w, 0.0).ravel())
            if bw is None:
                continue
            k = fi.shape[0]
            # entry (a, b) of block j: row fi[a, j], column fi[b, j]
            ri = np.repeat(fi, k, axis=0)  # (k*k, nb): row of entry k a + b is fi[a]
            ci = np.tile(fi, (k, 1))  # column of entry k a + b is fi[b]
            okm = np.repeat(ok, k, axis=0) & np.tile(ok, (k, 1))
            if np.any(okm & (np.abs(ri - ci) > bw)):
                raise ValueError("BandScatter: pattern wider than the given bandwidth")
            # Fortran storage of the (ldab, n) band: flat = col * ldab + (2 bw + row - col)
            flat = ci * self.ldab + (2 * bw + ri - ci)
            rm.append(np.where(okm, flat, self.size).ravel())
            wm.append((np.repeat(w, k, axis=0) * np.tile(w, (k, 1)) * okm).ravel())
        self.rows_v = np.concatenate(rv) if rv else np.zeros(0, np.int64)
        self.idx_m = np.concatenate(rm) if rm else np.zeros(0, np.int64)
        wv_ = np.concatenate(wv) if wv else np.zeros(0)
        wm_ = np.concatenate(wm) if wm else np.zeros(0)
        # weights are needed only for sliders at an angle (coefficients other than 0/1)
        unit_v = np.all((wv_ == 1.0) | (self.rows_v == n))
        unit_m = np.all((wm_ == 1.0) | (self.idx_m == self.size))
        self.w_v = None if unit_v else wv_
        self.w_m = None if unit_m else wm_

    def vector(self, blocks: list[np.ndarray]) -> np.ndarray:
        """Sum of entry-major blocks (one (k, nb) array per active family) into (n,)."""
        if not blocks:
            return np.zeros(self.n)
        flat = np.concatenate([b.ravel() for b in blocks]) if len(blocks) > 1 else blocks[0].ravel()
        if self.w_v is not None:
            flat = flat * self.w_v
        return np.bincount(self.rows_v, flat, minlength=self.n + 1)[: self.n]

    def band(self, mats: list[np.ndarray]) -> np.ndarray:
        """Sum of entry-major block matrices (one (k*k, nb) array per active family) in
        ``dgbtrf`` band storage, (3 bw + 1, n), Fortran order."""
        if not mats:
            return np.zeros((self.ldab, self.n), order="F")
        flat = mats[0].ravel() if len(mats) == 1 else np.concatenate([m.ravel() for m in mats])
        if self.w_m is not None:
            flat = flat * self.w_m
        ab = np.bincount(self.idx_m, flat, minlength=self.size + 1)[: self.size]
        return ab.reshape(self.n, self.ldab).T
