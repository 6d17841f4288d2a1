"""Speed benchmark record: what each model costs, as ratios measured in one run (issue 12).

``python -m reports.bench [--rounds 7] [--quick] [--suite] [--mech] [--out FILE.md]`` prints (and
writes) a Markdown table.  Every figure is the median CPU time (``time.process_time``, BLAS
pinned to one thread) of the *solve* of one (case, model) pair over ``--rounds`` rounds after
one warm-up, the post-processing (shapes, stress) excluded, and is shown beside a ratio
against its peer measured in the same run: single-beam models against the exact
``elastica``; ``fem-N`` against ``fem-64``; the replay against the static ``fem-N`` of the
same mesh.  Scaling exponents are least-squares slopes of log(time) against log(N) over the
larger N of each family.  Targets (issue 12) are printed beside each figure with met/missed.

The first table (``reports.bench.limits``, issue 22) measures each model against its limit in
the same process: the exact elliptic-integral path for ``elastica``, a plain-float path of the
same PRB chain or BCM segment (shapes and stresses included) for the PRB models and ``bcm``,
the model's solve alone and end to end (``reports.solve``), CPU and wall time.

``--suite`` also runs the default matrix (no report) and gives each model family's share of
its CPU time.  OpenSeesPy (``reports.bench.fem``) is not a dependency; when it imports, the
``fem-16`` / ``fem-64`` comparison against its corotational ``elasticBeamColumn`` is added.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence

import numpy as np

import cases
from cases.schema import Scene
from reports import api
from reports.bench.limits import limits_table
from reports.bench.measure import fit_exponent, ms, post_cost, solve_cost, verdict
from reports.run import timing

SINGLE_BEAM = (
    "cantilever-tip-load",
    "cantilever-inclined-compression",
    "cantilever-inclined-tension",
    "fixed-guided-beam",
    "pure-moment-rollup",
)
SMALL_MODELS = ("elastica", "prb-1r", "prb-3r", "prb-2rpr", "bcm", "cbcm-16")
# (model, target CPU ms on a 20-step path); None: no absolute target
TARGETS_MS = {"prb-1r": 0.3, "prb-3r": 0.5, "bcm": 0.5, "cbcm-16": 2.0}
SCALING = {
    "fem-N": (64, 256, 1024, 4096),
    "cbcm-N": (4, 16, 64, 256),
    "prb-fsm-N": (4, 16, 64, 256),
    "linear-N": (4, 16, 64, 256),
}


# why a small model costs what it costs (printed next to a missed target; the figures beside
# it -- iterations per path and CPU per iteration -- are measured in the same run)
COST_NOTES = {
    "prb-1r": (
        "Newton on one pivot angle (paths.engine on floats); the rest is Step/output assembly"
    ),
    "prb-3r": (
        "plain-float Newton on 3 angles (fused tridiagonal L D L^T): 2-3 evaluations per "
        "step to reach 1e-8 EI/L, ~10 us each in Python, plus ~0.1 ms of Step assembly"
    ),
    "bcm": (
        "plain-float Newton on 4 unknowns with a closed-form tangent solve, 1-3 iterations "
        "per step at ~5 us; as much again goes to step control (predictor, tangent, branch "
        "checks) and ~0.2 ms to the chain's arrays and Steps"
    ),
    "cbcm-16": (
        "general banded continuation at 3-4 iterations per step (the axial forces' predictor "
        "error sets the count); per iteration ~35 numpy calls on 16-segment arrays: segment "
        "Hessians ~45 %, retraction ~14 %, banded LU ~9 %, per-step stability Cholesky ~8 % "
        "(profiled); a p-condensed banded Cholesky Newton would save at most the last two"
    ),
}


def newton_iterations(scene: Scene, name: str) -> int:
    """Newton iterations of one solve (all steps, cuts included)."""
    sol = api.run_model(api.make_model(name, scene), scene, post=False)
    return sum(s.iterations for s in sol.steps)


def single_beam_table(rounds: int, cases_: Sequence[str]) -> tuple[list[str], list[str]]:
    """Rows: one per case, CPU ms and ratio to the elastica per model; and target verdicts
    (the worst case of each model, its Newton iterations and CPU per iteration, and why)."""
    lines = [
        "| case | " + " | ".join(f"{m} ms (x elastica)" for m in SMALL_MODELS) + " |",
        "|---" * (len(SMALL_MODELS) + 1) + "|",
    ]
    worst: dict[str, tuple[float, str]] = {}
    slower_than_elastica: list[str] = []
    for case in cases_:
        scene = cases.load(case)
        res = {m: solve_cost(scene, m, rounds) for m in SMALL_MODELS}
        t_el = res["elastica"][1] if res["elastica"] else None
        cells = []
        for m in SMALL_MODELS:
            r = res[m]
            if r is None:
                cells.append("n/a")
                continue
            ratio = f" ({r[1] / t_el:.2f})" if t_el else ""
            cells.append(f"{ms(r[1])}{ratio}")
            if r[1] > worst.get(m, (0.0, ""))[0]:
                worst[m] = (r[1], case)
            if m == "prb-1r" and t_el and r[1] >= t_el:
                slower_than_elastica.append(case)
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    verdicts = []
    for m, limit in TARGETS_MS.items():
        if m not in worst:
            continue
        t, case = worst[m]
        its = newton_iterations(cases.load(case), m)
        w = t * 1e3
        text = (
            f"- {m} <= {limit} ms: worst {w:.3g} ms ({case}; {its} Newton iterations, "
            f"{t / max(its, 1) * 1e6:.0f} us per iteration all included), {verdict(w, limit)}"
        )
        verdicts.append(text + ("" if w <= limit else f": {COST_NOTES[m]}"))
    verdicts.append(
        "- prb-1r faster than elastica on every single-beam case: "
        + ("met" if not slower_than_elastica else f"missed on {', '.join(slower_than_elastica)}")
    )
    return lines, verdicts


def post_table(rounds: int) -> list[str]:
    """Post-processing (shapes, stress) CPU next to the solve, cantilever-tip-load."""
    scene = cases.load("cantilever-tip-load")
    lines = ["| model | solve ms | post-processing ms |", "|---|---|---|"]
    for m in ("elastica", "prb-1r", "prb-3r", "bcm", "fem-16"):
        r = solve_cost(scene, m, rounds)
        lines.append(f"| {m} | {ms(r[1] if r else None)} | {ms(post_cost(scene, m, rounds))} |")
    return lines


def scaling_table(rounds: int, quick: bool) -> tuple[list[str], list[str]]:
    """CPU ms per N for each family on cantilever-tip-load and the fitted exponents."""
    scene = cases.load("cantilever-tip-load")
    lines = ["| family | N: CPU ms | exponent (larger N) |", "|---|---|---|"]
    verdicts = []
    for fam, ns in SCALING.items():
        ns = ns[:3] if quick else ns
        ts = []
        for n in ns:
            r = solve_cost(scene, fam.replace("-N", f"-{n}"), max(3, rounds // 2))
            ts.append(r[1] if r else math.nan)
        ok = [i for i, t in enumerate(ts) if math.isfinite(t)]
        k = fit_exponent([ns[i] for i in ok[-3:]], [ts[i] for i in ok[-3:]]) if len(ok) > 1 else 0
        cells = ", ".join(f"{n}: {ms(t)}" for n, t in zip(ns, ts))
        lines.append(f"| {fam} | {cells} | {k:.2f} |")
        if fam == "fem-N":
            per = [t / n for n, t in zip(ns, ts)]
            verdicts.append(
                f"- fem-N linear in N (exponent <= 1.15): {k:.2f}, {verdict(k, 1.15)}; "
                f"time per element {ns[-1]} vs {ns[0]}: {per[-1] / per[0]:.2f}x"
            )
    return lines, verdicts


def small_fem_table(rounds: int) -> tuple[list[str], list[str]]:
    """fem-16 against fem-64 (a smaller mesh must not cost more)."""
    scene = cases.load("cantilever-tip-load")
    t = {n: solve_cost(scene, f"fem-{n}", rounds)[1] for n in (16, 32, 64)}
    lines = [
        "| fem-16 ms | fem-32 ms | fem-64 ms | fem-16 / fem-64 |",
        "|---|---|---|---|",
        f"| {ms(t[16])} | {ms(t[32])} | {ms(t[64])} | {t[16] / t[64]:.2f} |",
    ]
    return lines, [f"- fem-16 no slower than fem-64: {t[16] / t[64]:.2f}x"]


def replay_table(rounds: int) -> list[str]:
    """The replay against the static FE of the same mesh on the catalog cantilever."""
    scene = cases.load("cantilever-tip-load")
    r = solve_cost(scene, "replay", max(3, rounds // 3))
    n = api.make_model("replay", scene).n_elements
    f = solve_cost(scene, f"fem-{n}", rounds) if n else None
    ratio = f"{r[1] / f[1]:.1f}" if r and f else "n/a"
    return [
        "| replay ms | static fem-N ms (same mesh) | replay / static |",
        "|---|---|---|",
        f"| {ms(r[1] if r else None)} | {ms(f[1] if f else None)} (N = {n}) | {ratio} |",
    ]


def _wall(cmd: list[str], rounds: int) -> tuple[float, float]:
    """Median wall and CPU (user + sys of the child) seconds of a command, after one call
    that writes the bytecode cache (a user's install has .pyc files; without them every call
    compiles ~30 modules, 0.16 s)."""
    import resource

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    subprocess.run(cmd, check=True, capture_output=True, env=env)
    ws, cs = [], []
    for _ in range(rounds):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env=env)
        ws.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cs.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    return statistics.median(ws), statistics.median(cs)


def cli_wall(rounds: int = 7) -> tuple[tuple[float, float], tuple[float, float]]:
    """Median (wall, CPU) seconds of ``python -m reports.cli solve cantilever-tip-load
    --model prb-3r --json`` and, as its floor in the same run, of ``python -c "import
    numpy"`` (CPU: what the process itself spent, whatever the machine's load)."""
    solve = [sys.executable, "-m", "reports.cli", "solve", "cantilever-tip-load"]
    solve += ["--model", "prb-3r", "--json"]
    return _wall(solve, rounds), _wall([sys.executable, "-c", "import numpy"], rounds)


