"""``linear-N``: a beam as N chained linear Euler-Bernoulli segments (DAS-2D Linear Model).

Each segment of length h stores the small-deflection energy of a cantilever in the frame of
the previous segment's tip (seed 000, "Linear Model"):

    V = 2 EI / h^3 (3 dy^2 + h^2 a^2 - 3 h dy a)  =  EI/h * 1/2 [y a] G [y a]^T,
    G = [[12, -6], [-6, 4]],  y = dy/h,

with no axial strain and no axial shortening (the local tip stays at x = h).  Large
rotations of the whole beam come from the chaining: each segment rotates with its
predecessor's tip.  Deformed segment shape: cubic Hermite; curvature (per 1/h)
y (6 - 12 s) + a (6 s - 2), the seed's bending stress sigma = E t kappa / 2.

Kinematics, axial multiplier and solver: ``reduced_models.beam.chain``.
"""

from __future__ import annotations

import numpy as np

from reduced_models.base import ModelCard
from reduced_models.beam.chain import SegmentLaw
from reduced_models.beam.chain_model import ChainModel

G_LINEAR = np.array([[12.0, -6.0], [-6.0, 4.0]])
LINEAR_LAW = SegmentLaw(G=G_LINEAR, P=np.zeros((2, 2)), Q=np.zeros((2, 2)))


def hermite_shape(y: np.ndarray, a: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Hermite deflection and curvature of clamped segments.

    Parameters
    ----------
    y, a : (N,) segment-normalised tip deflection and rotation.
    sigma : (s,) positions along the segment in [0, 1].

    Returns
    -------
    v, kappa : (N, s) deflection (units h) and curvature (units 1/h).
    """
    s = sigma[None, :]
    y, a = y[:, None], a[:, None]
    v = y * (3 * s**2 - 2 * s**3) + a * (s**3 - s**2)
    kappa = y * (6 - 12 * s) + a * (6 * s - 2)
    return v, kappa


class LinearChain(ChainModel):
    """``linear-N``: N chained linear Euler-Bernoulli segments (N = 1: linear beam theory).

    Parameters
    ----------
    n : number of segments.
    shape_points : shape samples per segment.
    """

    law = LINEAR_LAW
    family = "linear"
    extensible = False
    _card = ModelCard(
        name="linear-N",
        family="linear",
        summary="{N} chained linear Euler-Bernoulli segments, each in its predecessor's tip frame",
        assumptions=(
            "segment energy 2EI/h^3 (3 dy^2 + h^2 a^2 - 3 h dy a): small deflection per segment",
            "no axial strain and no axial shortening of a segment (local tip at x = h)",
            "large overall rotation from chaining segment frames",
            "dead tip loads (follower force: residual Newton with unsymmetric tangent)",
            "tip force and moment only; a single clamped beam",
        ),
        validity=(
            "N = 1: linear beam theory (tip deflection ~ 10 % of L at most); N > 1: converges "
            "to the inextensible elastica with error O(1/N^2) (segment shortening neglected)"
        ),
        references=(
            "DAS-2D seed 000_265bc60728766176.txt, 'Linear Model' and 'Multiple Segment Models'",
            "Timoshenko & Gere, Theory of Elastic Stability, 2nd ed. (1961), cantilever stiffness",
        ),
    )

    def shape(
        self,
        ux: np.ndarray,
        y: np.ndarray,
        a: np.ndarray,
        p: np.ndarray,
        k: float,
        sigma: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local segment shapes (xl, yl, kappa), each (N, s), segment units."""
        v, kappa = hermite_shape(y, a, sigma)
        xl = np.broadcast_to(sigma, v.shape)
        return xl, v, kappa
