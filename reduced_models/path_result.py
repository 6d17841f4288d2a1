"""``PathResult``: what a load continuation returns (``continuation``, ``small_path``).

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