def suite_shares() -> tuple[list[str], list[str]]:
    """CPU share of each model family in the default matrix (no report, one worker): of the
    first solves (the answers) and of all timed solves (first + repeats); and the verdict on
    the replay's share of all timed solves (target < 20 %)."""
    from reports.run.runner import run_matrix

    scenes = [cases.load(c) for c in cases.catalog_names()]
    with tempfile.TemporaryDirectory() as d:
        res = run_matrix(scenes, out_dir=d, workers=1, render=False, export=None, progress=False)
    first: dict[str, float] = {}
    total: dict[str, float] = {}
    for r in res.payload["results"]:
        t = r.get("timing") or {}
        fam = r["model"].rstrip("0123456789").rstrip("-") or r["model"]
        c1 = t.get("first_cpu_s", 0.0)
        repeated = t.get("total_s", 0.0) > t.get("first_s", 0.0)  # else n_repeats = 1 = first
        reps = t.get("cpu_median_s", 0.0) * t.get("n_repeats", 0) if repeated else 0.0
        first[fam] = first.get(fam, 0.0) + c1
        total[fam] = total.get(fam, 0.0) + c1 + reps
    f_all, t_all = sum(first.values()), sum(total.values())
    lines = [
        "| family | first solves CPU s | share | with timing repeats CPU s | share |",
        "|---|---|---|---|---|",
    ]
    for fam in sorted(total, key=lambda k: -total[k]):
        f, t = first[fam], total[fam]
        lines.append(
            f"| {fam} | {f:.2f} | {100 * f / f_all:.1f} % | {t:.2f} | {100 * t / t_all:.1f} % |"
        )
    share = {fam: 100 * total.get(fam, 0.0) / t_all for fam in ("replay", "elastica-bvp")}
    verdicts = [
        f"- replay share of the default matrix < 20 %: {share['replay']:.1f} %, "
        f"{verdict(share['replay'], 20.0)}",
        f"- elastica-bvp (speed baseline at tol 1e-10) share of the default matrix: "
        f"{share['elastica-bvp']:.1f} %",
    ]
    return lines + [f"| total | {f_all:.2f} | | {t_all:.2f} | |"], verdicts


