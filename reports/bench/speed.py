"""Speed benchmark record: what each model costs, as ratios measured in one process.

``python -m reports.bench [--rounds 7] [--quick] [--suite] [--mech] [--out FILE.md]
[--readme README.md]`` prints (and writes) a Markdown record: CPU time (``time.process_time``)
and wall time, median over ``--rounds`` rounds after one warm-up, BLAS pinned to one thread
(threadpoolctl), the load average printed at the start and the end.

``readme_sections`` (the one function behind README's speed table; ``--readme PATH`` runs only
it and rewrites the block between ``README_START`` and ``README_END`` in PATH) measures each
model against its limit (``reports.bench.limits``: the exact elliptic-integral path for
``elastica``, a plain-float path of the same PRB chain or BCM segment for the PRB models and
``bcm``, solve alone and end to end), ``fem-N`` end to end against OpenSeesPy at N = 16 ...
4096 (``reports.bench.opensees``; FE column only without it), the replay against the static
FE on the same mesh, and the ``flexbench solve`` start beside ``import numpy``; every issue-22
target's verdict is printed with the figure it judges.

The full record adds single-beam paths against the exact ``elastica``, post-processing,
``fem-16`` against ``fem-64``, scaling exponents (least-squares slopes of log time against log
N over the larger N) and the mechanism rows; ``--suite`` also runs the default matrix (no
report) and gives each model family's share of its CPU time.
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
# issue 22: cbcm-16 <= 1.5 ms; the PRB models, bcm, elastica and linear-8 are judged against
# their limits in ``limits_table`` (issue 12's absolute PRB/BCM targets are gone)
TARGETS_MS = {"cbcm-16": 1.5}
REPLAY_MAX = 3.0  # replay on a 20-increment path / static fem-N on the same mesh
CLI_MAX_S = 0.15  # ``flexbench solve`` of a reduced model, CPU s
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
        "Newton in the chain's own coordinates (reduced_models.beam.chain_path) at 2-3 "
        "iterations per step; per iteration ~75 numpy calls on 16-long arrays (segment "
        "law, closed-form condensation of the 3x3 segment blocks, one tridiagonal dptsv)"
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


def replay_table(rounds: int) -> tuple[list[str], list[str]]:
    """The replay against the static FE of the same mesh on the catalog cantilever (20 load
    steps), solve CPU; and the verdict (<= ``REPLAY_MAX``)."""
    scene = cases.load("cantilever-tip-load")
    r = solve_cost(scene, "replay", max(3, rounds // 3))
    n = api.make_model("replay", scene).n_elements
    f = solve_cost(scene, f"fem-{n}", rounds) if n else None
    ratio = r[1] / f[1] if r and f else None
    cell = "n/a" if ratio is None else f"{ratio:.1f}"
    rows = [
        "| replay CPU ms | static fem-N CPU ms (same mesh) | replay / static |",
        "|---|---|---|",
        f"| {ms(r[1] if r else None)} | {ms(f[1] if f else None)} (N = {n}) | {cell} |",
    ]
    v = "not measured" if ratio is None else f"{ratio:.1f}x, {verdict(ratio, REPLAY_MAX)}"
    return rows, [f"- replay / static fem-{n} on the same 20-step path <= {REPLAY_MAX:g}x: {v}"]


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


def machine() -> str:
    """One line naming the machine and library versions."""
    import scipy

    load = os.getloadavg() if hasattr(os, "getloadavg") else (math.nan,) * 3
    return (
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
        f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (1 / 5 / 15 min); Python "
        f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}"
    )


def cli_verdict() -> str:
    """The ``flexbench solve`` target's verdict line, with numpy's import as its floor."""
    (wall, cpu), (floor, floor_cpu) = cli_wall()
    return (
        f"- `flexbench solve cantilever-tip-load --model prb-3r --json` <= {CLI_MAX_S:g} s CPU: "
        f"{cpu:.3f} s CPU ({wall:.2f} s wall), {verdict(cpu, CLI_MAX_S)}; "
        f"`python -c 'import numpy'` alone in the same run: {floor_cpu:.3f} s CPU "
        f"({floor:.2f} s wall), so {cpu - floor_cpu:.3f} s is FlexBench's"
    )


LIMITS_TITLE = "Each model against its limit (cantilever-tip-load, 20 steps)"


def readme_sections(rounds: int) -> tuple[list[tuple[str, list[str]]], list[str]]:
    """The sections README's speed table shows (each model against its limit, fem-N against
    OpenSeesPy, the replay against the static FE) and every issue-22 verdict they and the
    CLI start give: the one function both ``--readme`` and the full record use."""
    from reports.bench.opensees import opensees_table

    sections, verdicts = [], []
    for title, make in (
        (LIMITS_TITLE, limits_table),
        ("fem-N against OpenSeesPy, end to end (cantilever-tip-load, PL^2/EI = 10)",
         opensees_table),
        ("Replay against the static FE (cantilever-tip-load)", replay_table),
    ):  # fmt: skip
        rows, v = make(rounds)
        sections.append((title, rows))
        verdicts += v
    verdicts.append(cli_verdict())
    return sections, verdicts


def markdown(head: list[str], sections: list[tuple[str, list[str]]], verdicts: list[str]) -> str:
    """The record as Markdown: header lines, one titled table per section, the verdicts."""
    out = list(head)
    for title, rows in sections:
        out += [f"#### {title}", "", *rows, ""]
    return "\n".join(out + ["#### Targets (issue 22)", "", *verdicts, ""])


README_START = "<!-- speed-record: python -m reports.bench --readme README.md -->"
README_END = "<!-- /speed-record -->"


def write_readme(path: str, text: str) -> None:
    """Replace the block between ``README_START`` and ``README_END`` in ``path``."""
    with open(path, encoding="utf-8") as fh:
        doc = fh.read()
    i, j = doc.find(README_START), doc.find(README_END)
    if i < 0 or j < i:
        raise SystemExit(f"{path}: no {README_START!r} ... {README_END!r} block")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(doc[: i + len(README_START)] + "\n\n" + text + "\n" + doc[j:])


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the Markdown record."""
    p = argparse.ArgumentParser(prog="python -m reports.bench", description=__doc__.split("\n")[0])
    p.add_argument("--rounds", type=int, default=7, help="timed rounds per pair (median)")
    p.add_argument("--quick", action="store_true", help="fewer cases, no N = 4096 / 256")
    p.add_argument("--suite", action="store_true", help="also time the default matrix")
    p.add_argument("--out", help="also write the Markdown record to this file")
    p.add_argument("--mech", action="store_true", help="only the mechanism rows (issue 9)")
    p.add_argument("--readme", help="only README's speed table, written into this file")
    p.add_argument("--limits", action="store_true", help="only the models-against-limits table")
    args = p.parse_args(argv)
    timing.pin_blas()
    api.make_model("fem-16")  # imports first: no import inside a timed call
    timing.pin_blas()
    rounds = max(3, args.rounds)
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    head = [f"Speed record of {when}. Machine: {machine()}. CPU and wall time, median of "
            f"{rounds} rounds (fewer for calls over 0.2 s; the limits table times each model's "
            "limit, solve and end-to-end call in turn, up to 25 rounds for sub-millisecond "
            "calls), BLAS on one thread (threadpoolctl).",
            ""]  # fmt: skip
    if args.mech:
        return _mech_only(["# FlexBench speed record", "", *head], rounds, args.out)
    if args.limits:  # the few seconds a change to a small model needs, not the whole record
        rows, verdicts = limits_table(rounds)
        head[0] += f" Load average: {_load()}."
        print(markdown(head, [(LIMITS_TITLE, rows)], verdicts))
        return 0
    sections, verdicts = readme_sections(rounds)
    if not args.readme:
        sections += _more_sections(rounds, args.quick, verdicts)
    if args.suite:
        rows, v = suite_shares()
        sections.append(("Default matrix: CPU share per family", rows))
        verdicts += v
    head[0] += f" Load average at the end: {_load()}."
    text = markdown(head, sections, verdicts)
    print(text)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)
    if args.readme:
        write_readme(args.readme, text)
    return 0


