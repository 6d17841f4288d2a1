"""``bcm`` under dead tip loads: one BCM segment solved directly, step by step, in plain floats.

With one segment clamped at the origin and dead loads, the segment's axial force is the
applied one, p = lam f_X (the first row of the mixed Lagrangian's gradient, see
``reduced_models.beam.chain_small``), so each load factor is one linear 2x2 solve

    [f, m] = K(p) [y, a],   K(p) = G + p P + p^2 Q        (guided tip: a = 0, y = f / K_00)

and the axial position follows from the x-relation, ux = p (k - w.Q.w) - 1/2 w.P.w.  This is
the equilibrium the continuation engine converges to whenever K(p) stays positive definite
along the ramp (it is then unique at every factor); where it does not (a compressive ramp
reaching the BCM's own buckling load) ``BCM`` hands the scene to the general continuation,
which traces or stops at that point as before.  ``pd_interval`` gives the range of p where
K(p) is positive definite, from the roots of K_00(p) and det K(p).

Reported per step as ``ChainModel.solve`` does: tip outputs, strain energy, one iteration
(the solve), stability (K(p) positive definite), the residual of the equations at the
returned state, the tip loads K w, the segment deflection; shapes and stress of all steps at
once in ``shapes`` (``bcm.bcm_shape``, vectorised over the steps).
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from cases.schema import Scene
from reduced_models.base import Solution, Step, load_factors
from reduced_models.beam.chain import SegmentLaw
from reduced_models.beam.single_beam import (
    Cantilever,
    cantilever_of,
    output_map,
    steps_with_shapes,
    unstable_note,
)

if TYPE_CHECKING:
    from reduced_models.beam.chain_model import ChainModel

__all__ = ["pd_interval", "single_segment_states", "solve_direct", "with_shapes"]


def pd_interval(law: SegmentLaw, guided: bool) -> tuple[float, float]:
    """(p_lo, p_hi): the open interval around p = 0 where K(p) = G + p P + p^2 Q is positive
    definite (guided: where K_00(p) > 0, the only stiffness a held tip angle leaves)."""
    G, P, Q = law.G, law.P, law.Q
    k00 = np.array([Q[0, 0], P[0, 0], G[0, 0]])  # K_00(p), highest power first
    polys = [k00]
    if not guided:  # det K = K_00 K_11 - K_01 K_10, a quartic
        k11 = np.array([Q[1, 1], P[1, 1], G[1, 1]])
        k01, k10 = np.array([Q[0, 1], P[0, 1], G[0, 1]]), np.array([Q[1, 0], P[1, 0], G[1, 0]])
        polys.append(np.polysub(np.polymul(k00, k11), np.polymul(k01, k10)))
    roots = np.concatenate([np.roots(c) for c in polys])
    real = roots[np.abs(roots.imag) <= 1e-12 * np.abs(roots)].real
    lo = real[real < 0.0].max(initial=-math.inf)
    hi = real[real > 0.0].min(initial=math.inf)
    return float(lo), float(hi)


def single_segment_states(
    law: SegmentLaw, k: float, loads: tuple[float, float, float], guided: bool, factors: list
) -> list[tuple]:
    """Per factor: (X, Y, phi, p, strain energy v, residual, stable, (p, f, m)) in the
    normalised units of ``reduced_models.beam.chain`` (lengths / L, energy EI/L, forces
    EI/L^2, moment EI/L); ``loads`` = (f_X, f_Y, m) at factor 1, ``k`` = EI/(EA L^2)."""
    (g00, g01), (g10, g11) = law.G.tolist()
    (p00, p01), (p10, p11) = law.P.tolist()
    (q00, q01), (q10, q11) = law.Q.tolist()
    fX, fY, m1 = loads
    out = []
    for lam in factors:
        p = lam * fX
        pp = p * p
        k00, k01 = g00 + p * p00 + pp * q00, g01 + p * p01 + pp * q01
        k10, k11 = g10 + p * p10 + pp * q10, g11 + p * p11 + pp * q11
        f, m = lam * fY, lam * m1
        det = k00 * k11 - k01 * k10
        if guided:  # the tip angle is held: a = 0, the moment is the guide's reaction
            Y, a = f / k00, 0.0
        else:
            Y, a = (k11 * f - k01 * m) / det, (k00 * m - k10 * f) / det
        yy, ya, aa = Y * Y, Y * a, a * a
        wPw = p00 * yy + (p01 + p10) * ya + p11 * aa
        wQw = q00 * yy + (q01 + q10) * ya + q11 * aa
        wGw = g00 * yy + (g01 + g10) * ya + g11 * aa
        D = k - wQw
        X = 1.0 + (p * D - 0.5 * wPw)
        fl, ml = k00 * Y + k01 * a, k10 * Y + k11 * a  # the segment's own tip loads K w
        # the equations at the returned state (the engine's residual: free rows only)
        res = max(abs(fl - f), 0.0 if guided else abs(ml - m), abs(X - 1.0 + 0.5 * wPw - p * D))
        stable = k00 > 0.0 and (guided or det > 0.0)
        energy = 0.5 * wGw + 0.5 * pp * D
        out.append((X, Y, a, p, energy, res, stable, (p, fl, ml)))
    return out


def solve_direct(model: ChainModel, scene: Scene, beam: Cantilever) -> Solution | None:
    """``model.solve(scene)`` of a one-segment BCM under dead loads, or None when K(p) leaves
    its positive-definite range on the ramp (the caller then runs the continuation)."""
    L, EI = beam.L, beam.EI
    k = EI / (beam.EA * L * L) if math.isfinite(beam.EA) else 0.0
    loads = (beam.fx * L * L / EI, beam.fy * L * L / EI, beam.m * L / EI)
    factors = load_factors(scene).tolist()
    lo, hi = model.pd_range(beam.guided)
    if not all(lo < lam * loads[0] < hi for lam in factors):
        return None
    states = single_segment_states(model.law, k, loads, beam.guided, factors)
    a_cfg = scene.analysis
    stop = a_cfg.kind == "path" and a_cfg.stop_output and a_cfg.stop_value is not None
    outputs_of = output_map(scene, beam)
    fs, ms = EI / (L * L), EI / L
    steps, v0 = [], None
    for j, (lam, (X, Y, a, _p, e, r, st, (pl, fl, ml))) in enumerate(zip(factors, states)):
        outputs = outputs_of(X * L, Y * L, a)
        info = {"tip.fx": pl * fs, "tip.fy": fl * fs, "tip.m": ml * ms, "residual": r}
        info["cuts"], info["max_segment_y"] = 0.0, abs(Y)
        steps.append(Step(lam, outputs, e * ms, 1, st, info=info))
        if stop:  # a "path" analysis stops once its stop output reaches the stop value
            v = outputs.get(a_cfg.stop_output)
            v0 = v if v0 is None else v0
            if v is not None and j > 0 and (v - a_cfg.stop_value) * (v0 - a_cfg.stop_value) <= 0:
                break
    n = len(steps)
    tips = np.array([s[:4] for s in states[:n]])  # (n, 4): X, Y, phi, p
    nodes = np.zeros((n, 2, 3))
    nodes[:, 1] = tips[:, :3] * np.array([L, L, 1.0])
    extras: dict[str, object] = {"nodes": nodes, "axial": tips[:, 3:4], "k": k}
    msg = f"{n} steps, each one 2x2 solve (dead loads: the axial force is the applied one)"
    # the model's validity flags, worded and ordered as ChainModel.solve words them
    seg = [c[:, None] for c in (tips[:, 0] - 1.0, tips[:, 1], tips[:, 2], tips[:, 3])]
    flags = model.warning_flags(*seg, k)
    first = sorted((int(np.argmax(f)), w) for w, f in flags if np.any(f))
    warned = "; ".join(f"{w} (from factor {factors[j]:.4g})" for j, w in first)
    if warned:
        extras["validity_warning"], extras["validity_message"] = True, warned
        msg += f"; outside validity range: {warned}"
    msg += unstable_note(steps)
    return Solution(scene.name, model.name, "converged", msg, tuple(steps), extras)


@functools.lru_cache(maxsize=8)
def stations(points: int) -> np.ndarray:
    """``points`` equally spaced positions in [0, 1] along a segment (read-only, made once)."""
    sigma = np.linspace(0.0, 1.0, points)
    sigma.flags.writeable = False
    return sigma


def with_shapes(model: ChainModel, scene: Scene, sol: Solution) -> Solution:
    """``sol`` (one segment) with the shapes and bending stress of every step, all at once:
    ``ChainModel.postprocess`` for N = 1 (the segment frame is the beam frame)."""
    beam = cantilever_of(scene)
    L, m = beam.L, len(sol.steps)
    tip = np.asarray(sol.extras["nodes"], dtype=float)[:m, 1] / np.array([L, L, 1.0])
    p = np.asarray(sol.extras["axial"], dtype=float)[:m, 0]
    sigma = stations(model.shape_points)
    xl, yl, kappa = model.shape(tip[:, 0] - 1.0, tip[:, 1], tip[:, 2], p, sol.extras["k"], sigma)
    pts = np.empty((m, sigma.size, 2))
    pts[:, :-1, 0], pts[:, :-1, 1] = xl[:, :-1], yl[:, :-1]
    pts[:, -1] = tip[:, :2]  # the last point is the tip node itself
    pts = beam.rotate_to_global(pts * L)
    steps = steps_with_shapes(scene, beam, sol.steps, pts, np.abs(kappa).max(axis=1) / L)
    return Solution(sol.case, sol.model, sol.status, sol.message, steps, sol.extras)
