"""Convergence of the thesis's force method in its increment factor (issue 10, item 7).

The thesis chose its Part 1 force fraction gamma = 0.005 "by hit-and-trial".  Each increment
moves the joints along the first-order mechanism modes (d = M phi), so every increment leaves
a second-order length error ~|d|^2 / L; the listing re-places joints II..V along the chain but
not bar VI or the boom, and Part 1 stops at the first increment past the deployed length
(overshoot up to one increment).  Both errors are proportional to the increment size, i.e. to
gamma.  Measured on Configuration 4 (``python -m reports.verdicts.thesis_study``): the error of the
final state is the overshoot alone (the thesis's Part 2 then finds the exact equilibrium at
the length it overshot to, up to a drift that converges at second order, 5e-8 m at 0.005);
the overshoot is bounded by the last increment (first order in gamma) but lands anywhere
below it, so the error is not monotone in gamma: 0.096 mm at the thesis's 0.005.

``increment_convergence(scene, factors)`` measures it against ``kinetostatic`` (the exact
equilibrium of the same idealised scene, constrained Newton to 1e-10) and returns a table; run
``python -m reports.verdicts.thesis_study [CASE] [OUT.png]`` for the table and the figure.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from cases.schema import Scene

FACTORS = (0.08, 0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125)


def _positions(sol: object) -> dict[str, float]:
    return {k: v for k, v in sol.steps[-1].outputs.items() if k.endswith((".x", ".y"))}


def increment_convergence(scene: Scene, factors: Sequence[float] = FACTORS) -> dict:
    """Final-state error of ``thesis-force-method`` against ``kinetostatic`` per Part 1
    factor: ``factor``, ``error_m``, ``increments``, ``overshoot_m``, ``last_increment_m``,
    ``drift_m`` lists, and ``order_last_increment`` / ``order_drift`` (observed orders
    between successive halvings)."""
    from reduced_models.thesis.force_method import ThesisForceMethod
    from reports import api

    exact = api.solve(scene, "kinetostatic")
    if exact.status != "converged" or exact.steps[-1].factor != 2.0:
        return {"error": f"kinetostatic: {exact.message}"}
    ref = _positions(exact)
    keys = ("factor", "error_m", "increments", "overshoot_m", "last_increment_m", "drift_m")
    out: dict[str, list] = {k: [] for k in keys}
    for f in factors:
        sol = ThesisForceMethod(delta1=f).solve(scene)
        if not sol.ok:
            continue
        pos = _positions(sol)
        lengths = sol.extras["part1_boom_length"]
        # the exact equilibrium at the length Part 1 actually stopped at: what is left is
        # the relaxation's own error (second-order drift of the bars it does not re-place)
        at = replace(scene, booms=(replace(scene.booms[0], length=lengths[-1]),))
        same = _positions(api.solve(at, "kinetostatic"))
        out["factor"].append(f)
        out["error_m"].append(max(abs(pos[k] - ref[k]) for k in ref))
        out["increments"].append(sol.extras["part1_increments"])
        out["overshoot_m"].append(lengths[-1] - scene.booms[0].length)
        out["last_increment_m"].append(lengths[-1] - lengths[-2])
        out["drift_m"].append(max(abs(pos[k] - same[k]) for k in same))
    fs = np.array(out["factor"])
    for key in ("last_increment_m", "drift_m"):
        e = np.array(out[key])
        order = np.log(e[:-1] / e[1:]) / np.log(fs[:-1] / fs[1:]) if len(e) > 1 else []
        out[f"order_{key[:-2]}"] = list(map(float, order))
    return out


def figure(study: dict, path: str | Path) -> Path:
    """Log-log error against factor, the thesis's 0.005 marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4))
    f, e = np.array(study["factor"]), np.array(study["error_m"]) * 1e3
    ax.loglog(f, e, "o-", label="final joints vs exact (max)")
    ax.loglog(f, np.array(study["last_increment_m"]) * 1e3, "s--", label="last boom increment")
    ax.loglog(f, np.array(study["drift_m"]) * 1e3, "^-", label="vs exact at reached length")
    ax.loglog(f, e[-1] * f / f[-1], "k:", label="first order")
    if 0.005 in study["factor"]:
        i = study["factor"].index(0.005)
        ax.annotate(f"thesis: {e[i]:.3g} mm", (0.005, e[i]), textcoords="offset points",
                    xytext=(8, -14))  # fmt: skip
    ax.set_xlabel("Part 1 force fraction gamma")
    ax.set_ylabel("final state vs exact equilibrium (mm)")
    ax.legend()
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def main(argv: Sequence[str]) -> int:
    """``python -m reports.verdicts.thesis_study [CASE] [OUT.png]``: print the table, write the
    figure."""
    import cases

    scene = cases.load(argv[0] if argv else "thesis-sixbar-config4")
    study = increment_convergence(scene)
    if "error" in study:
        print(study["error"], file=sys.stderr)
        return 1
    print("gamma     increments error(mm)  overshoot(mm) last-incr(mm) drift(mm)")
    rows = zip(
        study["factor"], study["increments"], study["error_m"], study["overshoot_m"],
        study["last_increment_m"], study["drift_m"],
    )  # fmt: skip
    for f, n, e, o, li, d in rows:
        print(f"{f:<9g} {n:<10d} {e * 1e3:<10.4g} {o * 1e3:<13.4g} {li * 1e3:<13.4g} {d * 1e3:.3g}")
    if len(argv) > 1:
        print(figure(study, argv[1]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
