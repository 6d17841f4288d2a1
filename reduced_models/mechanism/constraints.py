"""Constraints of the mechanism assembler: loop closure of rigid links and PRB chains, and
linear constraints (sliders, drivers).

Every constraint family returns, for a state ``q``, its values, its Jacobian rows and the
Hessian of ``mu . c`` (the curvature the KKT matrix needs)::

    con.values(q) -> (m,)
    con.jacobian(q) -> (rows (E,), cols (E,), vals (E,))   sparse triplets, row-local
    con.curvature(q, mu) -> (idx (E, k), H (E, k, k))

``Closure``: for each chain of rigid segments from node a to node b (a rigid link is one
segment; a PRB member is its segments with their joint angles), two equations

    x_b - x_a - sum_i (l_i + u_i) (cos(alpha + th_i), sin(alpha + th_i)) = 0,

with th_i the angle unknown of segment i (the link's rotation, a PRB joint angle or the end
rotation for a rigid root segment) and u_i an optional stretch unknown.

``Linear``: rows ``sum_j a_j q[i_j] = b`` (``b`` may change between steps: drivers).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

#: (rows, cols, values) of Jacobian entries
Triplets = tuple[np.ndarray, np.ndarray, np.ndarray]


class Closure:
    """Loop closure of rigid-segment chains (module doc).

    Parameters
    ----------
    ends : (C, 2) x indices of node a and node b of each chain.
    seg_chain, seg_len, seg_ang, seg_u, seg_alpha : (S,) chain index, length, angle unknown,
        stretch unknown (-1: none), drawn direction of each segment.
    """

    def __init__(
        self,
        ends: ArrayLike,
        seg_chain: ArrayLike,
        seg_len: ArrayLike,
        seg_ang: ArrayLike,
        seg_u: ArrayLike,
        seg_alpha: ArrayLike,
    ) -> None:
        self.ends = np.asarray(ends, np.int64).reshape(-1, 2)
        self.chain = np.asarray(seg_chain, np.int64)
        self.len = np.asarray(seg_len, float)
        self.ang = np.asarray(seg_ang, np.int64)
        self.u = np.asarray(seg_u, np.int64)
        self.alpha = np.asarray(seg_alpha, float)
        self.m = 2 * len(self.ends)
        self.has_u = self.u >= 0
        # curvature pairs (angle, stretch); without a stretch the angle repeats (zero block)
        self.cidx = np.column_stack([self.ang, np.where(self.has_u, self.u, self.ang)])
        self._pattern()
        self._last: tuple | None = None
        self.any_u = bool(np.any(self.has_u))
        self.cidx1 = self.ang[:, None]

    def _seg(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        hit = self._last
        if hit is not None and hit[0] is q:  # values/jacobian/curvature at the same state
            return hit[1]
        out = self._seg_eval(q)
        self._last = (q, out)
        return out

    def _seg_eval(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        psi = self.alpha + q[self.ang]
        ell = (
            self.len + np.where(self.has_u, q[np.maximum(self.u, 0)], 0.0)
            if self.any_u
            else self.len
        )
        return np.cos(psi), np.sin(psi), ell

    def values(self, q: np.ndarray) -> np.ndarray:
        c, s, ell = self._seg(q)
        # rows (x, y) of each chain: one bincount over the segments' (x, y) projections
        proj = np.bincount(self._prow, np.concatenate([ell * c, ell * s]), minlength=self.m)
        return q[self._ib] - q[self._ia] - proj

    def jacobian(self, q: np.ndarray) -> Triplets:
        c, s, ell = self._seg(q)
        u = self.has_u
        vals = np.concatenate([self._ends_vals, ell * s, -ell * c, -c[u], -s[u]])
        return self._rows, self._cols, vals

    def _pattern(self) -> None:
        """Row/column pattern of the Jacobian (constant; values change with q)."""
        C = len(self.ends)
        r = 2 * np.arange(C)
        xa, xb = self.ends[:, 0], self.ends[:, 1]
        rs, u = 2 * self.chain, self.has_u
        self._rows = np.concatenate([r, r, r + 1, r + 1, rs, rs + 1, rs[u], rs[u] + 1])
        self._cols = np.concatenate(
            [xb, xa, xb + 1, xa + 1, self.ang, self.ang, self.u[u], self.u[u]]
        )
        one = np.ones(C)
        self._ends_vals = np.concatenate([one, -one, one, -one])
        self._ia = np.column_stack([xa, xa + 1]).ravel()  # (x, y) unknowns per row
        self._ib = np.column_stack([xb, xb + 1]).ravel()
        self._prow = np.concatenate([rs, rs + 1])  # row of each segment's x and y projection

    def curvature(self, q: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c, s, ell = self._seg(q)
        mx, my = mu[2 * self.chain], mu[2 * self.chain + 1]
        u = self.has_u
        if not self.any_u:  # rigid segments only: the (angle, angle) entries
            return self.cidx1, (ell * (mx * c + my * s))[:, None, None]
        idx = self.cidx
        H = np.zeros((len(c), 2, 2))
        H[:, 0, 0] = ell * (mx * c + my * s)
        cross = np.where(u, mx * s - my * c, 0.0)
        H[:, 0, 1] = H[:, 1, 0] = cross
        # without a stretch unknown the second index repeats the angle: zero block there
        return idx, H


class Linear:
    """Linear constraints ``a . q[idx] = b`` (sliders, drivers); no curvature."""

    def __init__(self) -> None:
        self.rows: list[tuple[np.ndarray, np.ndarray]] = []
        self.b: list[float] = []
        self.names: list[str] = []
        self._flat: tuple | None = None

    @property
    def m(self) -> int:
        return len(self.rows)

    def add(self, idx: ArrayLike, coef: ArrayLike, b: float, name: str) -> int:
        """Append a row; returns its position."""
        self.rows.append((np.asarray(idx, np.int64), np.asarray(coef, float)))
        self.b.append(float(b))
        self.names.append(name)
        return len(self.rows) - 1

    def values(self, q: np.ndarray) -> np.ndarray:
        rows, cols, vals = self.jacobian(q)
        return np.bincount(rows, vals * q[cols], minlength=self.m) - np.asarray(self.b)

    def jacobian(self, q: np.ndarray) -> Triplets:
        if not self.rows:
            z = np.zeros(0)
            return z.astype(np.int64), z.astype(np.int64), z
        if self._flat is None or len(self._flat[0]) != len(self.rows):
            rows = np.concatenate([np.full(len(i), k) for k, (i, _) in enumerate(self.rows)])
            cols = np.concatenate([i for i, _ in self.rows])
            vals = np.concatenate([a for _, a in self.rows])
            self._flat = (list(self.rows), rows, cols, vals)
        return self._flat[1], self._flat[2], self._flat[3]

    def curvature(self, q: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros((0, 1), np.int64), np.zeros((0, 1, 1))
