"""The limits the speed record measures models against, written without FlexBench's models.

* ``exact_elastica_path``: the cantilever under a dead tip force by the elliptic-integral
  closed form (Bisshopp & Drucker 1945), one ``scipy.optimize.brentq`` in the parameter m per
  load factor with ``scipy.special.ellipk/ellipkinc/ellipe/ellipeinc``: the cost of the exact
  answer (tip x, y, rotation), the floor for the ``elastica`` model.
* ``plain_prb_path``: a pseudo-rigid-body chain (pivots at given fractions of the length,
  torsion springs) under a dead tip force, Newton on the pivot angles in plain floats (1 or 3
  angles) with the tip pose, strain energy, pivot-moment stress and the chain's shape of every
  step: what a PRB path costs when nothing but its equations is computed.
* ``plain_bcm_path``: Awtar's beam constraint model of one segment under a dead tip force:
  the axial load is the applied one, so each step is a 2x2 linear solve in plain floats, with
  the tip and strain energy; then the shapes the model draws (the exact beam-column through
  each tip state, 49 points) and the stress of their largest curvature, for all steps at once
  in numpy (until 2026-11-27 this limit left the shapes out and took the stress from the end
  moments: 24 us against the model's shapes).

``limits_table`` measures each model against its limit in one process (``python -m
reports.bench`` prints it first).
"""

from __future__ import annotations

import gc
import math
import statistics
import time
from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import cases
from cases.schema import Scene
from reduced_models.base import load_factors
from reduced_models.beam.single_beam import cantilever_of
from reports import api
from reports.bench.measure import verdict


def exact_elastica_path(
    L: float, EI: float, fx: float, fy: float, factors: np.ndarray
) -> list[tuple[float, float, float]]:
    """Tip (x, y, theta) in the beam frame (fx along the beam) at each load factor.

    Pendulum form: u = theta - phi + pi, sin(u/2) = +-k sn(w|m), tip at w = K (u'(L) = 0),
    root at F(psi*|m), sin psi* = c/k, c = |sin(u0/2)|: lam L = K(m) - F(psi*|m) fixes m.
    """
    out = []
    P0, phi = math.hypot(fx, fy), math.atan2(fy, fx)
    u0 = math.pi - phi
    u0 = u0 - 2.0 * math.pi if u0 > math.pi else u0
    c, sig = abs(math.sin(0.5 * u0)), math.copysign(1.0, u0)
    cp, sp = math.cos(phi), math.sin(phi)
    for t in factors:
        lam = math.sqrt(t * P0 / EI)
        if lam == 0.0 or c == 0.0:
            out.append((L, 0.0, 0.0))
            continue

        def g(m: float, lam: float = lam) -> float:
            return ellipk(m) - ellipkinc(math.asin(c / math.sqrt(m)), m) - lam * L

        m = brentq(g, c * c, 1.0 - 1e-16, xtol=1e-15, rtol=1e-15)
        k, psi = math.sqrt(m), math.asin(c / math.sqrt(m))
        A = L - 2.0 / lam * ((ellipk(m) - ellipe(m)) - (ellipkinc(psi, m) - ellipeinc(psi, m)))
        B = sig * 2.0 * k / lam * math.cos(psi)
        out.append((-A * cp + B * sp, -A * sp - B * cp, 2.0 * sig * math.asin(k) - u0))
    return out


