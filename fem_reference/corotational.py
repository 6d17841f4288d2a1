"""Batched 2-D corotational Euler-Bernoulli beam kernel and scikit-fem element matrices.

The element-independent corotational formulation (Crisfield 1991, Vol. 1, Ch. 7; Battini &
Pacoste 2002, CMAME 191:1755-1789, doi 10.1016/S0045-7825(01)00352-8) splits the motion of a
two-node element into the rigid motion of its chord and a small local deformation measured in
the rotating chord frame:

* chord: ``x21 = X21 + d2 - d1``, length ``ln``, rigid rotation ``alpha`` of the chord;
* local unknowns: stretch ``u_l = ln - L0`` and end rotations ``th_i_l = th_i - alpha`` (wrapped
  to (-pi, pi], so nodal rotations may grow without bound, e.g. a roll-up to 2 pi);
* local linear law: ``N = ka u_l`` and ``[M1, M2] = kb [th1_l, th2_l]`` with the axial (P1) and
  Hermite bending stiffnesses taken from scikit-fem forms (``local_matrices``).

Global internal force ``f = B^T [N, M1, M2]`` and the consistent tangent
``K = B^T K_l B + z z^T N / ln + (r z^T + z r^T)(M1 + M2) / ln^2`` with
``r = [-c, -s, 0, c, s, 0]``, ``z = [s, -c, 0, -s, c, 0]`` (Battini & Pacoste 2002, Eq. 25-30).
Every array carries the element index first; there is no Python loop over elements.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import skfem
from skfem.helpers import d, dd

TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Map angles (rad) to (-pi, pi]."""
    return a - TWO_PI * np.round(a / TWO_PI)


