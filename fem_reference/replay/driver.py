"""Replay of ``energy`` analyses: the driver moved slowly as a prescribed motion.

The FE scene is built as for the static energy analysis (``assembly.build(...,
driver_load=True)``, scene loads held at ``factor_end``); ``DrivenSystem`` removes the driver
DOF and prescribes it from the replay's "load factor", which here *is* the driver coordinate
(driver units: length, or degrees for a rotation).  ``replay_system`` then ramps it smoothly
between report points and holds until settled, exactly as it ramps loads; at each settled
state the driving force/torque is the reaction in the driver DOF (the static FE's unknown
``lam``), condensed onto it so that the rigid links' stiff-element round-off cancels
(``DrivenSystem.reaction``), reported as ``driver.force`` / ``driver.torque``.  Probes kick
the system with the driver held, the same condition as the FE tangent test of the energy
analysis.

Deleting one row and column of a banded matrix keeps it within the band, so ``DrivenSystem``
offers the fast path of ``FEMSystem`` (``evaluate`` / ``tangent_band``): the replay's
generalised-alpha steps then run in LAPACK band storage with factorisation reuse
(``band.step_band``) instead of slicing a csr tangent and calling SuperLU per iteration.

The driver's work is not in the replay's energy books (it acts on the removed DOF), so the
energy-balance figure of ``extras["settle"]`` is NaN and snap-through jumps (judged from that
balance) are not assessed.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.banded import BandedLU
from fem_reference.replay.finish import note as finish_note
from fem_reference.replay.integrator import factor
from fem_reference.statics.driver_post import post_process
from reduced_models.base import Solution, Step

#: settling tolerance of driver replays (see ``solve_energy``)
SETTLE_TOL = 1e-11


class DrivenSystem:
    """A ``DiscreteSystem`` without the driver DOF, which follows the parameter ``lam``."""

    def __init__(self, full: object, key: str) -> None:
        self.full = full
        self.i, self.c, _ = full.driver_functional()
        self.key = key
        n = full.ndof
        self.keep = np.delete(np.arange(n), self.i)
        self.ndof = n - 1
        self.is_rotation = np.asarray(full.is_rotation)[self.keep]
        self.n_elements = full.n_elements
        self._M = full.mass().tocsr()[self.keep][:, self.keep]
        self._lam = 0.0
        bw = full.fast.scatter.bw
        self.bandwidth = full.bandwidth  # the deletion keeps the band (GenAlpha reads it)
        self._bw = bw
        self._gather = None if bw is None else _band_gather(n, bw, self.i)

    def evaluate(self, u: np.ndarray, lam: float) -> SimpleNamespace:
        """Residual without the driver DOF (``.r``) and the full system's evaluation (``.ev``)."""
        self._lam = lam
        ev = self.full.evaluate(self._d(u, lam), 0.0)
        return SimpleNamespace(r=ev.r[self.keep], ev=ev)

    def tangent_band(self, ev: SimpleNamespace) -> np.ndarray:
        """Tangent without the driver row and column in ``dgbtrf`` band storage (Fortran)."""
        return self._without_driver(self.full.tangent_band(ev.ev))

    def _without_driver(self, ab: np.ndarray) -> np.ndarray:
        """Band storage of the full tangent ``ab`` without the driver row and column."""
        idx, ok = self._gather
        ab = ab.ravel(order="F")[idx]
        ab[~ok] = 0.0
        return np.asfortranarray(ab)

    def tangent_csr(self, ev: SimpleNamespace) -> sp.csr_matrix:
        """Tangent without the driver row and column as csr."""
        return self.full.tangent_csr(ev.ev)[self.keep][:, self.keep]

    def _d(self, u: np.ndarray, lam: float) -> np.ndarray:
        d = np.empty(self.ndof + 1)
        d[self.keep] = u
        d[self.i] = lam / self.c
        return d

    def full_state(self, u: np.ndarray, lam: float) -> tuple[np.ndarray, float]:
        """State of the full system (driver DOF at ``lam``) and its load factor (0)."""
        return self._d(u, lam), 0.0

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        self._lam = lam
        return np.asarray(self.full.residual(self._d(u, lam), 0.0))[self.keep]

    def residual_and_tangent(self, u: np.ndarray, lam: float) -> tuple:
        self._lam = lam
        r, K = self.full.residual_and_tangent(self._d(u, lam), 0.0)
        K = K.tocsr()[self.keep][:, self.keep]
        return np.asarray(r)[self.keep], K

    def external(self, u: np.ndarray) -> np.ndarray:
        return np.zeros(self.ndof)  # the motion is prescribed: no lam-scaled load remains

    def mass(self) -> object:
        return self._M

    def strain_energy(self, u: np.ndarray) -> float:
        return float(self.full.strain_energy(self._d(u, self._lam)))

    outputs_need_factor = True  # the driver coordinate is not in u

    def outputs(self, u: np.ndarray, lam: float | None = None) -> dict[str, float]:
        return self.full.outputs(self._d(u, self._lam if lam is None else lam))

    def length_scale(self) -> float:
        return float(self.full.length_scale())

    def reaction(self, u: np.ndarray, lam: float) -> float:
        """Driving force/torque holding the equilibrium next to the state ``u`` (driver at
        ``lam``): the static energy analysis' ``lam``, condensed onto the driver DOF i.

        The driver-DOF residual r_i alone is the sum of element forces that include the rigid
        links' (stiff elements, ``EA_r`` ~ 1e6 x the scene's stiffness): a position error of
        one ulp in the free DOFs k -- a round-off any encoding of the scene makes
        differently -- stretches them by eps L and moves r_i by eps EA_r (1e-8 N, 2e-8 of
        the excursion, on DAS-2D Ex. 5), and the settled free residual r_k is that round-off
        too.  Condensed, the reaction is that of the state one Newton correction
        dq_k = K_kk^-1 (f e_k - r_k) away, which balances the free DOFs::

            f = (r_i - K_ik K_kk^-1 r_k) / (e_i - K_ik K_kk^-1 e_k)

        To first order it does not depend on an error dq_k in the state (K_ik dq_k cancels
        between the two terms), and the stiff elements' forces enter only through the
        virtual motion (1, -K_kk^-1 K_ki), which does not stretch them: the round-off is then
        that of the force itself.  A singular K_kk (the state is critical with the driver
        held) has no such correction: the residual r_i / e_i is returned.  Driver replays
        lock no booms, so the free DOFs carry no constraint forces.
        """
        d = self._d(u, lam)
        ev = self.full.evaluate(d, 0.0)
        r, e = np.asarray(ev.r), np.asarray(self.full.external(d))
        k, i = self.keep, self.i
        try:
            solve, Ki = self._condensation(ev)
        except RuntimeError:
            return float(r[i] / e[i])
        x = solve(np.column_stack([r[k], e[k]]))
        return float((r[i] - Ki[k] @ x[:, 0]) / (e[i] - Ki[k] @ x[:, 1]))

    def _condensation(self, ev: object) -> tuple:
        """(solve with K_kk, row i of K (ndof + 1,)) of the full tangent at evaluation ``ev``:
        LAPACK band storage where the system has it (the cost of a residual evaluation
        again, not of a sparse assembly), else csr and sparse LU.  Raises RuntimeError
        when K_kk is singular."""
        if self._gather is None:
            K = self.full.tangent_csr(ev)
            return factor(K[self.keep][:, self.keep]), K[self.i].toarray().ravel()
        ab, bw, i = self.full.tangent_band(ev), self._bw, self.i
        j = np.arange(max(i - bw, 0), min(i + bw + 1, self.ndof + 1))
        Ki = np.zeros(self.ndof + 1)
        Ki[j] = ab[2 * bw + i - j, j]  # A[i, j] sits at ab[2 bw + i - j, j]
        return BandedLU(self._without_driver(ab), bw).solve, Ki

    def step(self, u: np.ndarray, lam: float, iterations: int, stable: bool | None) -> Step:
        st = self.full.step(self._d(u, lam), 0.0, iterations, stable)
        out = dict(st.outputs)
        out[self.key] = self.reaction(u, lam)
        return replace(st, factor=float(lam), outputs=out)