def opensees_lines(rounds: int) -> list[str]:
    """fem-16 and fem-64 against OpenSeesPy when it is installed (else a note)."""
    from reports.bench import fem_runs as bench_fem

    ops = bench_fem.import_opensees()
    if isinstance(ops, Exception):  # optional: not a FlexBench dependency
        return [f"OpenSeesPy not available ({type(ops).__name__}); see reports/bench/fem.py."]
    lines = []
    scene = bench_fem.bench_scene("cantilever-tip-load", 20)
    cfg = bench_fem.OSConfig()
    # "solve": model building excluded, no stability checks; "e2e": reports.solve with
    # stability at every step against OpenSees' wipe + build + analyze (bench_fem)
    for mode in ("solve", "e2e"):
        for n in (16, 64):
            fb = bench_fem.flexbench_runner(scene, n, mode)
            os_ = bench_fem.opensees_runner(ops, scene, n, cfg, mode)
            t_fb = statistics.median(fb().cpu_s for _ in range(rounds))
            r = t_fb / statistics.median(os_().cpu_s for _ in range(rounds))
            lines.append(
                f"- fem-{n} / OpenSeesPy ({mode}): {r:.2f}x, fem-{n} {t_fb * 1e3:.3g} ms "
                f"({verdict(r, 2.0)} for <= 2x)"
            )
    return lines


