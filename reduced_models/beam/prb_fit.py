"""PRB optimizer: fit a PRB matrix to the exact elastica over a normalised load range.

Seed 000_265bc60728766176.txt, "PRB Optimizer": start from a PRB model with a given number of
segments, define a normalised load range, and let the optimiser find the PRB parameters with
the least tip error against the analytical beam model.  Here the unknowns are the segment
lengths gamma_0..gamma_n (summing to 1; gamma_0 is the rigid root link) and the spring
stiffnesses k_1..k_n (units EI/L); the residuals are the tip position errors (x, y)/L and the
tip angle error (rad, weighted) at every load point, minimised by
``scipy.optimize.least_squares``.  Load points (L = EI = 1):

* a tip force with transverse component alpha = P L^2/EI in ``load_range`` and axial
  component -n alpha (Howell's load ratio n, compressive +), and optionally
* a pure end moment m = M L/EI in ``moment_range``.

``fit_prb_cli(argv)`` is the ``flexbench fit-prb`` command (wired by reports.cli).
"""

from __future__ import annotations

import argparse
import math
import sys
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from reduced_models.beam.prb_chain import PRBChain, equilibrium_path

INF = math.inf


@dataclass(frozen=True)
class FitResult:
    """A fitted PRB matrix and its tip errors against the reference over the fitted loads.

    Attributes
    ----------
    matrix : (n_segments + 1, 3) PRB matrix ``[k_theta, k_ex, gamma]`` (first row: rigid root).
    rms_error : RMS of all residuals (position errors / L and weighted angle errors, rad).
    max_position_error : largest |tip - exact| / L over the load points.
    max_angle_error : largest |tip angle - exact| (rad) over the load points.
    success : least_squares status > 0 and every PRB equilibrium converged.
    message : optimiser message.
    nfev : residual evaluations.
    """

    matrix: np.ndarray
    rms_error: float
    max_position_error: float
    max_angle_error: float
    success: bool
    message: str
    nfev: int


def _default_reference() -> Callable:
    from reduced_models.beam.elastica import tip_dead_force

    return tip_dead_force


@dataclass(frozen=True)
class LoadSet:
    """Load points of one proportional path: unit load direction (fx, fy, m) and magnitudes."""

    direction: tuple[float, float, float]
    magnitudes: np.ndarray

    def exact(self, reference: Callable) -> np.ndarray:
        """Reference tip (x, y, theta) at every magnitude, shape (k, 3) (L = EI = 1)."""
        d = self.direction
        return np.array(
            [reference(1.0, 1.0, a * d[0], a * d[1], a * d[2]) for a in self.magnitudes]
        )


def load_sets(
    load_range: Sequence[float] = (0.0, 10.0),
    n: float = 0.0,
    moment_range: Sequence[float] | None = None,
    n_points: int = 12,
) -> list[LoadSet]:
    """The load paths of a fit: a force at load ratio n (and a pure moment if asked)."""
    lo, hi = float(load_range[0]), float(load_range[1])
    sets = [LoadSet((-n, 1.0, 0.0), np.linspace(max(lo, hi / n_points), hi, n_points))]
    if moment_range is not None:
        mlo, mhi = float(moment_range[0]), float(moment_range[1])
        sets.append(LoadSet((0.0, 0.0, 1.0), np.linspace(max(mlo, mhi / n_points), mhi, n_points)))
    return sets


def prb_tips(matrix: np.ndarray, sets: Sequence[LoadSet]) -> tuple[np.ndarray, bool]:
    """PRB tip (x, y, tip-link angle) at every load point, shape (k, 3); False if a path failed.

    Failed points are NaN.  L = EI = 1, inextensible.
    """
    chain = PRBChain(matrix, 1.0, 1.0)
    out, ok = [], True
    for s in sets:
        factors = np.concatenate([[0.0], s.magnitudes])
        path = equilibrium_path(chain, np.asarray(s.direction, dtype=float), factors)
        tips = np.full((len(s.magnitudes), 3), np.nan)
        for i, x in enumerate(path.states[1:]):
            tips[i] = chain.tip(x)
        ok &= bool(path.ok)
        out.append(tips)
    return np.vstack(out), ok


