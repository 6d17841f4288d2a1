"""``fem-N`` against OpenSeesPy at N = 16 ... 4096, end to end, as ratios in one process.

Both codes solve ``cantilever-tip-load`` (PL^2/EI = 10) with 20 equal load steps on N
two-node corotational elements (``reports.bench.fem_runs``): ``reports.solve(scene,
"fem-N")`` as a user calls it (build, stability at every step, records) against OpenSees'
``wipe`` + model building + ``analyze`` loop.  OpenSees gets the algorithm it needs to reach
the full load, tried in this order and said in the table: ``Newton`` with 20 steps,
``NewtonLineSearch`` with 20 steps, then ``Newton`` and ``NewtonLineSearch`` with the step
count doubled up to ``MAX_STEPS``.  Targets (issue 22): fem-N end to end <= 2x OpenSees at
N = 16 and <= 1x from N = 64 up.  OpenSeesPy is not a FlexBench dependency (``pip install
openseespy`` and Debian ``libblas3 liblapack3``); without it the table has the FE column only.
"""

from __future__ import annotations

import os
import statistics
import tempfile
from typing import Any

from reports.bench import fem_runs as F
from reports.bench.measure import verdict

NS = (16, 64, 256, 1024, 4096)
MAX_STEPS = 640


def _rounds(n: int, rounds: int) -> int:
    """Fewer rounds for the big meshes (one call is 0.1-1 s)."""
    return rounds if n <= 256 else max(3, rounds // 3)


def _median(call: Any, k: int) -> tuple[float, float, Any]:
    """(median CPU s, median wall s, last run) of ``k`` calls after one warm-up."""
    call()
    runs = [call() for _ in range(k)]
    cpu = statistics.median(r.cpu_s for r in runs)
    return cpu, statistics.median(r.wall_s for r in runs), runs[-1]


def _opensees_config(ops: Any, scene: Any, n: int) -> F.OSConfig | None:
    """The first OpenSees setting (see module docstring) that reaches the full load."""
    steps = 20
    while steps <= MAX_STEPS:
        for algo in ("Newton", "NewtonLineSearch"):
            cfg = F.OSConfig(algorithm=(algo,), steps=steps)
            if F.opensees_runner(ops, scene, n, cfg, "e2e")().status == "converged":
                return cfg
        steps *= 2
    return None


def opensees_table(rounds: int) -> tuple[list[str], list[str]]:
    """Rows per N (fem-N and OpenSees CPU / wall ms, ratio, OpenSees' setting) and the
    target verdicts; the FE column alone when OpenSeesPy does not import."""
    ops = F.import_opensees()
    have = not isinstance(ops, Exception)
    if have:  # OpenSees' convergence chatter to a file, not the table
        ops.logFile(os.path.join(tempfile.gettempdir(), "flexbench-opensees.log"), "-noEcho")
    scene = F.bench_scene("cantilever-tip-load", 20)
    lines = [
        "| N | fem-N end to end CPU / wall ms | Newton iterations | OpenSeesPy CPU / wall ms "
        "| OpenSees setting (iterations) | fem-N / OpenSees (CPU) | target |",
        "|---|---|---|---|---|---|---|",
    ]
    verdicts = []
    for n in NS:
        k = _rounds(n, rounds)
        fb_cpu, fb_wall, fb = _median(F.flexbench_runner(scene, n, "e2e"), k)
        os_cell, cfg_cell, ratio_cell, target = "n/a", "not installed", "n/a", "n/a"
        limit = 2.0 if n < 64 else 1.0
        if have:
            cfg = _opensees_config(ops, scene, n)
            if cfg is None:
                cfg_cell = f"no setting reached the load within {MAX_STEPS} steps"
            else:
                os_cpu, os_wall, orun = _median(F.opensees_runner(ops, scene, n, cfg, "e2e"), k)
                os_cell = f"{os_cpu * 1e3:.3g} / {os_wall * 1e3:.3g}"
                cfg_cell = f"{cfg.algorithm[0]}, {cfg.steps} steps ({orun.iterations})"
                ratio = fb_cpu / os_cpu
                ratio_cell = f"{ratio:.2f}"
                target = f"<= {limit:g}x: {verdict(ratio, limit)}"
                verdicts.append(f"- fem-{n} end to end <= {limit:g}x OpenSeesPy: {ratio:.2f}x, "
                                f"{verdict(ratio, limit)}")  # fmt: skip
        lines.append(
            f"| {n} | {fb_cpu * 1e3:.3g} / {fb_wall * 1e3:.3g} | {fb.iterations} | {os_cell} "
            f"| {cfg_cell} | {ratio_cell} | {target} |"
        )
    if not have:
        verdicts.append(f"- fem-N vs OpenSeesPy: not measured ({type(ops).__name__}: {ops})")
    return lines, verdicts
