"""End loads, shape and stress of solved PRB chain states (seed 000_265bc60728766176.txt,
"Computing Beam Shape and Stress"): the end loads recovered from the spring torques through the
Moore-Penrose pseudo-inverse of the Jacobian transpose, the PRB's own chain of rigid links as
the shape, and the stress of the bending moment these loads give at the root, the pivots and
the tip.  The chain itself is ``reduced_models.beam.prb_chain.PRBChain``.
"""

from __future__ import annotations

import numpy as np

from cases.schema import Scene
from reduced_models.beam.prb_chain import PRBChain
from reduced_models.beam.single_beam import Cantilever


def recover_tip_loads_batch(
    chain: PRBChain, X: np.ndarray, f_known: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``recover_tip_loads`` for a stack of states X (m, n) (batched: the closed form of
    one spring row, LU solves of square J^T that are surely full rank, one SVD for the rest).

    ``f_known`` is None or (m, 3).  Returns ``(f (m, 3), rank (m,))``.
    """
    JT = chain.jacobian_T(X)  # (m, k, 3)
    tau = chain.spring_forces(X)  # (m, k)
    if JT.shape[1] == 1 and f_known is not None:  # one spring row r: closed form, no SVD
        r, t = JT[:, 0, :], tau[:, 0]
        r2 = (r * r).sum(axis=1)
        rank = (np.sqrt(r2) > 1e-12).astype(int)
        inv = np.where(rank > 0, 1.0 / np.where(rank > 0, r2, 1.0), 0.0)
        # f = pinv(r) tau + (I - r r^T / |r|^2) f_known
        fk = np.asarray(f_known, dtype=float)
        f = fk + r * (inv * (t - (r * fk).sum(axis=1)))[:, None]
        return _drop_round_off(f, chain.L), rank
    if JT.shape[1] != 3:
        return _pinv_loads(JT, tau, f_known, chain.L)
    # square J^T: an LU solve of each J^T that is surely full rank, the SVD for the others
    # (a straight chain, the unloaded state); per matrix both are exact to round-off
    full = _surely_full_rank(JT)
    if not full.any():
        return _pinv_loads(JT, tau, f_known, chain.L)
    f, rank = np.empty((len(JT), 3)), np.full(len(JT), 3)
    f[full] = _drop_round_off(np.linalg.solve(JT[full], tau[full][:, :, None])[:, :, 0], chain.L)
    rest = ~full
    if rest.any():
        known = None if f_known is None else np.asarray(f_known, dtype=float)[rest]
        f[rest], rank[rest] = _pinv_loads(JT[rest], tau[rest], known, chain.L)
    return f, rank


def _pinv_loads(
    JT: np.ndarray, tau: np.ndarray, f_known: np.ndarray | None, L: float
) -> tuple[np.ndarray, np.ndarray]:
    """f = pinv(J^T) tau by one batched SVD (J^T (m, k, 3), tau (m, k)), its null-space part
    from ``f_known`` (m, 3) where J^T has rank < 3; ``(f (m, 3), rank (m,))``."""
    U, sv, Vt = np.linalg.svd(JT, full_matrices=False)  # (m, k, r), (m, r), (m, r, 3)
    keep = sv > 1e-12 * np.maximum(1.0, sv[:, :1])
    rank = keep.sum(axis=1)
    # matmul, not einsum: einsum parses its subscripts on every call (~20 us each)
    coef = (tau[:, None, :] @ U)[:, 0] / np.where(keep, sv, 1.0) * keep
    f = (coef[:, None, :] @ Vt)[:, 0]
    if f_known is not None:
        # rank < 3: complete the null-space component of J^T from the known loads
        fk = np.asarray(f_known, dtype=float)
        Vk = Vt * keep[:, :, None]
        null = fk - ((Vk @ fk[:, :, None]).transpose(0, 2, 1) @ Vk)[:, 0]
        f = f + np.where((rank < 3)[:, None], null, 0.0)
    return _drop_round_off(f, L), rank


def _surely_full_rank(JT: np.ndarray) -> np.ndarray:
    """(m,) bool: square J^T (m, 3, 3) passes the SVD's rank test (smallest singular value
    > 1e-12 max(1, largest)), so that its pseudo-inverse is its inverse.  A sufficient test
    without the SVD: s_min >= |det| / s_max^2 and s_max <= the Frobenius norm F, so
    |det| > 1e-12 F^2 max(1, F) implies full rank."""
    fro2 = (JT * JT).sum(axis=(1, 2))
    bound = 1e-12 * fro2 * np.maximum(1.0, np.sqrt(fro2))
    return np.abs(np.linalg.det(JT)) > bound


def _drop_round_off(f: np.ndarray, L: float) -> np.ndarray:
    """End loads (m, 3) with components at round-off level (below the equilibrium tolerance)
    set to zero: a tip moment of 1e-16 would otherwise send the elastica to its slower
    combined-load route."""
    size = np.abs(f) * np.array([1.0, 1.0, 1.0 / L])
    tiny = size < 1e-10 * np.maximum(size.max(axis=1, keepdims=True), 1e-300)
    return np.where(tiny, 0.0, f)


def shape_and_stress(
    scene: Scene, beam: Cantilever, chain: PRBChain, X: np.ndarray, F: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None]:
    """The PRB's own deformed shapes (global points) and largest bending stresses of a stack
    of states X (m, n) under end loads F (m, 3), all states at once.

    Shape: the root, every pivot and the tip of the rigid links, shape (m, S + 1, 2).
    Stress: the bending moment ``m + (tip - p) x f`` of the end loads ``f`` (recovered from
    the PRB's spring forces) is linear along each rigid link, so its largest magnitude is at
    the root, a pivot or the tip; ``|M| t / (2 I)``, shape (m,).  Returns ``(shapes,
    max_stress)``, ``max_stress`` None when the member's thickness or E is unknown.
    """
    mem = scene.member(beam.member)
    xy = chain.points(X)
    stress = None
    if mem.thickness is not None and mem.E is not None:
        tip = xy[:, -1:, :]
        p = np.concatenate([np.zeros_like(tip), xy[:, chain.jidx], tip], axis=1)
        arm = tip - p
        M = F[:, 2:3] + arm[..., 0] * F[:, 1:2] - arm[..., 1] * F[:, 0:1]
        stress = mem.E * mem.thickness * np.max(np.abs(M), axis=1) / (2.0 * chain.EI)
    return beam.rotate_to_global(xy), stress