def _matrix(p: np.ndarray, n_segments: int) -> np.ndarray:
    # stick-breaking: gamma_i = v_i * (1 - sum of the previous), last takes the rest
    v, k = p[:n_segments], p[n_segments:]
    g, rest = np.empty(n_segments + 1), 1.0
    for i in range(n_segments):  # n_segments + 1 scalars, not a hot path
        g[i] = v[i] * rest
        rest -= g[i]
    g[-1] = rest
    m = np.empty((n_segments + 1, 3))
    m[:, 1] = INF
    m[:, 2] = g
    m[0, 0] = INF
    m[1:, 0] = k
    return m


def _params(matrix: np.ndarray) -> np.ndarray:
    g = matrix[:, 2]
    rest = 1.0 - np.concatenate([[0.0], np.cumsum(g)[:-1]])
    return np.concatenate([g[:-1] / rest[:-1], matrix[1:, 0]])


def _errors(tips: np.ndarray, exact: np.ndarray, angle_weight: float) -> np.ndarray:
    r = np.column_stack([tips[:, :2] - exact[:, :2], angle_weight * (tips[:, 2] - exact[:, 2])])
    return np.where(np.isfinite(r), r, 1.0).ravel()


def initial_matrix(n_segments: int) -> np.ndarray:
    """Start: the midpoint finite segment model (gamma 1/(2n), 1/n, ..., 1/(2n); k = n)."""
    g = np.full(n_segments + 1, 1.0 / n_segments)
    g[0] = g[-1] = 0.5 / n_segments
    k = np.full(n_segments, float(n_segments))
    return np.column_stack([np.concatenate([[INF], k]), np.full(n_segments + 1, INF), g])


def fit_prb(
    n_segments: int,
    load_range: Sequence[float] = (0.0, 10.0),
    *,
    n: float = 0.0,
    moment_range: Sequence[float] | None = None,
    n_points: int = 12,
    angle_weight: float = 1.0,
    x0: np.ndarray | None = None,
    reference: Callable | None = None,
) -> FitResult:
    """Fit an nR PRB matrix (n = ``n_segments`` revolute joints) to the exact elastica.

    Parameters
    ----------
    n_segments : number of spring-carrying segments (revolute joints); the matrix has
        ``n_segments + 1`` rows, the first being the rigid root link.
    load_range : (alpha_min, alpha_max) of the transverse tip force P L^2/EI.
    n : Howell's load ratio (axial/transverse, compressive +).
    moment_range : optional (m_min, m_max) of a pure end moment M L/EI fitted jointly.
    n_points : load points per path.
    angle_weight : weight of the tip-angle residual (rad) against position (/L).
    x0 : optional starting PRB matrix (default ``initial_matrix``).
    reference : ``(L, EI, fx, fy, m) -> (x, y, theta)``; default the exact elastica
        ``reduced_models.beam.elastica.tip_dead_force``.

    Returns
    -------
    FitResult
    """
    if n_segments < 1:
        raise ValueError("n_segments must be >= 1")
    reference = reference or _default_reference()
    sets = load_sets(load_range, n, moment_range, n_points)
    exact = np.vstack([s.exact(reference) for s in sets])
    p0 = _params(initial_matrix(n_segments) if x0 is None else np.asarray(x0, dtype=float))
    lb = np.concatenate([np.full(n_segments, 1e-3), np.full(n_segments, 0.05)])
    ub = np.concatenate([np.full(n_segments, 0.999), np.full(n_segments, 1e3)])
    p0 = np.clip(p0, lb * 1.0001, ub * 0.9999)

    def fun(p: np.ndarray) -> np.ndarray:
        return _errors(prb_tips(_matrix(p, n_segments), sets)[0], exact, angle_weight)

    sol = least_squares(fun, p0, bounds=(lb, ub), x_scale="jac", xtol=1e-10, ftol=1e-10)
    matrix = _matrix(sol.x, n_segments)
    tips, ok = prb_tips(matrix, sets)
    pos = np.hypot(tips[:, 0] - exact[:, 0], tips[:, 1] - exact[:, 1])
    ang = np.abs(tips[:, 2] - exact[:, 2])
    res = _errors(tips, exact, angle_weight)
    return FitResult(
        matrix=matrix,
        rms_error=float(np.sqrt(np.mean(res**2))),
        max_position_error=float(np.nanmax(pos)) if ok else math.inf,
        max_angle_error=float(np.nanmax(ang)) if ok else math.inf,
        success=bool(sol.status > 0 and ok),
        message=str(sol.message),
        nfev=int(sol.nfev),
    )