def plain_prb_path(
    matrix: np.ndarray,
    L: float,
    EI: float,
    f1: tuple[float, float, float],
    factors: list[float],
    t_E: float,
) -> list[tuple]:
    """A PRB chain's 20-step path in plain floats (inextensible, free tip): the floor for the
    PRB models, with everything the model reports per step.

    ``matrix`` (S, 3): spring factor K_p EI/L at the joint that starts segment i (NaN: no
    joint), axial factor (ignored: rigid links), length fraction.  Newton on the absolute
    pivot angles psi (tridiagonal Hessian, Thomas sweep) from the previous step, until
    |grad V| <= 1e-10 EI/L.  ``t_E`` = E t / (2 EI) turns a bending moment into a stress.
    Returns per factor (tip x, y, angle, strain energy, max stress, chain points).
    """
    if np.isfinite(matrix[:, 0]).sum() == 1:
        return _plain_one_pivot(matrix, L, EI, f1, factors, t_E)
    gL = [float(g) * L for g in matrix[:, 2]]
    owner, p = [], -1
    for k in matrix[:, 0]:
        p += 1 if math.isfinite(k) else 0
        owner.append(p)
    K = [float(k) * EI / L for k in matrix[:, 0] if math.isfinite(k)]
    n = len(K)
    Lp = [sum(g for g, o in zip(gL, owner) if o == j) for j in range(n)]
    fx, fy, m = f1
    psi = [0.0] * n
    out = []
    Kn = [*K[1:], 0.0]  # the next spring of each joint
    tol = 1e-10 * EI / L
    for t in factors:
        px, py, pm = t * fx, t * fy, t * m
        for _ in range(50):
            # gradient g and tridiagonal Hessian (d, -K[j+1]) in one sweep; Thomas forward
            g, d, prev = [0.0] * n, [0.0] * n, 0.0
            big = 0.0
            for j in range(n):
                c, s = math.cos(psi[j]), math.sin(psi[j])
                th_next = psi[j + 1] - psi[j] if j + 1 < n else 0.0
                gj = K[j] * (psi[j] - prev) - Kn[j] * th_next + Lp[j] * (px * s - py * c)
                g[j] = gj - pm if j == n - 1 else gj
                d[j] = K[j] + Kn[j] + Lp[j] * (px * c + py * s)
                big = max(big, abs(g[j]))
                prev = psi[j]
            if big <= tol:
                break
            cp, gp = 0.0, 0.0
            cps, gps = [0.0] * n, [0.0] * n
            for j in range(n):
                den = d[j] + K[j] * cp if j else d[j]
                gp = (g[j] + K[j] * gp) / den if j else g[j] / den
                cp = -Kn[j] / den
                cps[j], gps[j] = cp, gp
            dx = 0.0
            for j in range(n - 1, -1, -1):
                dx = gps[j] - cps[j] * dx
                psi[j] -= dx
        pts, x, y = [(0.0, 0.0)], 0.0, 0.0
        for gl, o in zip(gL, owner):
            a = psi[o] if o >= 0 else 0.0
            x, y = x + gl * math.cos(a), y + gl * math.sin(a)
            pts.append((x, y))
        th = [psi[0]] + [psi[j] - psi[j - 1] for j in range(1, n)]
        energy = 0.5 * sum(k * a * a for k, a in zip(K, th))
        joints = [pts[i] for i, k in enumerate(matrix[:, 0]) if math.isfinite(k)]
        moments = [pm + (x - qx) * py - (y - qy) * px for qx, qy in [(0.0, 0.0), *joints]]
        out.append((x, y, psi[-1], energy, t_E * max(abs(v) for v in moments), pts))
    return out


def _plain_one_pivot(matrix: np.ndarray, L: float, EI: float, f1, factors, t_E: float) -> list:  # noqa: ANN001
    """``plain_prb_path`` of a one-pivot chain: scalar Newton on the pivot angle."""
    j = int(np.flatnonzero(np.isfinite(matrix[:, 0]))[0])
    K = float(matrix[j, 0]) * EI / L
    a = float(matrix[:j, 2].sum()) * L  # rigid root length
    b = float(matrix[j:, 2].sum()) * L  # link after the pivot
    fx, fy, m = f1
    psi, out, tol = 0.0, [], 1e-10 * EI / L
    for t in factors:
        px, py, pm = t * fx, t * fy, t * m
        for _ in range(50):
            c, s = math.cos(psi), math.sin(psi)
            g = K * psi + b * (px * s - py * c) - pm
            if abs(g) <= tol:
                break
            psi -= g / (K + b * (px * c + py * s))
        x, y = a + b * c, b * s
        moments = (pm + x * py - y * px, pm + (x - a) * py - y * px, pm)
        pts = ((0.0, 0.0), (a, 0.0), (x, y))
        out.append((x, y, psi, 0.5 * K * psi * psi, t_E * max(map(abs, moments)), pts))
    return out


