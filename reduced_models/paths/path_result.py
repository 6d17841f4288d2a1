"""``PathResult``: what the continuation engine (``engine.minimize_path``) returns.

Its own module, free of scipy, so that models solved on plain floats import no sparse or
LAPACK layer (``flexbench solve`` of a small PRB model starts in a fraction of a second).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PathResult:
    """What ``minimize_path`` found.

    Attributes
    ----------
    factors : (m,) reported load factors reached (a prefix of the requested ones).
    states : (m, n) converged unknowns at those factors.
    iterations : (m,) Newton iterations spent reaching each reported factor (all substeps and
        failed attempts included).
    cuts : (m,) step halvings needed to reach each reported factor.
    residuals : (m,) final ``max |g|`` at each reported state (free unknowns only).
    stable : list of m stability flags (True/False/None).
    ok : True if every requested factor was reached.
    reason : '' if ok, else why the path stopped.
    """

    factors: np.ndarray
    states: np.ndarray
    iterations: np.ndarray
    cuts: np.ndarray
    residuals: np.ndarray
    stable: list
    ok: bool
    reason: str


def limit_note(ratio: float, lam: float) -> str:
    """Why load control stopped, from ``ratio`` = smallest |eigenvalue| of the tangent at the
    last converged state over that of the unloaded state: below 1 % the model's own limit
    point (a fold of its equilibrium path), otherwise an unexplained loss of equilibrium."""
    if ratio < 1e-2:
        return (
            f"the model's own limit point at factor ~{lam:.6g} (its tangent is singular "
            f"there: smallest |eigenvalue| {ratio:.1e} of the unloaded one); load control "
            "cannot pass it and this model has no equilibrium just beyond on this branch"
        )
    if not np.isfinite(ratio):
        return "limit point or loss of equilibrium?"
    return f"no limit point of the model found (tangent ratio {ratio:.1e}): loss of equilibrium?"
