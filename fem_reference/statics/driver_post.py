"""Post-processing of the reference's driver and load paths: mechanical advantage and the
equilibria of energy analyses, from the reported steps alone.

Numerics of its own (finite differences along the path; the reference shares none with the
reduced models it judges):

* ``ma`` ([analysis.ma]): ma = (1 - (dU/ds_in) / F_in) / (ds_out/ds_in) from the power
  balance F_in ds_in = dU + F_out ds_out, derivatives by second-order differences over the
  steps (``numpy.gradient``).  Input ``driver``: s_in = driver coordinate (rad for a rotation),
  F_in = ``driver.force``/``driver.torque``; input = a node load: s_in = the node's
  displacement along the load, F_in = factor x |load|.
* ``extras["equilibria"]`` (energy analyses): zero crossings of the driving force, stable
  where it rises along the driver (energy minimum), with ``extras["barrier"]``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cases.schema import Scene
from reduced_models.base import Solution


def _coord(scene: Scene, steps: tuple, name: str, direction: str) -> np.ndarray:
    key = f"{name}.{ {'x': 'x', 'y': 'y', 'rot': 'rot'}[direction] }"
    return np.array([s.outputs.get(key, math.nan) for s in steps])


def _ma(scene: Scene, steps: tuple) -> np.ndarray | None:
    a = scene.analysis
    spec = a.ma
    if spec is None or len(steps) < 3:
        return None
    s_out = _coord(scene, steps, spec.output, spec.direction)
    U = np.array([s.energy for s in steps])
    if spec.input == "driver" and a.kind == "energy":
        key = "driver.torque" if a.driver.kind == "rotation" else "driver.force"
        s_in = np.array([s.factor for s in steps])
        if a.driver.kind == "rotation":
            s_in = np.radians(s_in)
        F_in = np.array([s.outputs.get(key, math.nan) for s in steps])
    elif spec.input != "driver" and a.kind == "load":
        ld = next(x for x in scene.loads if x.id == spec.input)
        mag = math.hypot(ld.fx, ld.fy)
        if ld.node is None or mag == 0.0:
            return None
        out = next((o.name for o in scene.outputs if o.node == ld.node), None)
        if out is None:
            return None
        ux, uy = (_coord(scene, steps, out, d) for d in ("x", "y"))
        s_in = (ld.fx * ux + ld.fy * uy) / mag
        F_in = np.array([s.factor for s in steps]) * mag
    else:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.arange(len(steps), dtype=float)
        ds_in, ds_out, dU = (np.gradient(v, t, edge_order=2) for v in (s_in, s_out, U))
        return (1.0 - dU / (F_in * ds_in)) / (ds_out / ds_in)


def _equilibria(scene: Scene, steps: tuple) -> tuple[list, float | None]:
    a = scene.analysis
    key = "driver.torque" if a.driver.kind == "rotation" else "driver.force"
    F = np.array([s.outputs.get(key, math.nan) for s in steps])
    x = np.array([s.factor for s in steps])
    E = np.array([s.energy for s in steps])
    eq = []
    for k in range(len(F) - 1):
        if F[k] == 0.0 or F[k] * F[k + 1] < 0.0:
            w = 0.0 if F[k] == 0.0 else F[k] / (F[k] - F[k + 1])
            rising = (F[k + 1] - F[k]) * (x[k + 1] - x[k]) > 0
            eq.append(
                {
                    "coordinate": float(x[k] + w * (x[k + 1] - x[k])),
                    "kind": "stable" if rising else "unstable",
                    "energy": float(E[k] + w * (E[k + 1] - E[k])),
                }
            )
    stable = [e for e in eq if e["kind"] == "stable"]
    sign = np.sign(x[-1] - x[0]) if len(x) else 0.0
    after = [
        e
        for e in eq
        if stable
        and e["kind"] == "unstable"
        and (e["coordinate"] - stable[0]["coordinate"]) * sign > 0
    ]
    barrier = after[0]["energy"] - stable[0]["energy"] if after else None
    return eq, barrier


def post_process(scene: Scene, sol: Solution) -> Solution:
    """``sol`` with ``ma`` outputs and energy-analysis equilibria added (when they apply)."""
    if not sol.steps:
        return sol
    steps, extras = sol.steps, dict(sol.extras)
    ma = _ma(scene, steps)
    if ma is not None:
        steps = tuple(
            replace(s, outputs={**dict(s.outputs), "ma": float(v)}) for s, v in zip(steps, ma)
        )
    if scene.analysis.kind == "energy" and scene.analysis.driver is not None:
        extras["equilibria"], barrier = _equilibria(scene, steps)
        if barrier is not None:
            extras["barrier"] = barrier
    return replace(sol, steps=steps, extras=extras)
