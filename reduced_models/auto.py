"""Automatic fidelity: ``cbcm-auto``, ``prb-fsm-auto``, ``linear-auto``.

A parametrised family (N segments) is solved at N0, 2 N0, 4 N0; the observed order p of the
change between successive solutions gives the error estimate of the finest one (Richardson:
``e(N) = |f(N) - f(N_prev)| / ((N / N_prev)^p - 1)``).  While the estimate is above the target,
the order predicts the N that meets it, ``N* = N (e / target)^(1/p)`` (times a 10 % margin), and
that N is solved and checked the same way.  The returned Solution is the chosen N's own path
(not an extrapolation), with the estimate in ``extras``.

Change and estimate are measured like the report's path errors: the largest difference over
the whole path of the node outputs, a point's displacement change (as a vector: the same in
any orientation of the drawing) divided by the scene's longest member L, rotations in rad.
With three values on non-uniform N the order solves
``(h1^p - h2^p) / (h2^p - h3^p) = d21 / d32`` (h = 1/N); outside 0.5 <= p <= 6 (pre-asymptotic
or round-off) the family's formal order is used and the estimate is made conservative (the
larger of the Richardson correction and the last change).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq

from cases.schema import Scene
from reduced_models.base import Model, ModelCard, Solution, not_applicable, post_process
from reduced_models.beam.single_beam import cantilever_of
from reduced_models.options import Option

P_RANGE = (0.5, 6.0)
MARGIN = 1.1
MAX_ROUNDS = 8
MECHANISM_MAX_N = 64  # default largest N per member inside the mechanism assembler


def path_change(a: Solution, b: Solution, length: float) -> float:
    """Largest change over common steps and node outputs: a point's displacement change as a
    vector (|du| / L: the same number in any orientation of the drawing), rotations in rad."""
    m = min(len(a.steps), len(b.steps))
    keys = a.steps[0].outputs if m else ()
    worst = 0.0
    for key in keys:
        point, q = key.rsplit(".", 1) if "." in key else ("", key)
        if q == "rot":
            d = np.abs(a.path(key)[:m] - b.path(key)[:m])
        elif q == "ux" and f"{point}.uy" in keys:
            du = [a.path(f"{point}.{c}")[:m] - b.path(f"{point}.{c}")[:m] for c in ("ux", "uy")]
            d = np.hypot(*du) / length
        else:
            continue
        worst = max(worst, float(np.nanmax(d)))
    return worst


def observed_order(d21: float, d32: float, n: tuple[int, int, int]) -> float:
    """Order p from two successive changes on element counts n (nan if not monotone)."""
    if not (d21 > 0 and d32 > 0):
        return math.nan
    h1, h2, h3 = (1.0 / k for k in n)
    ratio = d21 / d32

    def g(p: float) -> float:
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    try:
        return float(brentq(g, 1e-3, 20.0))
    except ValueError:
        return math.nan


class AutoFidelity:
    """Refine a parametrised family until its error estimate is below ``target``.

    Parameters
    ----------
    target : allowed error estimate (translations / L, rotations in rad).
    start : first N (default: the family's).
    max_n : largest N tried; beyond it the solution is returned with ``target_reached``
        False in ``extras['fidelity']`` and the message says so.  Default: 512 on a single
        beam; ``MECHANISM_MAX_N`` per member inside the mechanism assembler.  Its KKT goes
        sparse above ``mechanism.kkt.SPARSE_FROM`` unknowns, so large N is affordable
        (prb-fsm-512 on Lee's frame: 3.9 s CPU and 150 MB, dense 25 s and 1.8 GB), but no
        catalog scene gains from N > 64: lee-frame's prb-fsm estimate stays near 0.5 up to
        N = 256 (0.5 s -> 2.1 s), and cbcm-N on the shallow arch stops converging at N = 130
        (residual floor 4.6e-10, dense or sparse); a larger ``max_n`` option is the user's
        choice.
    """

    family = ""
    formal_order = 2.0
    default_start = 4
    make: Callable[[int], Model]
    card: ModelCard

    OPTIONS = {  # declared options (reduced_models.options, checked by registry.build)
        "target": Option("float", 1e-12, 1.0, doc="error target (fraction of L or rad)"),
        "start": Option("int", 1, 100_000, doc="first N"),
        "max_n": Option("int", 2, 100_000, doc="largest N tried"),
    }

    def __init__(
        self, target: float = 1e-3, start: int | None = None, max_n: int | None = None
    ) -> None:
        if not (math.isfinite(float(target)) and float(target) > 0):
            raise ValueError(f"target must be a positive number, got {target!r}")
        self.target = float(target)
        self.start = int(start or self.default_start)
        self.max_n = None if max_n is None else int(max_n)
        if not 1 <= self.start < (self.max_n or MECHANISM_MAX_N):
            raise ValueError("need 1 <= start < max_n")
        self.name = f"{self.family}-auto"

    def applies_to(self, scene: Scene) -> str | None:
        """As the family's model."""
        return self.make(self.start).applies_to(scene)

    def solve(self, scene: Scene) -> Solution:
        """Solve at rising N until the estimate is below the target (module docstring)."""
        why = self.applies_to(scene)
        if why:
            return not_applicable(scene, self.name, why)
        length = max((scene.member_length(m.id) for m in scene.members), default=1.0) or 1.0
        single = not isinstance(cantilever_of(scene), str)  # str: why it is not a cantilever
        max_n = self.max_n or (512 if single else MECHANISM_MAX_N)
        ns = [self.start, 2 * self.start, 4 * self.start]
        sols = [self.make(n).solve(scene) for n in ns]
        p, est = self.formal_order, math.inf
        for _ in range(MAX_ROUNDS):
            bad = next((s for s in sols[-3:] if s.status != "converged"), None)
            if bad is not None and bad.status == "not-applicable":
                # a decline found only while solving (e.g. inextensible members that cannot
                # move under the load) is the family's decline, not a failed refinement
                return not_applicable(scene, self.name, f"{bad.model}: {bad.message}")
            if bad is not None:
                return self._result(scene, sols[-1], ns, p, est, f"{bad.model}: {bad.message}")
            d21 = path_change(sols[-3], sols[-2], length)
            d32 = path_change(sols[-2], sols[-1], length)
            p_obs = observed_order(d21, d32, tuple(ns[-3:]))
            r = ns[-1] / ns[-2]
            if P_RANGE[0] <= p_obs <= P_RANGE[1]:
                p, est = p_obs, d32 / (r**p_obs - 1.0)
            else:
                p = self.formal_order
                est = max(d32 / (r**p - 1.0), d32)
            if est <= self.target or ns[-1] >= max_n:
                break
            grow = (est / self.target) ** (1.0 / p) * MARGIN
            n_next = min(max_n, max(ns[-1] + 1, math.ceil(ns[-1] * grow)))
            ns.append(n_next)
            sols.append(self.make(n_next).solve(scene))
        return self._result(scene, sols[-1], ns, p, est, "")

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """Shapes and stress by the chosen N's own model (its ``postprocess``)."""
        fidelity = sol.extras.get("fidelity") or {}
        if "n" not in fidelity:
            return sol
        return post_process(self.make(int(fidelity["n"])), scene, sol)

    def _result(
        self, scene: Scene, sol: Solution, ns: list[int], p: float, est: float, failure: str
    ) -> Solution:
        reached = est <= self.target
        fidelity = {
            "n": ns[-1],
            "target": self.target,
            "estimate": est,
            "observed_order": p,
            "sequence": list(ns),
            "target_reached": reached and not failure,
        }
        extras = {**sol.extras, "fidelity": fidelity, "chosen_model": sol.model}
        if failure:
            msg = f"refinement stopped: {failure}"
            return Solution(scene.name, self.name, "failed", msg, sol.steps, extras)
        msg = f"N = {ns[-1]} (sequence {ns}): error estimate {est:.2e} (order {p:.2f})"
        msg += f" {'<=' if reached else '> (max_n reached)'} target {self.target:.2e}"
        if sol.message:
            msg += f"; {sol.message}"
        return Solution(scene.name, self.name, sol.status, msg, sol.steps, extras)


def _card(family: str, summary: str, order: str) -> ModelCard:
    return ModelCard(
        name=f"{family}-auto",
        family="auto",
        summary=summary,
        assumptions=(
            f"{family}-N solved at N0, 2 N0, 4 N0, then at the N the observed order predicts",
            "error estimate: Richardson with the observed order (formal order if outside "
            "0.5..6), largest over the path of translations / L and rotations (rad)",
        ),
        validity=f"as {family}-N; the estimate holds in the asymptotic range ({order})",
        references=(
            "Roache, Verification and Validation in Computational Science and Engineering, "
            "1998, ch. 5 (Richardson extrapolation, observed order)",
        ),
    )


def _linear(n: int) -> Model:
    from reduced_models.registry import make  # routed: mechanisms go to the assembler

    return make(f"linear-{n}")


def _cbcm(n: int) -> Model:
    from reduced_models.registry import make  # routed: mechanisms go to the assembler

    return make(f"cbcm-{n}")


def _fsm(n: int) -> Model:
    from reduced_models.registry import make  # routed: mechanisms go to the assembler

    return make(f"prb-fsm-{n}")


class LinearAuto(AutoFidelity):
    """``linear-auto``: chained linear segments, N chosen for the target."""

    family, formal_order, default_start = "linear", 2.0, 4
    make = staticmethod(_linear)
    card = _card("linear", "linear-N with N chosen for an error target", "O(1/N^2)")


class CBCMAuto(AutoFidelity):
    """``cbcm-auto``: chained BCM, N chosen for the target."""

    family, formal_order, default_start = "cbcm", 3.0, 2
    make = staticmethod(_cbcm)
    card = _card("cbcm", "cbcm-N with N chosen for an error target", "O(1/N^3) measured")


class PRBFSMAuto(AutoFidelity):
    """``prb-fsm-auto``: PRB finite-segment model, N chosen for the target."""

    family, formal_order, default_start = "prb-fsm", 2.0, 4
    make = staticmethod(_fsm)
    card = _card("prb-fsm", "prb-fsm-N with N chosen for an error target", "O(1/N^2)")
