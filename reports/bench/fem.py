"""Speed benchmark of the FE reference ``fem-N`` against OpenSeesPy (issue 3, "Speed").

Both codes solve the *same* problem: a cantilever meshed with N two-node corotational
Euler-Bernoulli elements, clamped at the root, a dead vertical tip force ramped to its full
value in ``steps`` equal load increments (default 20), Newton at every increment.

* FlexBench: ``fem_reference.models.Runner`` (what ``fem-N`` runs) on the same scene; its load
  control may cut an increment internally, the reported steps are the same 20 factors.
* OpenSeesPy: ``model('basic', '-ndm', 2, '-ndf', 3)``, ``geomTransf('Corotational', 1)``,
  ``element('elasticBeamColumn', ...)`` (same E A, E I, element lengths), ``numberer('RCM')``,
  ``integrator('LoadControl', 1/steps)``, ``algorithm('Newton')``,
  ``test('EnergyIncr', 1e-16 * P * L, 50)``, ``analysis('Static')``, one ``analyze(1)`` per
  increment (the tip displacement is read after each, as FlexBench records each step).
  ``system`` is chosen per mesh as the fastest general solver (``BandGen``, ``UmfPack``,
  ``SparseGeneral``) measured per Newton iteration at 1/10 of the load; FlexBench factorises
  with LAPACK ``dgbtrf`` (the same banded LU that ``BandGen`` calls).

Two timings (both median of ``--repeats`` interleaved runs, after one untimed warm-up):

``solve``  model building excluded for both: FlexBench ``Runner(...)`` is constructed before
           the clock starts (stability checks off: OpenSees computes no eigenvalues) and
           ``Runner.run()`` is timed; OpenSees nodes, elements and analysis objects are
           created before the clock starts and the ``analyze`` loop is timed.
``e2e``    building included for both: ``reports.solve(scene, "fem-N")`` with default
           options (it also checks stability at every step and records shapes) against
           ``wipe`` + model building + the ``analyze`` loop.

If OpenSees' plain Newton does not converge with the requested equal steps (it diverges on
slender meshes with a large EA L^2/EI), that is reported as such and three extra comparisons
are made: OpenSees with ``NewtonLineSearch`` and the same steps; OpenSees Newton with the step
count doubled until it converges; and both codes at the largest lower load (PL^2/EI = 5, 4, 3,
2, 1 times L^2/EI) at which OpenSees Newton converges with the requested steps.

Run (OpenSeesPy is not a FlexBench dependency; install it in a separate environment, it needs
Debian's ``libblas3 liblapack3``)::

    python3 -m venv --system-site-packages /tmp/benchenv
    /tmp/benchenv/bin/pip install openseespy
    /tmp/benchenv/bin/python -m reports.bench.fem --elements 64 1000 --steps 20 --repeats 5
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import statistics
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cases.schema import Scene
from reports.bench.fem_runs import (
    OSConfig,
    Run,
    bench_scene,
    cantilever_of,
    flexbench_runner,
    import_opensees,
    opensees_runner,
    scale_loads,
)

DEFAULT_CASES = ("flexure", "cantilever-tip-load")
OS_SYSTEMS = ("BandGen", "UmfPack", "SparseGeneral")
LOWER_LOADS = (0.5, 0.4, 0.3, 0.2, 0.1)
MAX_STEP_DOUBLINGS = 5  # 20 -> 640 equal steps


# -- comparisons --------------------------------------------------------------------------------


@dataclass
class Row:
    """One comparison line of the table."""

    case: str
    n: int
    load: float  # PL^2/EI
    mode: str
    os_config: str
    fb: dict = field(default_factory=dict)
    os: dict = field(default_factory=dict)
    ratio_wall: float | None = None
    ratio_cpu: float | None = None
    tip_diff: float | None = None
    note: str = ""


def _summary(runs: list[Run]) -> dict:
    last = runs[-1]
    ok = all(r.status == "converged" for r in runs)
    return {
        "status": "converged" if ok else "failed",
        "iterations": last.iterations,
        "wall_s": statistics.median(r.wall_s for r in runs),
        "cpu_s": statistics.median(r.cpu_s for r in runs),
        "wall_all_s": [r.wall_s for r in runs],
        "tip": last.tip,
        "message": next((r.message for r in runs if r.message), ""),
    }


def compare(
    ops: Any, scene: Scene, n: int, cfg: OSConfig, mode: str, repeats: int, note: str = ""
) -> Row:
    """Interleaved timed runs of both codes (one warm-up each) and their agreement."""
    c = cantilever_of(scene)
    fb_run = flexbench_runner(scene, n, mode)
    os_run = opensees_runner(ops, scene, n, cfg, mode)
    fb_runs, os_runs = [], []
    for k in range(repeats + 1):  # k = 0 is the warm-up
        fb, osr = fb_run(), os_run()
        if k:
            fb_runs.append(fb)
            os_runs.append(osr)
    fb_s, os_s = _summary(fb_runs), _summary(os_runs)
    row = Row(scene.name, n, c.load_scale, mode, cfg.label(), fb_s, os_s, note=note)
    if row.fb["status"] == row.os["status"] == "converged":
        row.ratio_wall = row.fb["wall_s"] / row.os["wall_s"]
        row.ratio_cpu = row.fb["cpu_s"] / row.os["cpu_s"]
        d = np.subtract(row.fb["tip"], row.os["tip"])
        # translations relative to L, rotation in rad
        row.tip_diff = float(max(abs(d[0]) / c.length, abs(d[1]) / c.length, abs(d[2])))
    return row


def pick_system(ops: Any, scene: Scene, n: int, base: OSConfig) -> tuple[str, dict]:
    """Fastest OpenSees general solver, by wall time per Newton iteration at 1/10 load."""
    light = scale_loads(scene, 0.1)
    per_iter: dict[str, float] = {}
    for system in OS_SYSTEMS:
        cfg = dataclasses.replace(base, system=system)
        try:
            runs = [opensees_runner(ops, light, n, cfg, "solve")() for _ in range(2)]
        except Exception:  # noqa: BLE001 - a solver OpenSees lacks is just not a candidate
            continue
        best = min(runs, key=lambda r: r.wall_s)
        if best.status == "converged" and best.iterations:
            per_iter[system] = best.wall_s / best.iterations
    if not per_iter:
        return base.system, per_iter
    return min(per_iter, key=per_iter.get), per_iter


def _os_converges(ops: Any, scene: Scene, n: int, cfg: OSConfig) -> bool:
    return opensees_runner(ops, scene, n, cfg, "solve")().status == "converged"


def bench_case(
    ops: Any, case: str, n: int, steps: int, repeats: int, system: str, log: Callable[[str], None]
) -> tuple[list[Row], dict]:
    """All comparisons for one case and one mesh."""
    scene = bench_scene(case, steps)
    base = OSConfig(steps=steps)
    info: dict[str, Any] = {}
    if system == "auto":
        system, per_iter = pick_system(ops, scene, n, base)
        info["os_system_per_iteration_s"] = per_iter
        log(
            f"  OpenSees system: {system} (s/iteration at 1/10 load: "
            + ", ".join(f"{k} {v * 1e6:.0f} us" for k, v in per_iter.items())
            + ")"
        )
    info["os_system"] = system
    base = dataclasses.replace(base, system=system)
    rows: list[Row] = []

    def add(sc: Scene, cfg: OSConfig, mode: str = "solve", note: str = "") -> None:
        rows.append(compare(ops, sc, n, cfg, mode, repeats, note))
        log("  " + format_row(rows[-1]))

    add(scene, base, "solve")
    add(scene, base, "e2e")
    if rows[0].os["status"] == "converged":
        return rows, info
    # OpenSees' plain Newton failed with the requested equal steps: extra, honest comparisons.
    add(scene, dataclasses.replace(base, algorithm=("NewtonLineSearch",)), note="line search")
    for k in range(1, MAX_STEP_DOUBLINGS + 1):
        more = dataclasses.replace(base, steps=steps * 2**k)
        if _os_converges(ops, scene, n, more):
            add(scene, more, note=f"OpenSees Newton needs {more.steps} equal steps")
            break
    else:
        info["os_newton_max_steps_failed"] = steps * 2**MAX_STEP_DOUBLINGS
        log(f"  OpenSees Newton still fails with {steps * 2**MAX_STEP_DOUBLINGS} equal steps")
    for f in LOWER_LOADS:
        if _os_converges(ops, scale_loads(scene, f), n, base):
            add(scale_loads(scene, f), base, note="largest lower load OpenSees Newton solves")
            break
    else:
        log(f"  OpenSees Newton fails with {steps} steps even at {LOWER_LOADS[-1]} x load")
    return rows, info


# -- output -------------------------------------------------------------------------------------

HEADER = (
    f"{'case':22s} {'N':>5s} {'PL2/EI':>6s} {'mode':5s} {'OpenSees config':34s} "
    f"{'FB s':>8s} {'FB it':>5s} {'OS s':>8s} {'OS it':>5s} {'FB/OS':>6s} {'cpu':>6s} "
    f"{'|dtip|':>8s}"
)


def _t(d: dict) -> str:
    return f"{d['wall_s']:8.4f}" if d["status"] == "converged" else "  FAILED"


def format_row(r: Row) -> str:
    """One table line (times = median wall seconds; ratio = FlexBench / OpenSees)."""
    rw = f"{r.ratio_wall:6.2f}" if r.ratio_wall is not None else "     -"
    rc = f"{r.ratio_cpu:6.2f}" if r.ratio_cpu is not None else "     -"
    td = f"{r.tip_diff:8.1e}" if r.tip_diff is not None else "       -"
    line = (
        f"{r.case:22s} {r.n:5d} {r.load:6.2f} {r.mode:5s} {r.os_config:34s} "
        f"{_t(r.fb)} {r.fb['iterations']:5d} {_t(r.os)} {r.os['iterations']:5d} {rw} {rc} {td}"
    )
    return line + (f"  ({r.note})" if r.note else "")


def verdicts(rows: list[Row]) -> list[str]:
    """The issue's targets: N = 64 within 2x of OpenSees, N = 1000 faster than OpenSees."""
    out = []
    for r in rows:
        if r.mode != "solve" or r.n not in (64, 1000):
            continue
        if r.ratio_wall is None:
            out.append(
                f"n/a    {r.case} N={r.n} PL2/EI={r.load:g} vs {r.os_config}: FlexBench "
                f"{r.fb['status']}, OpenSees {r.os['status']} ({r.os['message']})"
            )
            continue
        goal = 2.0 if r.n == 64 else 1.0
        ok = r.ratio_wall <= goal if r.n == 64 else r.ratio_wall < goal
        rel = "<=" if r.n == 64 else "<"
        out.append(
            f"{'MET ' if ok else 'MISSED'} {r.case} N={r.n} PL2/EI={r.load:g} vs "
            f"{r.os_config}: FB/OS = {r.ratio_wall:.2f} (target {rel} {goal:g})"
            + (f" [{r.note}]" if r.note else "")
        )
    return out


