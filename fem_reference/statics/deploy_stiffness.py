"""The deployed structure's tangent stiffness at a joint on the FE reference (issue 25: the
thesis's Eqs. 2-46 to 2-48 computed from the full tangent, seed 001).

At the locked equilibrium of ``statics.deploy`` the tangent ``W = K + mu H`` (springs, the
FE's rigid links and the geometric stiffness of every member force, the locked boom's
bar force ``mu`` through its length's Hessian ``H``) bordered by the boom's length gradient
``G``; a force ``f`` at the joint enters through the joint's displacement map ``S`` (2, ndof)
and its first-order displacement is ``S x``: the compliance ``C = S [W G; G' 0]^-1 S'``.
"""

from __future__ import annotations

import numpy as np

from fem_reference.replay import events


def joint_compliance(d: object, q: np.ndarray, bar: float, node: str) -> dict[str, object]:
    """Compliance (length/force, 2x2), softest stiffness (force/length) and its direction at
    ``node`` of the locked deployed state ``q`` (``d``: the ``FEDeploy``; ``bar``: the boom's
    bar force multiplier)."""
    _, K = d.sys.residual_and_tangent(q, 0.0)
    _, G, H = d.pair.geometry(q)
    n = d.sys.ndof
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = K.toarray() + bar * H.toarray()
    A[:n, n] = A[n, :n] = np.asarray(G).ravel()
    S = np.zeros((2, n))
    for k, i, c in events.node_map(d.sys, node)[1]:
        S[k, i] += c
    X = np.linalg.solve(A, np.vstack([S.T, np.zeros((1, 2))]))[:n]
    C = S @ X
    w, v = np.linalg.eigh(0.5 * (C + C.T))
    return {
        "joint": node,
        "joint_compliance": C.tolist(),
        "joint_soft_stiffness": float(1.0 / w[-1]),
        "joint_soft_direction": v[:, -1].tolist(),
    }