def _load() -> str:
    la = os.getloadavg()
    return f"{la[0]:.1f} / {la[1]:.1f} / {la[2]:.1f}"


def _more_sections(rounds: int, quick: bool, verdicts: list[str]) -> list[tuple[str, list[str]]]:
    """The record's other tables (single-beam paths, post-processing, small and scaled FE,
    mechanisms); their verdicts are appended to ``verdicts``."""
    out = []
    rows, v = single_beam_table(rounds, SINGLE_BEAM[:2] if quick else SINGLE_BEAM)
    out.append(("Single-beam models, 20-step load path (CPU ms; ratio to the elastica)", rows))
    verdicts += v
    out.append(("Solve and post-processing (cantilever-tip-load)", post_table(rounds)))
    rows, v = small_fem_table(rounds)
    out.append(("FE at small N (cantilever-tip-load)", rows))
    verdicts += v
    rows, v = scaling_table(rounds, quick)
    out.append(("Scaling with N (cantilever-tip-load)", rows))
    verdicts += v
    rows, v = _mech_rows(rounds)
    out.append(("Mechanisms (issue 9)", rows))
    verdicts += v
    return out


def _mech_rows(rounds: int) -> tuple[list[str], list[str]]:
    """The mechanism section (``reports.bench_mech``) and its verdicts."""
    from reports.bench.mech import kkt_path_table, mechanism_table

    rows, v = mechanism_table(rounds)
    return rows + [""] + kkt_path_table(rounds), v


def _mech_only(out: list[str], rounds: int, path: str | None) -> int:
    rows, v = _mech_rows(rounds)
    text = markdown(out, [("Mechanisms (issue 9)", rows)], v)
    print(text)
    if path:
        with open(path, "w") as fh:
            fh.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
