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
There is no Python loop over elements.

Two layouts: the public ``forces`` / ``local_state`` take and return
element-major arrays ((ne, 6)); the hot-loop kernel ``kernel_forces`` /
``kernel_tangent`` works *entry-major* ((6, ne) displacements and forces, (36, ne) tangents:
one contiguous row per entry), which the band scatter (``scatter.BandScatter``) consumes
directly.  The tangent is written in closed form from 11 distinct rows (``_K_SYMBOLIC``), so no
6x6 products are formed; at tens of elements the cost is the number of numpy calls, which the
kernel keeps to a few dozen.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from types import SimpleNamespace

import numpy as np
import skfem
from skfem.helpers import d, dd

TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Map angles (rad) to (-pi, pi]."""
    return a - TWO_PI * np.rint(a / TWO_PI)  # rint: np.round's result without its wrapper


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

    @cached_property
    def packed(self) -> SimpleNamespace:
        """Contiguous (ne,) copies of every constant the kernel reads (one column each), so
        the hot loop works on unit-stride vectors: ``X, Y, L0, ka, k11, k12, k21, k22, kb_all``
        and the scaled column/row sums ``c1, c2`` (``sum_i kb_ij``), ``r1, r2``
        (``sum_j kb_ij``), the same four stacked as ``cr`` (4, ne), ``kpp`` (4, ne) the kb
        entries (11, 12, 21, 22), ``kbase`` the work array of ``kernel_tangent`` (its last
        four rows are ``kpp``), ``X21T`` (2, ne) and ``X21T2 = 2 X21T``, the kb columns
        ``kcol1 = (k11, k21)``, ``kcol2 = (k12, k22)``; ``sym`` is True when every kb is
        symmetric (then c = r)."""
        kb_all, kb_col, kb_row = self.kb_sums
        kpp = self.kb.reshape(-1, 4).T.copy()
        c = np.ascontiguousarray
        return SimpleNamespace(
            X=c(self.X21[:, 0]),
            Y=c(self.X21[:, 1]),
            L0=c(self.L0),
            ka=c(self.ka),
            k11=c(self.kb[:, 0, 0]),
            k12=c(self.kb[:, 0, 1]),
            k21=c(self.kb[:, 1, 0]),
            k22=c(self.kb[:, 1, 1]),
            kb_all=c(kb_all),
            c1=c(kb_col[:, 0]),
            c2=c(kb_col[:, 1]),
            r1=c(kb_row[:, 0]),
            r2=c(kb_row[:, 1]),
            sym=bool(np.array_equal(self.kb[:, 0, 1], self.kb[:, 1, 0])),
            cr=np.stack([kb_col[:, 0], kb_col[:, 1], kb_row[:, 0], kb_row[:, 1]]),
            X21T=np.ascontiguousarray(self.X21.T),
            X21T2=np.ascontiguousarray(2.0 * self.X21.T),
            kcol1=np.ascontiguousarray(self.kb[:, :, 0].T),  # (k11, k21)
            kcol2=np.ascontiguousarray(self.kb[:, :, 1].T),  # (k12, k22)
            kpp=kpp,
            kbase=np.concatenate([np.zeros((2 * len(_K_BASE), self.L0.shape[0])), kpp]),
        )


@dataclass(slots=True)
class LocalState:
    """Local (chord-frame) quantities of all elements, each (ne,).  Not frozen: a frozen
    dataclass sets its ten fields through ``object.__setattr__``, a measurable part of a
    16-element residual evaluation; nothing writes to it."""

    ln: np.ndarray
    c: np.ndarray
    s: np.ndarray
    ul: np.ndarray
    th1: np.ndarray
    th2: np.ndarray
    N: np.ndarray
    M1: np.ndarray
    M2: np.ndarray
    cs: np.ndarray | None = None  # (2, ne) = (c, s) stacked, when the kernel has it


def _chord(p: SimpleNamespace, dT: np.ndarray, f: np.ndarray) -> LocalState:
    """Chord-frame state from entry-major element displacements ``dT`` (6, ne); the end
    moments are written into rows 2 and 5 of ``f`` (6, ne), where the element force vector
    holds them.

    Pairs of quantities are computed as (2, ne) arrays (x and y, the two end rotations and
    moments): at a few dozen elements the cost is the number of numpy calls, not their size.
    """
    d21 = dT[3:5] - dT[0:2]  # (2, ne) chord displacement
    x21 = p.X21T + d21
    ln = np.hypot(x21[0], x21[1])
    cs = x21 / ln
    # rigid chord rotation from the undeformed chord (atan2 of cross and dot products)
    xy = p.X21T * x21
    yx = p.X21T * x21[::-1]
    alpha = np.arctan2(yx[0] - yx[1], xy[0] + xy[1])
    # ln - L0 without cancellation: (ln^2 - L0^2) / (ln + L0), ln^2 - L0^2 = (2 X21 + d21).d21
    t = (p.X21T2 + d21) * d21
    ul = (t[0] + t[1]) / (ln + p.L0)
    th = wrap_angle(dT[2::3] - alpha)  # rows 2 and 5: the two end rotations
    M = f[2::3]  # (M1, M2) = kb @ (th1, th2)
    np.multiply(p.kcol1, th[0], out=M)
    M += p.kcol2 * th[1]
    return LocalState(ln, cs[0], cs[1], ul, th[0], th[1], p.ka * ul, M[0], M[1], cs)


def local_state(beams: BeamSet, de: np.ndarray) -> LocalState:
    """Chord-frame deformation and forces.

    Parameters
    ----------
    beams : element constants.
    de : (ne, 6) element displacements ``[u1, v1, th1, u2, v2, th2]`` (length, rad).
    """
    return _chord(beams.packed, np.ascontiguousarray(de.T), np.empty((6, de.shape[0])))


def kernel_forces(beams: BeamSet, dT: np.ndarray) -> tuple[np.ndarray, LocalState]:
    """Internal element forces in entry-major layout, (6, ne), and the local state.

    ``dT`` (6, ne) holds the element displacements ``[u1, v1, th1, u2, v2, th2]`` row by row
    (the layout the assembly gathers, so every operation runs on contiguous (ne,) rows).
    ``f = r N - z (M1 + M2) / ln + M1 e_3 + M2 e_6``: with ``q = (M1 + M2) / ln`` the
    translational entries are ``fx1 = -c N - s q``, ``fy1 = c q - s N`` and their negatives
    at node 2.
    """
    f = np.empty(dT.shape)
    st = _chord(beams.packed, dT, f)  # rows 2 and 5 of f: M1, M2
    cs = st.cs
    q = (st.M1 + st.M2) / st.ln
    # (fx1, fy1) = -(c, s) N + (-s, c) q
    np.multiply(cs[::-1], q, out=f[0:2])
    f[0] *= -1.0
    f[0:2] -= cs * st.N
    np.negative(f[0:2], out=f[3:5])
    return f, st


# Symbolic element tangent (Battini & Pacoste 2002, expanded): rows/columns are the element
# DOFs (u1, v1, th1, u2, v2, th2); "-x" is the negative of x.  ``c1s`` = s * sum_i kb_i1 / ln,
# ``r1c`` = c * sum_j kb_1j / ln, ... (see ``kernel_tangent``).
_K_SYMBOLIC = (
    ("T00", "T01", "-c1s", "-T00", "-T01", "-c2s"),
    ("T01", "T11", "c1c", "-T01", "-T11", "c2c"),
    ("-r1s", "r1c", "k11", "r1s", "-r1c", "k12"),
    ("-T00", "-T01", "c1s", "T00", "T01", "c2s"),
    ("-T01", "-T11", "-c1c", "T01", "T11", "-c2c"),
    ("-r2s", "r2c", "k21", "r2s", "-r2c", "k22"),
)
# rows of the base array computed by ``kernel_tangent`` (pairs are filled by one operation)
_K_BASE = ("T00", "T11", "T01", "c1s", "c2s", "c1c", "c2c", "r1s", "r2s", "r1c", "r2c")


def _k_rows(sym: bool) -> np.ndarray:
    """Row of ``[base; -base; kb entries]`` feeding each of the 36 tangent entries."""
    pos = {name: i for i, name in enumerate(_K_BASE)}
    if sym:  # kb symmetric: row sums equal column sums
        for k in ("1s", "2s", "1c", "2c"):
            pos["r" + k] = pos["c" + k]
    nb = len(_K_BASE)
    pos.update({"k11": 2 * nb, "k12": 2 * nb + 1, "k21": 2 * nb + 2, "k22": 2 * nb + 3})
    rows = []
    for name in (x for row in _K_SYMBOLIC for x in row):
        rows.append(pos[name[1:]] + nb if name.startswith("-") else pos[name])
    return np.array(rows)


_K_ROWS = {True: _k_rows(True), False: _k_rows(False)}


def kernel_tangent(beams: BeamSet, st: LocalState) -> np.ndarray:
    """Consistent tangents of all elements in entry-major layout, (36, ne): row ``6 a + b``
    holds ``K[a, b]`` of every element (closed form, no 6x6 products).

    With ``e = (c, s)``, ``n = (s, -c)`` the translational blocks are ``[[T, -T], [-T, T]]``,
    ``T = ka e e^T + (sum(kb)/ln^2 + N/ln) n n^T - (M1 + M2)/ln^2 (e n^T + n e^T)``; the
    rotation couplings are ``K[t, p_j] = -(kb_1j + kb_2j)/ln [n, -n]`` and
    ``K[p_i, t] = -(kb_i1 + kb_i2)/ln [n, -n]^T``; ``K_pp = kb`` (Battini & Pacoste 2002).
    The 11 distinct (ne,) rows are computed once, negated once and gathered into the 36
    entries with one ``take`` (layout ``_K_SYMBOLIC``).
    """
    p = beams.packed
    c, s = st.c, st.s
    cs2 = st.cs if st.cs is not None else np.stack([c, s])  # (2, ne): (c, s)
    ne = c.shape[0]
    inv_l = 1.0 / st.ln
    sq = cs2 * cs2  # (c^2, s^2)
    csx = c * s
    czz = (p.kb_all * inv_l + st.N) * inv_l
    g = (st.M1 + st.M2) * (inv_l * inv_l)
    g2cs = 2.0 * g * csx
    nb = len(_K_BASE)
    base = p.kbase  # kept between calls (the result below is a new array): K_pp rows preset
    if base.shape[1] != ne:  # pragma: no cover - a BeamSet has one element count
        raise ValueError("kernel_tangent: local state of another element set")
    # (T00, T11) = ka (c^2, s^2) + czz (s^2, c^2) -+ 2 g c s
    np.multiply(p.ka, sq, out=base[0:2])
    base[0:2] += czz * sq[::-1]
    base[0] -= g2cs
    base[1] += g2cs
    base[2] = (p.ka - czz) * csx + g * (sq[0] - sq[1])
    cl = p.cr * inv_l  # (4, ne): column sums 1, 2 and row sums 1, 2 of kb, over ln
    k = 4 if not p.sym else 2
    sc = base[3 : 3 + 2 * k].reshape(2, k, ne)  # [s * cl[:k], c * cl[:k]] (rows c1s c2s ...)
    np.multiply(cl[:k], s, out=sc[0])
    np.multiply(cl[:k], c, out=sc[1])
    if not p.sym:  # base rows 3..10 are c1s c2s r1s r2s c1c c2c r1c r2c: reorder to _K_BASE
        base[3:11] = base[[3, 4, 7, 8, 5, 6, 9, 10]]
    np.negative(base[:nb], out=base[nb : 2 * nb])
    return base[_K_ROWS[p.sym]]


def forces(beams: BeamSet, de: np.ndarray) -> tuple[np.ndarray, LocalState]:
    """Global internal element forces, (ne, 6), and the local state."""
    fT, st = kernel_forces(beams, np.ascontiguousarray(de.T))
    return fT.T.copy(), st


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
    s = np.asarray(s, dtype=float)
    # the 2-D-points pitfall, checked on the coordinates (``Mesh.is_valid`` cost a tenth of
    # building a 16-element system)
    if s.ndim != 1 or s.size < 2 or not bool(np.all(s[1:] > s[:-1])):  # pragma: no cover
        raise ValueError("invalid MeshLine1 (arc-length coordinates must be 1-D, increasing)")
    return skfem.MeshLine1.init_tensor(s)


_BASES: dict[bytes, tuple[skfem.CellBasis, skfem.CellBasis]] = {}
BASES_KEPT = 32  # meshes whose bases are kept (a run solves each case's few meshes many times)


# element matrices per (mesh, material): assembling the scikit-fem forms cost as much as
# building the bases, and every solve of a case assembles the same ones again; read-only so a
# caller cannot change a kept copy
_MATS: dict[tuple, tuple[np.ndarray, ...]] = {}


def _mesh_key(mesh: skfem.MeshLine1) -> bytes:
    return mesh.p.tobytes() + mesh.t.tobytes()


def _keep(key: tuple, arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    if len(_MATS) >= 4 * BASES_KEPT:
        del _MATS[next(iter(_MATS))]  # the oldest
    for a in arrays:
        a.setflags(write=False)
    _MATS[key] = arrays
    return arrays


def _bases(mesh: skfem.MeshLine1) -> tuple[skfem.CellBasis, skfem.CellBasis]:
    """Hermite and P1 bases of a line mesh, built once per mesh geometry: building a
    ``CellBasis`` (element maps, quadrature, shape functions) cost a fifth of a 16-element
    solve, and every solve of a case meshes the same arc lengths again."""
    key = _mesh_key(mesh)
    got = _BASES.get(key)
    if got is None:
        if len(_BASES) >= BASES_KEPT:
            del _BASES[next(iter(_BASES))]  # the oldest
        got = _BASES[key] = (
            skfem.Basis(mesh, skfem.ElementLineHermite()),
            skfem.Basis(mesh, skfem.ElementLineP1()),
        )
    return got


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
    key = ("k", _mesh_key(mesh), float(EA), float(EI))
    got = _MATS.get(key)
    if got is None:
        hb, pb = _bases(mesh)
        Kb = _bending.coo_data(hb, EI=EI).tolocal()  # (ne, 4, 4)
        Ka = _axial.coo_data(pb, EA=EA).tolocal()  # (ne, 2, 2)
        kb = Kb[:, [1, 3]][:, :, [1, 3]]
        L0 = mesh.p[0, mesh.t[1]] - mesh.p[0, mesh.t[0]]
        got = _keep(key, (Ka[:, 0, 0].copy(), np.ascontiguousarray(kb), L0))
    return got


def local_mass(mesh: skfem.MeshLine1, rho_line: float) -> np.ndarray:
    """Consistent P1 element mass matrices ``int rho_line N_i N_j ds``, (ne, 2, 2).

    Used for translations (``rho_line = rho A``) and rotary inertia (``rho_line = rho I``).
    Linear interpolation keeps the mass matrix constant and frame-invariant under large
    rotations (Le, Battini & Hjiaj 2011, Comput. Mech. 48:153-161).
    """
    key = ("m", _mesh_key(mesh), float(rho_line))
    got = _MATS.get(key)
    if got is None:
        got = _keep(key, (_mass.coo_data(_bases(mesh)[1], rho=rho_line).tolocal(),))
    return got[0]