def _band_gather(n: int, bw: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Where each entry of the band storage of A without row/column ``k`` sits in the
    F-ravelled band storage (3 bw + 1, n) of A: (flat indices, valid mask), both
    (3 bw + 1, n - 1); entries outside the band or the matrix are masked out."""
    d, j = np.mgrid[0 : 3 * bw + 1, 0 : n - 1]
    i = j + d - 2 * bw  # reduced row
    fi, fj = i + (i >= k), j + (j >= k)  # rows/columns of A
    fd = 2 * bw + fi - fj
    ok = (i >= 0) & (i < n - 1) & (np.abs(fi - fj) <= bw)
    return np.where(ok, fd + (3 * bw + 1) * fj, 0), ok


def applies(scene: Scene) -> str | None:
    """None if the energy analysis of ``scene`` can be replayed, else why not."""
    try:
        full = build(scene, 1, driver_load=True)
        i, _, _ = full.driver_functional()
    except Exception as err:  # noqa: BLE001 - any build failure is a reason, not a crash
        return f"not representable: {err}"
    if i < 0:
        return "the driver coordinate is fixed by a support"
    return None


def solve_energy(scene: Scene, n_elements: int, options: object) -> Solution:
    """Replay the energy analysis of ``scene`` (module doc)."""
    from fem_reference.replay.run import ReplayOptions, replay_system

    a = scene.analysis
    full = build(scene, n_elements, driver_load=True)
    full.const_factor = a.factor_end
    key = "driver.torque" if a.driver.kind == "rotation" else "driver.force"
    system = DrivenSystem(full, key)
    values = np.linspace(a.driver.start, a.driver.stop, a.steps + 1)
    if options.settle_tol == ReplayOptions.settle_tol:
        # the reaction is a residual force: rigid links (stiff FE elements) turn a settled
        # displacement error of 1e-7 L into newtons of driving force; settle 1e4 x tighter
        options = replace(options, settle_tol=SETTLE_TOL)
    # the jump test weighs dissipation against booked work, which misses the driver's: with
    # it off, no eigenvalue bisections are spent on jumps that are not assessed (below)
    options = replace(options, jump_dissipation=math.inf)
    sol = replay_system(system, values, scene=scene, case=scene.name, options=options)
    extras = dict(sol.extras)
    settle = dict(extras.get("settle", {}))
    settle["energy_balance_error"] = math.nan
    settle["note"] = "prescribed driver motion: the driver's work is not booked"
    extras["settle"] = settle
    # the jump test compares dissipation with the booked work, which misses the driver's:
    # it is not meaningful here
    extras["jumps"], extras["critical_points"] = [], []
    extras["jumps_note"] = "not assessed under a prescribed driver motion"
    fr = dict(extras.get("frames", {}))
    if "q" in fr and len(fr["q"]):  # frames in FE coordinates (the animation rebuilds the FE)
        fr["q"] = np.array([system._d(q, f) for q, f in zip(fr["q"], fr["factor"])])
        extras["frames"] = fr
    msg = sol.message
    if sol.status == "converged":
        res = max(st.info["residual"] for st in sol.steps)
        msg = f"settled {len(sol.steps)} driver positions; max residual {res:.2e}"
        msg += finish_note(extras)
    return post_process(scene, Solution(sol.case, sol.model, sol.status, msg, sol.steps, extras))