def tip_errors(
    matrix: np.ndarray,
    load_range: Sequence[float] = (0.0, 10.0),
    *,
    n: float = 0.0,
    moment_range: Sequence[float] | None = None,
    n_points: int = 12,
    reference: Callable | None = None,
) -> tuple[float, float]:
    """Max tip position error (/L) and max tip angle error (rad) of a PRB matrix over loads."""
    reference = reference or _default_reference()
    sets = load_sets(load_range, n, moment_range, n_points)
    exact = np.vstack([s.exact(reference) for s in sets])
    tips, ok = prb_tips(np.asarray(matrix, dtype=float), sets)
    if not ok:
        return math.inf, math.inf
    pos = np.hypot(tips[:, 0] - exact[:, 0], tips[:, 1] - exact[:, 1])
    return float(pos.max()), float(np.abs(tips[:, 2] - exact[:, 2]).max())


@dataclass(frozen=True)
class ForceDeflectionError:
    """Errors of a model on a cantilever (L = EI = 1) under a tip force, per load alpha.

    Attributes
    ----------
    alpha : (k,) transverse load P L^2/EI.
    deflection_rel : (k,) (y_model - y_exact)/y_exact, the relative error of the transverse
        tip deflection -- what a user sees on a force-deflection curve (small loads included).
    position : (k,) |tip - exact| / L.
    angle : (k,) tip angle error (rad).
    status : (k,) model status per load ("converged", "failed", "not-applicable").
    """

    alpha: np.ndarray
    deflection_rel: np.ndarray
    position: np.ndarray
    angle: np.ndarray
    status: tuple[str, ...]


def cantilever_scene(alpha: float, n: float = 0.0, steps: int = 10):  # noqa: ANN201
    """A unit cantilever (L = E = I = 1, A = 1e8) with tip force alpha (-n, 1)."""
    from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support

    return Scene(
        name="unit-cantilever",
        title="unit cantilever, tip force",
        units="nondim",
        nodes=(Node("A", 0.0, 0.0), Node("B", 1.0, 0.0)),
        members=(Member("beam", "A", "B", "flexible", E=1.0, I=1.0, A=1e8),),
        supports=(Support("A", "clamp"),),
        loads=(Load("P", fx=-n * alpha, fy=alpha, node="B"),),
        analysis=Analysis(kind="load", steps=steps),
        outputs=(Output("tip", "B"),),
    )


def force_deflection_error(
    model_name: str,
    alpha_grid: Sequence[float],
    n: float = 0.0,
    options: dict | None = None,
    reference: Callable | None = None,
) -> ForceDeflectionError:
    """Error of a registered model against the exact elastica over a load range.

    Every alpha is solved as its own load ramp (10 steps) on ``cantilever_scene``, so the
    error at small loads is measured as carefully as at large ones.
    """
    from reduced_models.registry import make

    reference = reference or _default_reference()
    alpha = np.asarray(alpha_grid, dtype=float)
    rel, pos, ang, status = [], [], [], []
    for a in alpha:
        model = make(model_name, options)
        if hasattr(model, "shapes"):
            model.shapes = False  # tip errors only: skip shape recovery
        sol = model.solve(cantilever_scene(float(a), n))
        status.append(sol.status)
        if sol.status != "converged":
            rel.append(np.nan), pos.append(np.nan), ang.append(np.nan)
            continue
        o = sol.steps[-1].outputs
        xe, ye, te = reference(1.0, 1.0, -n * a, a, 0.0)
        rel.append((o["tip.uy"] - ye) / ye if ye else 0.0)
        pos.append(float(np.hypot(o["tip.x"] - xe, o["tip.y"] - ye)))
        ang.append(o["tip.rot"] - te)
    return ForceDeflectionError(alpha, np.array(rel), np.array(pos), np.array(ang), tuple(status))


