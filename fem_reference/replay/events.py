"""Boom events of the replay and of the static deploy: a ``LengthLock`` (the thesis's
tape-spring boom: a constant push between two points until their distance reaches
``length``, then a bar of exactly that length), resolved on a system's DOFs as a
``LockPair`` (distance, gradient, Hessian); ``locks_from_options`` reads them from case
options.  How the integrator locates and latches them: ``integrator.py``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


@dataclass(frozen=True)
class LengthLock:
    """A tape-spring boom between two points (Python API behind the proposed ``[[events]]``).

    Attributes
    ----------
    a, b : node ids, or ``(x, y)`` ground points (length units).
    length : distance at which the boom locks into a bar (length units).
    force : constant push (> 0 pushes the points apart) applied until the lock (force units).
    stop_stiffness : 0 (default): the boom latches into a bar; > 0: it never latches, the
        push stays on and an elastic stop of this stiffness (force / length) resists
        extension past ``length`` (the thesis's ADAMS collision damper, BISTOP).
    """

    a: str | tuple[float, float]
    b: str | tuple[float, float]
    length: float
    force: float = 0.0
    stop_stiffness: float = 0.0


class LockPair:
    """A LengthLock resolved on the DOFs: distance, its gradient G and Hessian H."""

    def __init__(self, lock: LengthLock, x0: np.ndarray, S: sp.csr_matrix) -> None:
        self.lock = lock
        self.x0 = x0  # (2,) undeformed b - a
        self.S = S  # (2, ndof): displacement of b minus displacement of a
        self.locked = False

    def geometry(self, q: np.ndarray) -> tuple[float, np.ndarray, sp.csr_matrix]:
        """Distance ell, gradient G (ndof,) and Hessian H (ndof, ndof) of ell(q)."""
        d = self.x0 + self.S @ q
        ell = float(math.hypot(d[0], d[1]))
        n = d / ell
        G = self.S.T @ n
        P = (np.eye(2) - np.outer(n, n)) / ell
        H = (self.S.T @ sp.csr_matrix(P) @ self.S).tocsr()
        return ell, np.asarray(G).ravel(), H

    def gap(self, q: np.ndarray) -> float:
        """ell(q) - lock length (negative before the lock when extending)."""
        d = self.x0 + self.S @ q
        return float(math.hypot(d[0], d[1])) - self.lock.length


def node_map(system: object, node: str) -> tuple[tuple[float, float], list]:
    """Coordinates of a scene node and its displacement map [(component, dof, coef)].

    FE systems (``assembly.FEMSystem``: ``trans``/``free``/``coef``) map sliders to one DOF
    with direction cosines; test systems give ``node_xy(node)`` and ``node_dofs(node)``.
    """
    if hasattr(system, "trans"):
        p = system.extra["nodes"][node]
        terms = []
        for k in range(2):
            f = system.trans[p, k]
            if system.free[f] >= 0 and system.coef[f] != 0.0:
                terms.append((k, int(system.free[f]), float(system.coef[f])))
        return tuple(system.points[p]), terms
    dofs = system.node_dofs(node)[:2]
    return system.node_xy(node), [(k, int(i), 1.0) for k, i in enumerate(dofs) if i is not None]


def resolve_locks(system: object, scene: object, locks: tuple[LengthLock, ...]) -> list[LockPair]:
    """Resolve lock ends (node ids or ground points) into distance maps on the free DOFs."""
    pairs = []
    n = system.ndof
    for lock in locks:
        x0 = np.zeros(2)
        rows, cols, vals = [], [], []
        for end, sign in ((lock.a, -1.0), (lock.b, 1.0)):
            if isinstance(end, str):
                xy, terms = node_map(system, end)
                for k, i, c in terms:
                    rows.append(k)
                    cols.append(i)
                    vals.append(sign * c)
            else:
                xy = end
            x0 += sign * np.asarray(xy, dtype=float)
        S = sp.csr_matrix((vals, (rows, cols)), shape=(2, n))
        pairs.append(LockPair(lock, x0, S))
    return pairs


def locks_from_options(events: object) -> tuple[LengthLock, ...]:
    """Case-option events (list of tables) -> LengthLocks (proposed ``[[events]]`` format)."""
    out = []
    for ev in events or ():
        if isinstance(ev, LengthLock):
            out.append(ev)
            continue
        if ev.get("kind", "lock-length") != "lock-length":
            raise ValueError(f"unknown event kind {ev.get('kind')!r}")
        ends = [tuple(ev[k]) if isinstance(ev[k], list | tuple) else ev[k] for k in ("a", "b")]
        out.append(LengthLock(ends[0], ends[1], float(ev["length"]), float(ev.get("force", 0))))
    return tuple(out)
