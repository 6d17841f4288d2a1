"""The deployed six-bar as a structure (seed 001, Chapter 2): mechanism and self-stress counts
from the equilibrium matrix (Eqs. 2-11, 2-12, Pellegrino & Calladine 1986) and the overall
stiffness from the equilibrium, flexibility and spring matrices (Eqs. 2-46 to 2-48), condensed
to one joint.

The equations' symbols were lost from the text; written from the words around them and the
standard force-method forms: ``m = n_r - r`` and ``h = n_c - r`` (``r`` the rank of the
equilibrium matrix ``A``, ``n_r`` / ``n_c`` its rows / columns); the bars' stiffness
``K_b = A C^-1 A'`` with ``C`` the diagonal flexibility ``L / (E A)`` of each column (Eq. 2-7),
the springs' ``K_s = R_rows K R_rows'`` (joint stiffness in the joints' Cartesian
displacements), and ``K_t = K_b + K_s`` (Eq. 2-48).  Being linear, ``K_t`` holds no geometric
stiffness of the members' forces: where those vanish (springs at rest in the deployed pose)
it is the tangent, and as ``E A -> inf`` it tends to the constrained tangent of rigid bars.
"""

from __future__ import annotations

import numpy as np

from cases.schema import Scene
from reduced_models.thesis.chain import Chain


def counts(A: np.ndarray, rank: int) -> dict[str, int]:
    """Mechanisms ``m = n_r - r`` and states of self-stress ``h = n_c - r`` (Eqs. 2-11, 2-12)."""
    return {"mechanisms": A.shape[0] - rank, "self_stress": A.shape[1] - rank}


def flexibilities(scene: Scene, chain: Chain, lengths: np.ndarray, ncols: int) -> np.ndarray:
    """Diagonal of ``C`` (m/N) in the column order of ``A``: bar ``L / (E A)``; the ternary
    link's moment column is rigid (zero) and so is a locked boom unless the scene gives one
    (booms carry no E, A: rigid).  Shape (ncols,)."""
    welded = dict(chain.welds)
    out = []
    for i, mi in enumerate(chain.bars):
        m = scene.members[mi]
        out.append(lengths[i] / (m.E * m.A) if m.E and m.A else 0.0)
        if i in welded:
            out.append(0.0)
    out += [0.0] * (ncols - len(out))
    return np.array(out)


def joint_stiffness(
    A: np.ndarray, c: np.ndarray, R_rows: np.ndarray, K: np.ndarray, row: int
) -> dict[str, object]:
    """Overall stiffness ``K_t`` (Eq. 2-48) condensed to the joint whose x row is ``row``.

    Rigid columns (``c = 0``) are kept as exact constraints: ``K_t`` on the null space of
    their rows' transposes.  Returns the joint's 2x2 compliance (m/N; a rigid direction, e.g.
    along a locked boom, has none: the stiffness there is infinite), the stiffness of its
    softest direction (N/m, the inverse of the largest compliance) and that direction, and
    ``K_t``'s lowest eigenvalue on the admissible space (N/m)."""
    rigid = c == 0.0
    Kb = A[:, ~rigid] @ np.diag(1.0 / c[~rigid]) @ A[:, ~rigid].T
    Kt = Kb + R_rows @ K @ R_rows.T
    G = A[:, rigid].T  # rigid columns: G d = 0 (their elongations vanish)
    if G.size:
        _, s, Vt = np.linalg.svd(G)
        r = int(np.sum(s > s[0] * 1e-12)) if s.size else 0
        N = Vt[r:].T
    else:
        N = np.eye(Kt.shape[0])
    Kr = N.T @ Kt @ N
    F = N @ np.linalg.solve(Kr, N.T)  # flexibility of the constrained structure
    Fj = F[row : row + 2, row : row + 2]
    w, v = np.linalg.eigh(0.5 * (Fj + Fj.T))
    return {
        "joint_compliance": Fj.tolist(),
        "joint_soft_stiffness": float(1.0 / w[-1]),
        "joint_soft_direction": v[:, -1].tolist(),
        "lowest_eigenvalue": float(np.linalg.eigvalsh(0.5 * (Kr + Kr.T))[0]),
    }