def _fmt(v: float) -> str:
    return "inf" if math.isinf(v) else f"{v:.10g}"


def matrix_toml(matrix: np.ndarray) -> str:
    """A PRB matrix as a TOML array of arrays (``inf`` for infinite entries)."""
    rows = ", ".join("[" + ", ".join(_fmt(float(v)) for v in r) + "]" for r in np.asarray(matrix))
    return f"[{rows}]"


def save_to_case(path: str | Path, matrix: np.ndarray) -> None:
    """Append a ``[[models]] name = "prb-custom"`` entry with this matrix to a case file.

    Raises ValueError if the file already names a prb-custom model (edit it by hand then).
    """
    path = Path(path)
    text = path.read_text()
    existing = tomllib.loads(text).get("models", [])
    if any(isinstance(m, dict) and m.get("name") == "prb-custom" for m in existing):
        raise ValueError(f"{path}: already has a [[models]] prb-custom entry")
    block = (
        "\n[[models]]\n"
        'name = "prb-custom"\n'
        "[models.options]\n"
        "# rows [k_theta (EI/L), k_ex (EA/L), gamma]; written by flexbench fit-prb\n"
        f"matrix = {matrix_toml(matrix)}\n"
    )
    path.write_text(text.rstrip("\n") + "\n" + block)


def fit_prb_cli(argv: Sequence[str] | None = None) -> int:
    """``flexbench fit-prb``: fit a PRB matrix, print it and its errors, optionally save it."""
    ap = argparse.ArgumentParser(prog="flexbench fit-prb", description=__doc__.splitlines()[0])
    ap.add_argument("segments", type=int, help="number of revolute joints (e.g. 3 for a 3R)")
    ap.add_argument("--alpha-max", type=float, default=10.0, help="largest P L^2/EI (10)")
    ap.add_argument("--alpha-min", type=float, default=0.0, help="smallest P L^2/EI (0)")
    ap.add_argument("--n", type=float, default=0.0, help="load ratio axial/transverse (0)")
    ap.add_argument("--moment-max", type=float, default=None, help="also fit end moments to ML/EI")
    ap.add_argument("--points", type=int, default=12, help="load points per path (12)")
    ap.add_argument("--angle-weight", type=float, default=1.0, help="tip-angle weight (1)")
    ap.add_argument("--save", metavar="CASE.toml", help="append the matrix as prb-custom")
    try:
        a = ap.parse_args(argv)
    except SystemExit as exc:  # argparse already printed the usage line / help
        return int(exc.code or 0)
    if a.segments < 1 or a.points < 2 or not a.alpha_max > a.alpha_min >= 0.0:
        print(
            "fit-prb: need segments >= 1, points >= 2, 0 <= alpha-min < alpha-max", file=sys.stderr
        )
        return 2
    if a.save and not Path(a.save).is_file():
        print(f"fit-prb: {a.save}: no such case file", file=sys.stderr)
        return 2
    mrange = None if a.moment_max is None else (0.0, a.moment_max)
    try:
        r = fit_prb(
            a.segments,
            (a.alpha_min, a.alpha_max),
            n=a.n,
            moment_range=mrange,
            n_points=a.points,
            angle_weight=a.angle_weight,
        )
    except (ValueError, ArithmeticError, RuntimeError) as exc:  # e.g. no exact reference
        print(f"fit-prb: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    print("PRB matrix [k_theta (EI/L), k_ex (EA/L), gamma]:")
    for row in r.matrix:
        print("  [" + ", ".join(f"{_fmt(float(v)):>12}" for v in row) + "]")
    print(f"max tip position error {r.max_position_error:.3e} L")
    print(f"max tip angle error    {r.max_angle_error:.3e} rad")
    print(f"rms residual           {r.rms_error:.3e}  ({r.nfev} evaluations; {r.message})")
    if not r.success:
        print("fit-prb: the fit did not converge cleanly", file=sys.stderr)
    if a.save:
        try:
            save_to_case(a.save, r.matrix)
        except (ValueError, tomllib.TOMLDecodeError) as exc:
            print(f"fit-prb: {exc}", file=sys.stderr)
            return 2
        print(f"saved as [[models]] prb-custom in {a.save}")
    return 0 if r.success else 1
