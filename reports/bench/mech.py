"""Mechanism rows of the speed record (``python -m reports.bench``; issue 9, "Speed").

* the 26-DOF parallel guide (every beam a 2-segment CBCM), whole 20-step load analysis:
  ``cbcm-2`` against ``fem-auto`` on the same scene, in the same run (targets: <= 10 ms and
  >= 20x faster than fem-auto);
* DAS-2D Ex. 4's energy plot at 121 driver positions with ``linear-4`` (target < 50 ms);
* the dense and the sparse KKT path of the assembler side by side at rising N on the guide
  (``mechanism.kkt.SPARSE_FROM`` chooses between them).

Every figure is the solve's CPU time as the runner times it (``measure.solve_cost``: median
over the rounds after a warm-up, BLAS on one thread, post-processing excluded).
"""

from __future__ import annotations

import cases
from reduced_models.mechanism import kkt
from reports.bench.measure import ms, solve_cost, verdict

GUIDE = "das2d-parallel-guide-26dof"
EX4 = "das2d-ex4-bistable-fourbar"
GUIDE_MS, GUIDE_RATIO, EX4_MS = 10.0, 20.0, 50.0  # issue 9 targets
PATHS = ("cbcm-16", "cbcm-32", "prb-fsm-128")  # dense vs sparse on the guide (258-530)


def mechanism_table(rounds: int) -> tuple[list[str], list[str]]:
    """Rows (guide, fem-auto, ratio, Ex. 4) and the target verdicts."""

    guide = cases.load(GUIDE)
    t_c = solve_cost(guide, "cbcm-2", rounds)
    t_f = solve_cost(guide, "fem-auto", max(3, rounds // 2))
    t_4 = solve_cost(cases.load(EX4), "linear-4", rounds)
    med = {k: (t[1] if t else None) for k, t in (("c", t_c), ("f", t_f), ("4", t_4))}
    ratio = med["f"] / med["c"] if med["c"] and med["f"] else None
    rat = f"{ratio:.1f}x" if ratio else "n/a"
    lines = [
        "| figure | CPU ms, median (min - max) | target |",
        "|---|---|---|",
        f"| {GUIDE}, cbcm-2, 20-step load | {_span(t_c)} | <= {GUIDE_MS:g} ms |",
        f"| {GUIDE}, fem-auto, same scene | {_span(t_f)} | |",
        f"| fem-auto / cbcm-2 (medians) | {rat} | >= {GUIDE_RATIO:g}x |",
        f"| {EX4}, linear-4, 121 driver positions | {_span(t_4)} | < {EX4_MS:g} ms |",
    ]
    verdicts = []
    if med["c"] is not None:
        c = med["c"] * 1e3
        verdicts.append(
            f"- 26-DOF guide cbcm-2 <= {GUIDE_MS:g} ms: {c:.3g} ms, {verdict(c, GUIDE_MS)}"
        )
    if ratio:
        met = "met" if ratio >= GUIDE_RATIO else f"missed ({ratio / GUIDE_RATIO:.2g} of it)"
        verdicts.append(
            f"- 26-DOF guide >= {GUIDE_RATIO:g}x faster than fem-auto: {ratio:.1f}x "
            f"(fem-auto {ms(med['f'])} ms), {met}"
        )
    if med["4"] is not None:
        e = med["4"] * 1e3
        verdicts.append(
            f"- Ex. 4 energy plot (121 points, linear-4) < {EX4_MS:g} ms: {e:.3g} ms, "
            f"{verdict(e, EX4_MS)}"
        )
    return lines, verdicts


def kkt_path_table(rounds: int) -> list[str]:
    """Dense against sparse KKT on the guide at rising N (the crossover behind
    ``SPARSE_FROM``)."""

    guide = cases.load(GUIDE)
    lines = [
        f"KKT path by size: sparse from {kkt.SPARSE_FROM} unknowns (free + constraint rows).",
        "",
        "| model on the guide | dense CPU ms | sparse CPU ms |",
        "|---|---|---|",
    ]
    keep = kkt.SPARSE_FROM
    try:
        for name in PATHS:
            cells = []
            for sf in (10**9, 0):
                kkt.SPARSE_FROM = sf
                t = solve_cost(guide, name, max(3, rounds // 3))
                cells.append(ms(t[1] if t else None))
            lines.append(f"| {name} | {cells[0]} | {cells[1]} |")
    finally:
        kkt.SPARSE_FROM = keep
    return lines


def _span(t: tuple[float, float, float] | None) -> str:
    if t is None:
        return "n/a"
    return f"{t[1] * 1e3:.3g} ({t[0] * 1e3:.3g} - {t[2] * 1e3:.3g})"