def plain_bcm_path(
    L: float, EI: float, EA: float, f1: tuple[float, float, float], factors: list[float],
    t_E: float, points: int = 49,
) -> list[tuple]:  # fmt: skip
    """One BCM segment's path (Awtar et al. 2007) in plain floats: per factor (tip x, y,
    rotation, strain energy, largest bending stress, shape (points, 2)).  With a dead force in
    the clamp frame p = F_x L^2/EI is known, so [f, m] = (G + p P + p^2 Q) [y, a] is a 2x2
    linear solve; the shapes (the exact beam-column through each tip state, as the model
    draws them) and the stress (largest curvature along them) of all steps at once."""
    k = EI / (EA * L * L) if math.isfinite(EA) else 0.0
    tips = []
    for t in factors:
        f, p, m = t * f1[1] * L * L / EI, t * f1[0] * L * L / EI, t * f1[2] * L / EI
        a11 = 12.0 + p * 6.0 / 5.0 - p * p / 700.0
        a12 = -6.0 - p / 10.0 + p * p / 1400.0
        a22 = 4.0 + p * 2.0 / 15.0 - p * p * 11.0 / 6300.0
        det = a11 * a22 - a12 * a12
        y, a = (a22 * f - a12 * m) / det, (a11 * m - a12 * f) / det
        vPv = 6.0 / 5.0 * y * y - y * a / 5.0 + 2.0 / 15.0 * a * a
        vQv = -y * y / 700.0 + y * a / 700.0 - 11.0 / 6300.0 * a * a
        vGv = 12.0 * y * y - 12.0 * y * a + 4.0 * a * a
        ux = k * p - 0.5 * vPv - p * vQv
        energy = EI / L * (0.5 * vGv + 0.5 * p * p * (k - vQv))
        tips.append((ux, y, a, p, energy))
    ux, y, a, p, energy = np.array(tips).T
    xy, kmax = _beam_column_shapes(ux, y, a, p, k, points)
    stress = t_E * EI / L * kmax
    return list(zip((L * (1.0 + ux)).tolist(), (L * y).tolist(), a.tolist(), energy.tolist(),
                    stress.tolist(), xy * L))  # fmt: skip


def _beam_column_shapes(
    ux: np.ndarray, y: np.ndarray, a: np.ndarray, p: np.ndarray, k: float, points: int
) -> tuple[np.ndarray, np.ndarray]:
    """Segment-normalised shapes (m, points, 2) and largest |curvature| (m,) of clamped
    beam-columns (axial force p, tension +) through tip states (y, a): the tip loads (f, m)
    from the tip compliance, u(s) = k11 f + k12 m, theta(s) = k21 f + k22 m, in closed form
    (complex sqrt(p): cosh/sinh in tension, cos/sin in compression; the cubic where p = 0),
    axial position from the stretch and the trapezoid of theta^2."""
    s = np.linspace(0.0, 1.0, points)
    zero = p == 0.0
    if zero.all():  # no axial force: the cantilever cubic
        k11, k12 = s * s / 2.0 - s**3 / 6.0, s * s / 2.0
        k21, k22 = s - s * s / 2.0, s
        c11, c12, c21, c22 = 1.0 / 3.0, 0.5, 0.5, 1.0
    else:
        pc = np.where(zero, 1.0, p)[:, None] + 0j
        r = np.sqrt(pc)
        C1, T = np.cosh(r), np.tanh(r) / r
        ch, sh = np.cosh(r * s), np.sinh(r * s) / r
        k11 = ((T * (ch - 1.0) - sh + s) / pc).real
        k12 = ((ch - 1.0) / (pc * C1)).real
        k21 = (-(ch - 1.0) / pc + T * sh).real
        k22 = (sh / C1).real
        cubic = (s * s / 2.0 - s**3 / 6.0, s * s / 2.0, s - s * s / 2.0, s)
        closed = (k11, k12, k21, k22)
        k11, k12, k21, k22 = (np.where(zero[:, None], c, v) for c, v in zip(cubic, closed))
        c11, c12, c21, c22 = k11[:, -1], k12[:, -1], k21[:, -1], k22[:, -1]
    det = c11 * c22 - c12 * c21
    f, m = ((c22 * y - c12 * a) / det)[:, None], ((c11 * a - c21 * y) / det)[:, None]
    yl, th = k11 * f + k12 * m, k21 * f + k22 * m
    kappa = m + f * (1.0 - s) - p[:, None] * (y[:, None] - yl)
    t2 = th * th
    short = np.zeros_like(t2)
    np.cumsum(0.5 * (t2[:, 1:] + t2[:, :-1]) * np.diff(s), axis=1, out=short[:, 1:])
    xl = s * (1.0 + k * p[:, None]) - 0.5 * short
    xl += s * ((1.0 + ux)[:, None] - xl[:, -1:])
    return np.stack([xl, yl], axis=-1), np.abs(kappa).max(axis=1)