def environment(ops: Any) -> dict:
    """Versions and machine state recorded with the figures."""
    import scipy

    try:
        from importlib.metadata import version

        osv = version("openseespy")
    except Exception:  # noqa: BLE001
        osv = "?"
    return {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "openseespy": osv,
        "opensees": str(ops.version()) if hasattr(ops, "version") else "?",
        "cpus": os.cpu_count(),
        "loadavg_at_start": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "platform": platform.platform(),
    }


def main(argv: list[str] | None = None) -> int:
    """``python -m reports.bench.fem [--elements 64 1000] [--steps 20] [--repeats N]
    [--cases ...] [--system auto|BandGen|...] [--json OUT]``; exit 2 without OpenSeesPy."""
    p = argparse.ArgumentParser(
        prog="python -m reports.bench.fem",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--elements", type=int, nargs="+", default=[64, 1000])
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument(
        "--cases",
        nargs="+",
        default=list(DEFAULT_CASES),
        help="'flexure' (PL^2/EI = 10, EA L^2/EI = 1.2e5) and/or catalog cantilever cases",
    )
    p.add_argument("--system", default="auto", help="OpenSees system (default: fastest)")
    p.add_argument("--json", dest="json_out", default=None, help="write all figures here")
    a = p.parse_args(argv)
    if min(a.elements) < 1 or a.steps < 1 or a.repeats < 1:
        print("bench_fem: --elements, --steps and --repeats must be positive", file=sys.stderr)
        return 2
    ops = import_opensees()
    if isinstance(ops, Exception):
        print(
            f"bench_fem: OpenSeesPy is not available ({type(ops).__name__}: {ops}); install "
            "it in a benchmark venv: pip install openseespy (+ Debian libblas3 liblapack3)",
            file=sys.stderr,
        )
        return 2
    ops.logFile(os.devnull, "-noEcho")  # OpenSees' own convergence chatter
    env = environment(ops)
    print(
        f"FlexBench fem-N vs OpenSeesPy {env['openseespy']}: {a.steps} equal load steps, "
        f"median of {a.repeats} (wall s), load average at start {env['loadavg_at_start']}"
    )
    print(
        "mode solve = model building excluded for both; e2e = included for both "
        "(FlexBench e2e = reports.solve(scene, 'fem-N'), with per-step stability)"
    )
    print(HEADER)
    rows: list[Row] = []
    infos: dict[str, dict] = {}
    for case in a.cases:
        for n in a.elements:
            try:
                r, info = bench_case(ops, case, n, a.steps, a.repeats, a.system, print)
            except (ValueError, KeyError) as exc:
                print(f"bench_fem: case {case!r}: {exc}", file=sys.stderr)
                return 2
            rows += r
            infos[f"{case}/{n}"] = info
    print("\nTargets (issue 3, solve-only wall time):")
    for line in verdicts(rows):
        print("  " + line)
    if a.json_out:
        with open(a.json_out, "w") as fh:
            json.dump(
                {
                    "environment": env,
                    "steps": a.steps,
                    "repeats": a.repeats,
                    "meshes": infos,
                    "rows": [dataclasses.asdict(r) for r in rows],
                },
                fh,
                indent=1,
            )
        print(f"figures written to {a.json_out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
