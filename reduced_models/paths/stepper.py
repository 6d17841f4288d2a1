"""The one load-stepping loop of the reduced models' continuation engines.

``follow(engine, x0, factors, max_cuts)`` walks the equilibrium path through the reported
load factors: Newton at the first factor from ``x0``; between two reported factors an
increment that starts at the last successful one (carried across reported factors), a
predicted start (``engine.predict``; a failed predicted start is retried from the last
converged state), halving on a Newton failure or a branch jump (``engine.branch_jump``: a
stable state followed by an unstable one, or a path turning back; accepted once the
increment is as short as allowed), doubling after an easy step (<= 4 iterations), and a stop
after ``max_cuts`` halvings in a row or once the increment falls below the reported interval
/ 2^max_cuts.

The arithmetic lives in the engine, so each keeps its own representation: numpy arrays and
LAPACK factorisations (``continuation.minimize_path``), plain float lists for a few unknowns
(``small_path``), one float (``scalar_path``).  An engine provides

* ``solve(start, lam) -> (converged or None, iterations, reason)``: Newton at factor ``lam``;
* ``state(c)``: the unknowns of a converged solve;
* ``tangent(c, lam)``: dx/dlam there, or None;
* ``predict(x, x_prev, t, t_prev, s, lam, lam_prev)``: the start for an increment ``s`` from
  ``x`` (None: from ``x`` itself);
* ``branch_jump(cur, conv, x, x_prev, lam, lam_prev) -> str``: why ``conv`` left the branch of
  ``cur`` ("" if it did not);
* ``diagnose(c, lam) -> str``: why the path stopped at ``c`` (``path_result.limit_note``);
* ``record(c, lam, iterations, cuts)``: keep a reported state.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from reduced_models.paths.path_result import PathResult


class Engine(Protocol):
    """The arithmetic of one continuation engine (module docstring)."""

    def solve(self, start: Any, lam: float) -> tuple[Any, int, str]: ...
    def state(self, c: Any) -> Any: ...
    def tangent(self, c: Any, lam: float) -> Any: ...
    def predict(
        self, x: Any, x_prev: Any, t: Any, t_prev: Any, s: float, lam: float, lam_prev: Any
    ) -> Any: ...
    def branch_jump(
        self, cur: Any, conv: Any, x: Any, x_prev: Any, lam: float, lam_prev: Any
    ) -> str: ...
    def diagnose(self, c: Any, lam: float) -> str: ...
    def record(self, c: Any, lam: float, its: int, cuts: int) -> None: ...


def follow(engine: Engine, x0: Any, factors: Sequence[float], max_cuts: int) -> tuple[bool, str]:
    """Walk the path through ``factors`` (module docstring); (ok, reason it stopped)."""
    if len(factors) == 0:
        return True, ""
    conv, its, why = engine.solve(x0, factors[0])
    if conv is None:
        return False, f"no equilibrium at factor {factors[0]:.6g}: {why}"
    engine.record(conv, factors[0], its, 0)
    x_prev, lam_prev = None, None  # the converged state before the current one
    cur, lam_cur = conv, float(factors[0])
    t_cur, t_prev = engine.tangent(cur, lam_cur), None
    dlam = None  # size of the last successful increment (carried to the next reported step)
    for target in factors[1:]:
        target = float(target)
        its_total, cuts_total, consecutive = 0, 0, 0
        span = target - lam_cur
        direction = 1.0 if span >= 0 else -1.0
        step = abs(span) if dlam is None else min(dlam, abs(span))
        shortest = abs(span) * 0.5**max_cuts
        while abs(target - lam_cur) > 1e-14 * max(1.0, abs(target)):
            lam_try = lam_cur + direction * step
            if direction * (target - lam_try) < 1e-9 * step:
                lam_try = target  # do not leave a sliver before the reported factor
            x_cur = engine.state(cur)
            s = lam_try - lam_cur
            start = engine.predict(x_cur, x_prev, t_cur, t_prev, s, lam_cur, lam_prev)
            conv, its, why = engine.solve(x_cur if start is None else start, lam_try)
            its_total += its
            if conv is None and start is not None:
                # the predictor can overshoot near a limit: retry from the last state
                conv, its, why = engine.solve(x_cur, lam_try)
                its_total += its
            if conv is not None and 0.5 * abs(s) >= shortest:
                jump = engine.branch_jump(cur, conv, x_cur, x_prev, lam_cur, lam_prev)
                if jump:
                    conv, why = None, jump
            if conv is None:
                cuts_total += 1
                consecutive += 1
                step = 0.5 * abs(s)
                if consecutive > max_cuts or step < shortest:
                    return False, (
                        f"Newton failed between factors {lam_cur:.6g} and {lam_try:.6g} "
                        f"after {cuts_total} step cuts ({why}); " + engine.diagnose(cur, lam_cur)
                    )
                continue
            consecutive = 0
            x_prev, lam_prev = x_cur, lam_cur
            step = abs(s)
            cur, lam_cur = conv, lam_try
            t_prev, t_cur = t_cur, engine.tangent(cur, lam_cur)
            if its <= 4:  # easy step: allow a larger increment next time (also carried on)
                step *= 2.0
            dlam = step
        engine.record(cur, lam_cur, its_total, cuts_total)
    return True, ""


class Recorder:
    """The reported states of a path, turned into its ``PathResult``."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.f: list[float] = []
        self.x: list = []
        self.its: list[int] = []
        self.cuts: list[int] = []
        self.res: list[float] = []
        self.stable: list = []

    def add(self, lam: float, x: Any, its: int, cuts: int, res: float, stable: Any) -> None:
        """Keep one reported state (load factor, unknowns, work, residual, stability)."""
        self.f.append(float(lam))
        self.x.append(x)
        self.its.append(its)
        self.cuts.append(cuts)
        self.res.append(res)
        self.stable.append(stable)

    def result(self, ok: bool, reason: str) -> PathResult:
        """The ``PathResult`` of the states kept so far."""
        return PathResult(
            factors=np.array(self.f),
            states=np.array(self.x, dtype=float).reshape(len(self.x), self.n),
            iterations=np.array(self.its, dtype=int),
            cuts=np.array(self.cuts, dtype=int),
            residuals=np.array(self.res),
            stable=self.stable,
            ok=ok,
            reason=reason,
        )