def interleaved(
    calls: list[Callable[[], object]], rounds: int, budget_s: float = 0.3
) -> list[tuple[float, float]]:
    """Median CPU and wall seconds of each call, the calls timed in turn within each round.

    On a shared machine the load drifts between one call's rounds and the next's; timing
    ``limit, solve, end to end`` in turn puts every ratio's numerator and denominator under
    the same load.  At least ``rounds`` rounds, more for sub-millisecond calls until one
    call has spent ``budget_s`` of CPU (at most 25 rounds), one warm-up each, GC off.
    """
    for call in calls:
        call()
    cpu: list[list[float]] = [[] for _ in calls]
    wall: list[list[float]] = [[] for _ in calls]
    gc.disable()
    try:
        while len(cpu[0]) < rounds or (len(cpu[0]) < 25 and max(map(sum, cpu)) < budget_s):
            for k, call in enumerate(calls):
                w0, c0 = time.perf_counter(), time.process_time()
                call()
                cpu[k].append(time.process_time() - c0)
                wall[k].append(time.perf_counter() - w0)
    finally:
        gc.enable()
    return [(statistics.median(c), statistics.median(w)) for c, w in zip(cpu, wall)]


# model -> (its limit, target ratio of end-to-end CPU to the limit, or an absolute ms target)
TARGETS = {
    "elastica": ("exact elliptic-integral path", 1.5, None),
    "prb-1r": ("plain-float PRB path", 3.0, None),
    "prb-3r": ("plain-float PRB path", 3.0, None),
    "bcm": ("plain-float BCM path", 3.0, None),
    "linear-1": ("none: absolute target", None, 0.2),
    "linear-8": ("none: absolute target", None, 0.2),
    "cbcm-16": ("none: absolute target", None, 1.5),
    "fem-16": ("OpenSeesPy: the fem-N table", None, None),
}


# why a target is out of reach as stated (printed beside its verdict)
NOTES = {
    "prb-1r": (
        "; measured in one process (CPU, load 6 on 2 cores, 2026-11-27): the engine's path "
        "0.087 ms (1.4x the whole plain path), the rest of the solve (tips, energy, 21 output "
        "maps and Steps) ~0.09, post-processing ~0.12-0.16 (end loads 0.06, shape and stress "
        "0.04, the 21 Steps rebuilt), the predicted error ~0.06: some 300 numpy calls and "
        "Python objects of ~1 us each, not arithmetic (end loads, shape and stress fused into "
        "one plain-float pass: 0.079 ms against the numpy pair's 0.087, not kept); 3x (~0.17 "
        "ms) would need a path that builds no per-step objects and the predicted error "
        "outside the timed call"
    ),
    "linear-1": (
        "; measured (as prb-1r): solve ~0.2 ms (the 21 2x2 solves ~0.013; end loads from the "
        "segment law 0.022, energy 0.011, local coordinates 0.010, 21 Steps), shapes ~0.1 "
        "(49 points a step: 0.039 placing and rotating them, 0.021 the shape functions, 0.014 "
        "the Steps), predicted error ~0.06: a dozen numpy passes of 5-40 us each; 0.2 ms "
        "would need the shapes on request and the predicted error outside the timed call"
    ),
    "linear-8": (
        "; linear-N with N > 1 is geometrically nonlinear (each segment turns with its "
        "predecessor's tip: at PL^2/EI = 10 its tip deflection is 0.82 L, the elastica's "
        "0.81 L, linear-1's 3.3 L), so one factorisation cannot give its answers; it is "
        "solved by Newton in the chain's own coordinates (reduced_models.beam.chain_path: "
        "one tridiagonal dptsv per iteration, 2-3 iterations per step) at the cost per "
        "iteration of cbcm-16's"
    ),
    "cbcm-16": (
        "; Newton in the chain's own coordinates (reduced_models.beam.chain_path), 48 "
        "iterations (2-3 per step, the floor with a 1e-10 update test and a verifying "
        "iteration), measured 74 us each: 47 the residual and condensed system (~40 numpy "
        "calls of ~1 us on 16-long arrays: segment law, closed-form 3x3 condensation), 8 the "
        "back-substitution, 2 the dptsv; the quintic predictor 17 us a step.  That system "
        "rewritten with a third fewer calls (reused buffers, fused rows, gathers) measured no "
        "faster (5.85 against 5.74 ms); steps 1-7 take 3 iterations because the predictor's "
        "error there (2e-3 to 1e-4 scaled, the tip segment's axial force) is the path's own "
        "curvature: below 1.5 ms would need compiled per-iteration code"
    ),
}