def machine() -> str:
    """One line naming the machine and library versions."""
    import scipy

    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,) * 3
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
        f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min); Python "
        f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}"
    )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the Markdown record."""
    p = argparse.ArgumentParser(prog="python -m reports.bench", description=__doc__.split("\n")[0])
    p.add_argument("--rounds", type=int, default=7, help="timed rounds per pair (median)")
    p.add_argument("--quick", action="store_true", help="fewer cases, no N = 4096 / 256")
    p.add_argument("--suite", action="store_true", help="also time the default matrix")
    p.add_argument("--out", help="also write the Markdown record to this file")
    p.add_argument("--mech", action="store_true", help="only the mechanism rows (issue 9)")
    args = p.parse_args(argv)
    timing.pin_blas()
    api.make_model("fem-16")  # imports first: no import inside a timed call
    timing.pin_blas()
    rounds = max(3, args.rounds)
    out = [f"# FlexBench speed record ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})", ""]
    out += [f"Machine: {machine()}. CPU time, median of {rounds} rounds, BLAS on one thread.", ""]
    verdicts: list[str] = []
    if args.mech:
        return _mech_only(out, rounds, args.out)
    out += ["## Each model against its limit (cantilever-tip-load, 20 steps, same process)", ""]
    rows, v = limits_table(rounds)
    out += rows + [""]
    verdicts += v
    out += ["## Single-beam models, 20-step load path (CPU ms; ratio to the elastica)", ""]
    rows, v = single_beam_table(rounds, SINGLE_BEAM[:2] if args.quick else SINGLE_BEAM)
    out += rows + [""]
    verdicts += v
    out += ["## Solve and post-processing (cantilever-tip-load)", ""] + post_table(rounds) + [""]
    out += ["## FE at small N (cantilever-tip-load)", ""]
    rows, v = small_fem_table(rounds)
    out += rows + [""]
    verdicts += v
    out += ["## Scaling with N (cantilever-tip-load)", ""]
    rows, v = scaling_table(rounds, args.quick)
    out += rows + [""]
    verdicts += v
    out += ["## Replay (cantilever-tip-load)", ""] + replay_table(rounds) + [""]
    rows, v = _mech_rows(rounds)
    out += rows
    verdicts += v
    (wall, cpu), (floor, floor_cpu) = cli_wall()
    verdicts.append(
        f"- `solve --model prb-3r` <= 0.15 s CPU: {cpu:.3f} s CPU ({wall:.2f} s wall), "
        f"{verdict(cpu, 0.15)}; `python -c 'import numpy'` alone in the same run: "
        f"{floor_cpu:.3f} s CPU ({floor:.2f} s wall), so {cpu - floor_cpu:.3f} s is ours"
    )
    if args.suite:
        rows, v = suite_shares()
        out += ["## Default matrix: CPU share per family", ""] + rows + [""]
        verdicts += v
    out += ["## OpenSeesPy (optional)", ""] + opensees_lines(rounds) + [""]
    out += ["## Targets", ""] + verdicts + [""]
    text = "\n".join(out)
    print(text)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)
    return 0


def _mech_rows(rounds: int) -> tuple[list[str], list[str]]:
    """The mechanism section (``reports.bench_mech``) and its verdicts."""
    from reports.bench.mech import kkt_path_table, mechanism_table

    rows, v = mechanism_table(rounds)
    return ["## Mechanisms (issue 9)", ""] + rows + [""] + kkt_path_table(rounds) + [""], v


def _mech_only(out: list[str], rounds: int, path: str | None) -> int:
    rows, v = _mech_rows(rounds)
    text = "\n".join(out + rows + ["## Targets", ""] + v + [""])
    print(text)
    if path:
        with open(path, "w") as fh:
            fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
