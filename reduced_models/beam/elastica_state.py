"""One exact elastica state (``Equilibrium``: the pendulum orbit of a clamped beam), its
shape sampled on demand (``SampledShape``) and where its closed-form evaluation stops being
trustworthy (``conditioning_issue``).  ``reduced_models.beam.elastica`` solves for these states.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from reduced_models.beam.elastica_flow import max_abs_p, orbit, pendulum
from reduced_models.beam.single_beam import Cantilever

N_SHAPE = 41


@dataclass(frozen=True)
class Equilibrium:
    """One exact elastica state of a clamped beam (beam frame: root at 0, tangent +x).

    ``u_start, p_start`` are the pendulum state u = theta - phi + pi, u' = kappa at the root,
    or, when ``reverse``, at the tip with the arc length running backwards (follower loads).
    ``phi`` is the force direction (rad), ``lam = sqrt(P/EI)`` (1/length), ``m1`` the exact
    complementary elliptic parameter when the solver knows it (closed form), else None.
    """

    L: float
    lam: float
    phi: float
    u_start: float
    p_start: float
    reverse: bool = False
    m1: float | None = None

    def sample(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """theta, kappa, x, y at arc lengths s (shape (n,) each, s[-1] = L) and int kappa^2 ds."""
        s = np.asarray(s, dtype=float)
        if self.reverse:
            sb = np.append(self.L - s, self.L)
            u, p, A, B, U2 = pendulum(self.u_start, self.p_start, self.lam, sb, self.m1)
            th, kap = u[:-1] - u[-1], -p[:-1]
            A, B, U2 = A[-1] - A[:-1], B[-1] - B[:-1], U2[-1]
        else:
            u, p, A, B, U2 = pendulum(self.u_start, self.p_start, self.lam, s, self.m1)
            th, kap, U2 = u - self.u_start, p, U2[-1]
        c, d = math.cos(self.phi), math.sin(self.phi)
        # dr/ds = -cos u e_F - sin u e_perp with e_F = (c, d), e_perp = (-d, c)
        return th, kap, -A * c + B * d, -A * d - B * c, float(U2)

    def ends(self) -> tuple[float, float, float, float, float, float]:
        """theta(L), kappa(0), kappa(L), x(L), y(L) and int kappa^2 ds (beam frame).

        Forward orbits take the scalar flow at L (a fifth of the cost of sampling the shape).
        """
        if self.reverse:
            th, kap, x, y, U2 = self.sample(np.array([0.0, self.L]))
            return float(th[-1]), float(kap[0]), float(kap[-1]), float(x[-1]), float(y[-1]), U2
        u, p, A, B, U2 = pendulum(self.u_start, self.p_start, self.lam, float(self.L), self.m1)
        c, d = math.cos(self.phi), math.sin(self.phi)
        th, x, y = float(u - self.u_start), float(-A * c + B * d), float(-A * d - B * c)
        return th, float(self.p_start), float(p), x, y, float(U2)

    def tip(self) -> tuple[float, float, float]:
        """Tip (x, y, theta) in the beam frame."""
        if self.reverse:
            th, _, x, y, _ = self.sample(np.array([self.L]))
            return float(x[0]), float(y[0]), float(th[0])
        u, _, A, B, _ = pendulum(self.u_start, self.p_start, self.lam, float(self.L), self.m1)
        c, d = math.cos(self.phi), math.sin(self.phi)
        return float(-A * c + B * d), float(-A * d - B * c), float(u - self.u_start)

    def root_curvature(self) -> float:
        """kappa(0) (1/length)."""
        if not self.reverse:
            return self.p_start
        return float(-pendulum(self.u_start, self.p_start, self.lam, float(self.L), self.m1)[1])

    def max_abs_curvature(self, p_far: float) -> float:
        """Exact max |kappa| over the beam; ``p_far`` = |kappa| at the far end of the span."""
        return max_abs_p(self.u_start, self.p_start, self.lam, self.L, p_far, self.m1)


class SampledShape(Mapping):
    """``Step.shapes`` of one elastica state: member -> (N_SHAPE, 2) deformed centre line
    (global frame), sampled on first access (a solve whose caller reads only the tip pays
    nothing for it; picklable: it holds the beam and the state, no closure)."""

    def __init__(self, beam: Cantilever, eq: Equilibrium) -> None:
        self._beam, self._eq, self._xy = beam, eq, None

    def __getitem__(self, member: str) -> np.ndarray:
        if member != self._beam.member:
            raise KeyError(member)
        if self._xy is None:
            _, _, x, y, _ = self._eq.sample(np.linspace(0.0, self._beam.L, N_SHAPE))
            self._xy = self._beam.rotate_to_global(np.column_stack([x, y]))
        return self._xy

    def __iter__(self) -> Iterator[str]:
        return iter((self._beam.member,))

    def __len__(self) -> int:
        return 1


LAM_L_MAX = 12.0  # validated range of lam L = sqrt(P L^2/EI) for near-separatrix orbits


def conditioning_issue(eq: Equilibrium) -> str | None:
    """Why the closed-form evaluation of ``eq`` cannot be trusted to ~1e-9, or None.

    Orbits hugging the pendulum separatrix (1 - m < 1e-12: a beam nearly aligned with a large
    tensile force over most of its length) lose ~3e-15 exp(lam L) (absolute, in units of L;
    measured against solve_bvp and linear theory) near the saddle, because cn(w) ~ sech(w)
    comes out of cos(am(w)); beyond lam L = 12 that exceeds 1e-9.
    """
    if eq.lam * eq.L <= LAM_L_MAX:
        return None
    m1 = orbit(eq.u_start, eq.p_start, eq.lam, eq.m1).m1
    if m1 >= 1e-12:
        return None
    return (
        f"sqrt(P L^2/EI) = {eq.lam * eq.L:.3g} > {LAM_L_MAX:g} on an orbit within "
        f"{m1:.1e} of the pendulum separatrix (strong tension): the elliptic evaluation "
        "loses digits there, outside the validated range"
    )