def _limit_call(name: str, scene: Scene) -> Callable[[], object] | None:
    """The limit of ``name`` on a cantilever scene as a call, or None."""
    b = cantilever_of(scene)
    f = load_factors(scene).tolist()
    mem = scene.member(b.member)
    t_E = mem.E * mem.thickness / (2.0 * b.EI) if mem.thickness and mem.E else 0.0
    f1 = (b.fx, b.fy, b.m)
    if name == "elastica":
        return lambda: exact_elastica_path(b.L, b.EI, b.fx, b.fy, f)
    if name.startswith("prb-"):
        matrix = api.make_model(name, scene).setup(b)[0]
        return lambda: plain_prb_path(matrix, b.L, b.EI, f1, f, t_E)
    if name == "bcm":
        return lambda: plain_bcm_path(b.L, b.EI, b.EA, f1, f, t_E)
    return None


def limits_table(rounds: int, case: str = "cantilever-tip-load") -> tuple[list[str], list[str]]:
    """Rows: each model's limit, its solve alone and end to end (``reports.solve``), CPU and
    wall ms (the three timed in turn, ``interleaved``), the end-to-end CPU ratio to the
    limit; and the target verdicts."""
    scene = cases.load(case)
    lines = [
        "| model | limit | limit CPU / wall ms | solve CPU / wall ms | end-to-end CPU / wall ms "
        "| end-to-end / limit (CPU) | target |",
        "|---|---|---|---|---|---|---|",
    ]
    verdicts = []
    for name, (what, ratio_max, ms_max) in TARGETS.items():
        model = api.make_model(name, scene)
        limit = _limit_call(name, scene)
        timed = [
            lambda m=model: api.run_model(m, scene, post=False),
            lambda m=model: api.solve(scene, m),
        ]
        solo, e2e, *lim = interleaved(timed + ([limit] if limit else []), rounds)
        lim = lim[0] if lim else None
        ratio = e2e[0] / lim[0] if lim else None
        if ratio_max is not None and ratio is not None:
            target = f"<= {ratio_max:g}x: {verdict(ratio, ratio_max)}"
        elif ms_max is not None:
            target = f"<= {ms_max:g} ms: {verdict(e2e[0] * 1e3, ms_max)}"
        else:
            target = "n/a"
        lim_cell = f"{lim[0] * 1e3:.3g} / {lim[1] * 1e3:.3g}" if lim else "n/a"
        lines.append(
            f"| {name} | {what} | {lim_cell} | {solo[0] * 1e3:.3g} / {solo[1] * 1e3:.3g} | "
            f"{e2e[0] * 1e3:.3g} / {e2e[1] * 1e3:.3g} | "
            f"{'n/a' if ratio is None else f'{ratio:.2f}'} | {target} |"
        )
        if target != "n/a":
            verdicts.append(f"- {name} ({what}) {target}{NOTES.get(name, '')}")
    return lines, verdicts