@dataclass(frozen=True)
class BeamSet:
    """Constant data of ``ne`` two-node beam elements.

    Attributes
    ----------
    X21 : (ne, 2) undeformed chord vectors (length).
    L0 : (ne,) undeformed lengths.
    ka : (ne,) axial stiffness EA / L0 (force / length).
    kb : (ne, 2, 2) local bending stiffness (moment / rad), ``EI / L0 [[4, 2], [2, 4]]`` for a
        prismatic element.
    EI : (ne,) flexural rigidity (for curvature recovery).
    """

    X21: np.ndarray
    L0: np.ndarray
    ka: np.ndarray
    kb: np.ndarray
    EI: np.ndarray

    @cached_property
    def kb_sums(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Constant reductions of kb used by the tangent: total (ne,), column sums (ne, 2),
        row sums (ne, 2)."""
        return self.kb.sum(axis=(1, 2)), self.kb.sum(axis=1), self.kb.sum(axis=2)


@dataclass(frozen=True)
class LocalState:
    """Local (chord-frame) quantities of all elements, each (ne,)."""

    ln: np.ndarray
    c: np.ndarray
    s: np.ndarray
    ul: np.ndarray
    th1: np.ndarray
    th2: np.ndarray
    N: np.ndarray
    M1: np.ndarray
    M2: np.ndarray


def local_state(beams: BeamSet, de: np.ndarray) -> LocalState:
    """Chord-frame deformation and forces.

    Parameters
    ----------
    beams : element constants.
    de : (ne, 6) element displacements ``[u1, v1, th1, u2, v2, th2]`` (length, rad).
    """
    d21 = de[:, 3:5] - de[:, 0:2]
    x21 = beams.X21 + d21
    ln = np.hypot(x21[:, 0], x21[:, 1])
    c = x21[:, 0] / ln
    s = x21[:, 1] / ln
    X, Y = beams.X21[:, 0], beams.X21[:, 1]
    # rigid chord rotation from the undeformed chord (atan2 of cross and dot products)
    alpha = np.arctan2(X * x21[:, 1] - Y * x21[:, 0], X * x21[:, 0] + Y * x21[:, 1])
    # ln - L0 without cancellation: (ln^2 - L0^2) / (ln + L0), ln^2 - L0^2 = 2 X21.d21 + |d21|^2
    ul = (2.0 * (X * d21[:, 0] + Y * d21[:, 1]) + np.einsum("ij,ij->i", d21, d21)) / (ln + beams.L0)
    th1 = wrap_angle(de[:, 2] - alpha)
    th2 = wrap_angle(de[:, 5] - alpha)
    N = beams.ka * ul
    M1 = beams.kb[:, 0, 0] * th1 + beams.kb[:, 0, 1] * th2
    M2 = beams.kb[:, 1, 0] * th1 + beams.kb[:, 1, 1] * th2
    return LocalState(ln, c, s, ul, th1, th2, N, M1, M2)


def _rz(st: LocalState) -> tuple[np.ndarray, np.ndarray]:
    ne = st.c.shape[0]
    r = np.zeros((ne, 6))
    z = np.zeros((ne, 6))
    r[:, 0], r[:, 1], r[:, 3], r[:, 4] = -st.c, -st.s, st.c, st.s
    z[:, 0], z[:, 1], z[:, 3], z[:, 4] = st.s, -st.c, -st.s, st.c
    return r, z


def forces(beams: BeamSet, de: np.ndarray) -> tuple[np.ndarray, LocalState]:
    """Global internal element forces, (ne, 6), and the local state."""
    st = local_state(beams, de)
    r, z = _rz(st)
    f = r * st.N[:, None] - z * ((st.M1 + st.M2) / st.ln)[:, None]
    f[:, 2] += st.M1
    f[:, 5] += st.M2
    return f, st


def forces_and_tangent(beams: BeamSet, de: np.ndarray) -> tuple[np.ndarray, np.ndarray, LocalState]:
    """Internal forces (ne, 6), consistent tangents (ne, 6, 6) and the local state.

    ``B^T K_l B`` with ``b_i = e_{p_i} - z / ln`` (p = rotation slots 2, 5) is expanded so that
    only three 4x4 outer products on the translational slots are formed:
    ``K_tt = ka r r^T + (sum(kb)/ln^2 + N/ln) z z^T + (M1 + M2)/ln^2 (r z^T + z r^T)``,
    ``K_t,p_j = -(kb_1j + kb_2j)/ln z``, ``K_p_i,t = -(kb_i1 + kb_i2)/ln z^T``, ``K_pp = kb``.
    """
    st = local_state(beams, de)
    ne = st.c.shape[0]
    inv_l = 1.0 / st.ln
    msum = st.M1 + st.M2
    c, s = st.c, st.s
    r4 = np.stack([-c, -s, c, s], axis=1)
    z4 = np.stack([s, -c, -s, c], axis=1)
    f = np.empty((ne, 6))
    ft = r4 * st.N[:, None] - z4 * (msum * inv_l)[:, None]
    f[:, 0:2], f[:, 3:5] = ft[:, 0:2], ft[:, 2:4]
    f[:, 2] = st.M1
    f[:, 5] = st.M2
    kb = beams.kb
    kb_all, kb_col, kb_row = beams.kb_sums
    czz = (kb_all * inv_l + st.N) * inv_l
    crz = msum * inv_l * inv_l
    # translational 4x4 block: ka r r^T + czz z z^T + crz (r z^T + z r^T)
    a = r4[:, :, None] * (beams.ka[:, None] * r4 + crz[:, None] * z4)[:, None, :]
    Ktt = a + a.transpose(0, 2, 1)
    Ktt -= r4[:, :, None] * (beams.ka[:, None] * r4)[:, None, :]
    Ktt += z4[:, :, None] * (czz[:, None] * z4)[:, None, :]
    K = np.empty((ne, 6, 6))
    K[:, 0:2, 0:2] = Ktt[:, 0:2, 0:2]
    K[:, 0:2, 3:5] = Ktt[:, 0:2, 2:4]
    K[:, 3:5, 0:2] = Ktt[:, 2:4, 0:2]
    K[:, 3:5, 3:5] = Ktt[:, 2:4, 2:4]
    col = -(kb_col * inv_l[:, None])  # (ne, 2): -sum_i kb_ij / ln
    row = -(kb_row * inv_l[:, None])  # (ne, 2): -sum_j kb_ij / ln
    for j, p in enumerate((2, 5)):
        zc = z4 * col[:, j, None]
        zr = z4 * row[:, j, None]
        K[:, 0:2, p], K[:, 3:5, p] = zc[:, 0:2], zc[:, 2:4]
        K[:, p, 0:2], K[:, p, 3:5] = zr[:, 0:2], zr[:, 2:4]
    K[:, 2, 2], K[:, 2, 5] = kb[:, 0, 0], kb[:, 0, 1]
    K[:, 5, 2], K[:, 5, 5] = kb[:, 1, 0], kb[:, 1, 1]
    return f, K, st


def energy(beams: BeamSet, st: LocalState) -> np.ndarray:
    """Strain energy per element, (ne,)."""
    return 0.5 * (st.N * st.ul + st.M1 * st.th1 + st.M2 * st.th2)


def end_curvatures(beams: BeamSet, st: LocalState) -> np.ndarray:
    """Bending curvature magnitudes at both element ends, (ne, 2) (1/length).

    The internal moment of the linear local element is ``-M1`` at end 1 and ``M2`` at end 2.
    """
    return np.abs(np.stack([st.M1, st.M2], axis=1)) / beams.EI[:, None]


# -- scikit-fem element matrices ---------------------------------------------------------------


@skfem.BilinearForm
def _bending(u, v, w):  # noqa: ANN001, ANN202 - scikit-fem form signature
    return w["EI"] * dd(u)[0, 0] * dd(v)[0, 0]


@skfem.BilinearForm
def _axial(u, v, w):  # noqa: ANN001, ANN202
    return w["EA"] * d(u)[0] * d(v)[0]


@skfem.BilinearForm
def _mass(u, v, w):  # noqa: ANN001, ANN202
    return w["rho"] * u * v


def line_mesh(s: np.ndarray) -> skfem.MeshLine1:
    """A ``MeshLine1`` on sorted arc-length coordinates ``s`` (n,) (1-D coordinates only)."""
    mesh = skfem.MeshLine1.init_tensor(np.asarray(s, dtype=float))
    if not mesh.is_valid():  # pragma: no cover - guards the 2-D-points pitfall
        raise ValueError("invalid MeshLine1 (arc-length coordinates must be 1-D, increasing)")
    return mesh


def local_matrices(
    mesh: skfem.MeshLine1, EA: float, EI: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local linear stiffnesses of every element of a prismatic member from scikit-fem forms.

    Bending: cubic Hermite (``ElementLineHermite``) with ``EI w'' v''``; in the chord frame the
    end deflections vanish, so the rotation rows/columns (local DOFs 1 and 3) give ``kb``.
    Axial: P1 with ``EA u' v'``; ``ka = K[0, 0]``.

    Returns
    -------
    ka : (ne,) axial stiffness; kb : (ne, 2, 2) bending stiffness; L0 : (ne,) lengths.
    """
    hb = skfem.Basis(mesh, skfem.ElementLineHermite())
    pb = skfem.Basis(mesh, skfem.ElementLineP1())
    Kb = _bending.coo_data(hb, EI=EI).tolocal()  # (ne, 4, 4)
    Ka = _axial.coo_data(pb, EA=EA).tolocal()  # (ne, 2, 2)
    kb = Kb[:, [1, 3]][:, :, [1, 3]]
    L0 = mesh.p[0, mesh.t[1]] - mesh.p[0, mesh.t[0]]
    return Ka[:, 0, 0].copy(), np.ascontiguousarray(kb), L0


def local_mass(mesh: skfem.MeshLine1, rho_line: float) -> np.ndarray:
    """Consistent P1 element mass matrices ``int rho_line N_i N_j ds``, (ne, 2, 2).

    Used for translations (``rho_line = rho A``) and rotary inertia (``rho_line = rho I``).
    Linear interpolation keeps the mass matrix constant and frame-invariant under large
    rotations (Le, Battini & Hjiaj 2011, Comput. Mech. 48:153-161).
    """
    pb = skfem.Basis(mesh, skfem.ElementLineP1())
    return _mass.coo_data(pb, rho=rho_line).tolocal()
