"""The ``flexbench`` command line.

::

    flexbench cases                          list the catalog (name, title, tags)
    flexbench models                         list the registry with each model's card summary
    flexbench solve CASE --model M [--json]  solve one case (catalog name or .toml path)
    flexbench recommend CASE [--tol 1%] [--json]   cheapest model within the tolerance
    flexbench claims [--json] [--id ID]      published validity claims judged on their own terms
    flexbench teach [--out DIR] [--quick]    teaching page: atlases, cards, worked advice
    flexbench run [--cases GLOB] [--models LIST] [--out DIR] [--quick] [--workers N]
                  [--dask ADDRESS] [--history PATH] [--fresh] [--no-report] [--time-limit S]
    flexbench compare BASE CURRENT [--abs-tol X] [--rel-factor F]   exit 1 on regression
    flexbench report DIR                     re-render report.html/.md from DIR/results.json
    flexbench history [DIR|PATH] [--case C]  runs in history.sqlite (or one case's trend)
    flexbench fit-prb ...                    fit a PRB matrix (reduced_models.beam.prb_fit)

Exit codes: 0 success, 1 regression (compare) or a report that could not be rendered (run),
2 bad input (one line ``flexbench: error: ...`` on stderr, never a traceback; an unwritable
or full --out included), 3 an internal error (one line naming case, model and exception type;
``--debug`` anywhere on the line shows the traceback), 130 interrupted (finished pairs are
kept in DIR/partial.jsonl; rerun to resume).
"""

from __future__ import annotations

import argparse
import fnmatch
import glob
import json
import math
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from reduced_models.base import Solution
from reports import api, timing
from reports.compare import DEFAULT_ABS_TOL, DEFAULT_REL_FACTOR
from reports.timing import DEFAULT_TIME_LIMIT, QUICK_TIME_LIMIT  # not the runner: lazy

PROG = "flexbench"
SOLVE_TIME_LIMIT = 600.0  # s: `flexbench solve` ends a model that runs away
# what the command was working on, for the one-line internal-error message
_CONTEXT: dict[str, str] = {}


class UsageError(Exception):
    """A user's mistake: printed as one line, exit 2."""


class _Parser(argparse.ArgumentParser):
    """argparse that raises instead of printing usage + error over several lines."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)


def _fail(message: str) -> int:
    text = " ".join(str(message).split())  # exactly one line
    print(f"{PROG}: error: {text}", file=sys.stderr)
    return 2


def _user_errors() -> tuple[type[BaseException], ...]:
    from reports.journal import LockedError, OutputError

    errs: list[type[BaseException]] = [UsageError, api.UnknownModelError, api.OptionError]
    errs += [OutputError, LockedError]
    try:
        import cases

        errs.append(cases.CaseError)
    except (ImportError, AttributeError):
        pass
    return tuple(errs)


def _load(case: str) -> Any:
    import cases

    try:
        return cases.load(case)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        raise UsageError(f"{case}: cannot read case file ({exc.strerror or exc})") from None


def _floats(x: Any) -> Any:
    """Float or None (JSON has no NaN/inf)."""
    x = float(x)
    return x if math.isfinite(x) else None


def solution_json(sol: Any, wall_s: float) -> dict[str, Any]:
    """The ``solve --json`` object of DESIGN.md (non-finite numbers -> null)."""
    out = {
        "case": sol.case,
        "model": sol.model,
        "status": sol.status,
        "message": sol.message,
        "steps": [
            {
                "factor": _floats(s.factor),
                "outputs": {str(k): _floats(v) for k, v in s.outputs.items()},
                "energy": _floats(s.energy),
                "iterations": int(s.iterations),
                "stable": None if s.stable is None else bool(s.stable),
            }
            for s in sol.steps
        ],
        "wall_s": float(wall_s),
    }
    # Extension (DESIGN.md allows extending, never breaking): the reference's own error
    # estimate, observed orders, limit points, dynamic jumps and validity flags, when present.
    extra = {k: sol.extras[k] for k in _JSON_EXTRAS if k in sol.extras}
    if extra:
        from reports.store import extras_json

        out["extras"] = extras_json(extra)
    return out


_JSON_EXTRAS = (
    "error_estimate",
    "observed_order",
    "limit_points",
    "critical_points",
    "reference_usable",
    "mesh_error_worst",
    "jumps",
    "validity_warning",
    "validity_message",
    # mechanism analyses (issue 9)
    "equilibria",
    "barrier",
    "synthesis",
    "bistable",
    "drivers",
    "mobility",
    "mobility_rank",
    "range",
    # deploy: the thesis's load totals (Tables 4-5 .. 4-10), its stability number, the booms
    "load_total_rows",
    "part1_load_total",
    "part2_load_total",
    "part1_increments",
    "part2_increments",
    "stability_number",
    "boom_reached",
    "boom_bar_force",
)


# -- commands ------------------------------------------------------------------------------------
def cmd_cases(args: argparse.Namespace) -> int:
    import cases

    bad = False
    for name in cases.catalog_names():
        try:
            s = cases.load(name)
        except cases.CaseError as exc:
            print(f"{name:<34} INVALID: {' '.join(str(exc).split())}")
            bad = True
            continue
        print(f"{name:<34} {s.title:<58} {', '.join(s.tags)}")
    return 1 if bad else 0


def cmd_models(args: argparse.Namespace) -> int:
    table = api.registry_table()
    defaults = set(api.default_names())
    print(f"{'name':<14} {'family':<10} summary   (* = in the default run)")
    for key in sorted(table):
        card = api.card_of(key)
        family = key[:-2] if key.endswith("-N") else None
        default = key in defaults or any(
            family and re.fullmatch(rf"{re.escape(family)}-\d+", d) for d in defaults
        )
        star = "*" if default else " "
        if card is None:
            print(f"{key:<13}{star} {'?':<10} (card unavailable: {table[key]} not importable)")
        else:
            print(f"{key:<13}{star} {card.family:<10} {card.summary}")
    for warning in api.REGISTRY_WARNINGS:
        print(f"warning: {warning}")
    return 0


def _option_key(scene: Any, model: str) -> str:
    """Where a model's options come from: ``FILE: models[i].options``."""
    i = next((i for i, s in enumerate(scene.models) if s.name == model), None)
    return f"{scene.path}: " + ("(no options given)" if i is None else f"models[{i}].options")


def cmd_solve(args: argparse.Namespace) -> int:
    from reports import limits

    _CONTEXT.update(case=args.case, model=args.model)
    _check_limits(args)
    scene = _load(args.case)
    try:
        model = api.make_model(args.model, scene)
    except ValueError as exc:
        if isinstance(exc, api.UnknownModelError):
            raise
        raise UsageError(f"{_option_key(scene, args.model)}: {exc}") from None
    except Exception as exc:  # a broken model module is not the user's mistake: say so
        text = f"cannot build model: {type(exc).__name__}: {exc}".splitlines()[0]
        sol, wall = Solution(scene.name, args.model, "failed", text), 0.0
    else:
        _one_blas_thread()
        t0 = time.perf_counter()
        memory = None if args.memory_limit == 0 else args.memory_limit
        try:
            with limits.guard(args.time_limit, memory):
                # post=False: shapes and stress are not printed (and cost their imports)
                sol = limits.explain(api.run_model(model, scene, post=False), memory)
        except limits.LimitExceeded as exc:
            sol = Solution(scene.name, args.model, "failed", str(exc))
        wall = time.perf_counter() - t0
    if args.json:
        print(json.dumps(solution_json(sol, wall), allow_nan=False))
        return 0
    print(f"{scene.name} / {args.model}: {sol.status} ({wall * 1e3:.3g} ms) {sol.message}")
    if sol.steps:
        keys = [k for k in scene.output_keys() if k.split(".")[-1] in ("ux", "uy", "rot")]
        print("  ".join(f"{k:>12}" for k in ["factor", *keys, "energy", "iter"]))
        for s in sol.steps:
            vals = [s.factor, *(s.outputs.get(k, math.nan) for k in keys), s.energy]
            print("  ".join(f"{v:12.6g}" for v in vals) + f"  {s.iterations:12d}")
    return 0


def _one_blas_thread() -> None:
    """One BLAS thread for a solve, as in the runner's workers: the FE's banded factorisations
    are far below threading's break-even, and threaded OpenBLAS on a busy machine cost 80x
    (fem-64 on the double parallelogram: 4 s against 0.05 s).  Loaded pools are pinned now;
    the variables cover a BLAS imported during the solve (scipy ships its own OpenBLAS)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    timing.pin_blas()


def cmd_recommend(args: argparse.Namespace) -> int:
    from reports.recommend import format_text, recommend
    from reports.tolerance import ToleranceError, parse_tolerance

    try:
        tol = None if args.tol is None else parse_tolerance(args.tol)
        result = recommend(_load(args.case), tol)
    except ToleranceError as exc:
        raise UsageError(str(exc)) from None
    print(json.dumps(result.as_json(), allow_nan=False) if args.json else format_text(result))
    return 0


def cmd_claims(args: argparse.Namespace) -> int:
    from reports import claims

    ids = [c.id for c in claims.CLAIMS]
    if args.id and args.id not in ids:
        raise UsageError(f"--id {args.id}: no such claim (known: {', '.join(ids)})")
    records = [r for r in claims.evaluate_all() if not args.id or r["id"] == args.id]
    out = claims.as_json(records)
    print(json.dumps(out, allow_nan=False) if args.json else claims.format_table(out["claims"]))
    return 0


def cmd_teach(args: argparse.Namespace) -> int:
    import cases
    from reports.render import teaching

    names = [s.name for s in select_cases(args.cases)] if args.cases else cases.catalog_names()
    small = {"n_mag": 20, "n_ang": 21} if args.quick else {}
    tols = ("1%",) if args.quick else ("1%", "0.1%")
    data = teaching.build_data(names, tols, workers=args.workers, progress=print, **small)
    path = teaching.write_page(data, Path(args.out) / "teaching.html")
    print(f"teaching.html: {path} ({data['seconds']:.1f} s; atlases {data['atlas_seconds']} s)")
    return 0


def select_cases(patterns: str | None) -> list[Any]:
    """Scenes for ``--cases``: comma-separated catalog globs or .toml paths/globs."""
    import cases

    if not patterns:
        return [cases.load(n) for n in cases.catalog_names()]
    names: list[str] = []
    for pat in (p.strip() for p in patterns.split(",")):
        if not pat:
            continue
        if pat.endswith(".toml") or os.sep in pat:
            found = sorted(glob.glob(pat)) or [pat]  # a missing path: the loader says so
        else:
            found = fnmatch.filter(cases.catalog_names(), pat)
            if not found:
                raise UsageError(f"--cases: no catalog case matches {pat!r}")
        names += [n for n in found if n not in names]
    return [_load(n) for n in names]


def _check_limits(args: argparse.Namespace) -> None:
    for flag, v in (("--time-limit", args.time_limit), ("--memory-limit", args.memory_limit)):
        if v is not None and not (0 <= v < math.inf):
            raise UsageError(f"{flag} must be a finite number >= 0, got {v:g}")


def cmd_run(args: argparse.Namespace) -> int:
    from reports import journal, runner

    _CONTEXT.update(case=args.cases or "(catalog)", model=args.models or "(defaults)")
    _check_limits(args)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be >= 1, got {args.workers}")
    models = [m.strip() for m in args.models.split(",") if m.strip()] if args.models else None
    if args.models is not None and not models:
        raise UsageError("--models: empty list")
    for name in models or ():
        api.resolve(name)
    if args.dask:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise UsageError(
                "--dask needs dask[distributed] (pip install flexbench[dask])"
            ) from None
    scenes = select_cases(args.cases)
    tol = None
    if args.tol is not None:
        from reports.tolerance import ToleranceError, parse_tolerance

        try:
            tol = parse_tolerance(args.tol)
        except ToleranceError as exc:
            raise UsageError(str(exc)) from None
        if tol.per_output or tol.default is None:
            raise UsageError("--tol for run takes one value (e.g. 1%), not per-output values")
        tol = tol.default
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a directory")
    try:
        with journal.RunLock(out, wait=args.wait):
            res = _run(args, runner, scenes, models, out, tol)
    except KeyboardInterrupt:
        print(
            f"{PROG}: interrupted; finished pairs are kept in {out / 'partial.jsonl'} "
            "(rerun the same command to resume)",
            file=sys.stderr,
        )
        return 130
    except (OSError, TimeoutError) as exc:
        if args.dask:
            return _fail(f"dask scheduler {args.dask}: {type(exc).__name__}: {exc}")
        err = journal.output_error(exc, out) if isinstance(exc, OSError) else None
        if err is None:
            raise
        return _fail(str(err))
    return _summary(res)


def _run(
    args: argparse.Namespace, runner: Any, scenes: list, models: Any, out: Path, tol: Any
) -> Any:
    return runner.run_matrix(
        scenes,
        models,
        out,
        quick=args.quick,
        workers=args.workers,
        dask=args.dask,
        history=args.history,
        fresh=args.fresh,
        render=not args.no_report,
        time_limit="auto" if args.time_limit is None else (args.time_limit or None),
        memory_limit=args.memory_limit or None,
        tolerance=tol,
    )


def _summary(res: Any) -> int:
    stats = res.payload["stats"]
    failed = sum(r["status"] == "failed" for r in res.payload["results"])
    print(
        f"{stats['pairs']} pairs ({stats['solved']} solved, {stats['resumed']} resumed, "
        f"{failed} failed) in {res.elapsed_s:.1f} s"
    )
    for label, p in res.paths.items():
        if isinstance(p, Path):
            print(f"{label}: {p}")
    if res.report_error:
        print(
            f"{PROG}: report not rendered ({res.report_error}); results are in "
            f"{res.paths['results.json']}",
            file=sys.stderr,
        )
        return 1
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from reports import compare, store

    if args.abs_tol < 0 or args.rel_factor < 1:
        raise UsageError("--abs-tol must be >= 0 and --rel-factor >= 1")
    try:
        base = store.read_results(args.base)
        cur = store.read_results(args.current)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    result = compare.compare(base, cur, args.abs_tol, args.rel_factor)
    print(compare.report(result))
    return 0 if result.ok else 1


def cmd_report(args: argparse.Namespace) -> int:
    from reports import store
    from reports.render import render_report

    try:
        payload = store.read_results(args.dir)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if "cases" not in payload:
        raise UsageError(f"{args.dir}: results file has no case metadata to render")
    out = Path(args.dir) if Path(args.dir).is_dir() else Path(args.dir).parent
    paths = render_report(payload, out, pyvista=True if args.pyvista else None)
    print(f"report.html: {paths['report.html']}\nreport.md: {paths['report.md']}")
    return 0


def cmd_history(args: argparse.Namespace) -> int:
    from reports import history

    try:
        return history.cmd_history(args)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def cmd_fit_prb(argv: Sequence[str]) -> int:
    try:
        from reduced_models.beam.prb_fit import fit_prb_cli
    except ImportError as exc:
        raise UsageError(f"fit-prb is not available ({exc})") from None
    return int(fit_prb_cli(list(argv)) or 0)


def _memory_flag(p: argparse.ArgumentParser) -> None:
    from reports.limits import DEFAULT_MEMORY_LIMIT_MB

    p.add_argument(
        "--memory-limit",
        type=float,
        default=DEFAULT_MEMORY_LIMIT_MB,
        metavar="MB",
        help=f"memory per solve before it is failed (0: none; default {DEFAULT_MEMORY_LIMIT_MB:g})",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for docs and tests)."""
    p = _Parser(prog=PROG, description="FEA-validated benchmark of reduced compliant-beam models")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    sub.add_parser("cases", help="list the case catalog").set_defaults(func=cmd_cases)
    sub.add_parser("models", help="list the models").set_defaults(func=cmd_models)
    s = sub.add_parser("solve", help="solve one case with one model")
    s.add_argument("case", help="catalog name or path to a .toml case file")
    s.add_argument("--model", "-m", required=True, help="registry name, e.g. elastica, linear-8")
    s.add_argument("--json", action="store_true", help="print the contract JSON object")
    s.add_argument(
        "--time-limit",
        type=float,
        default=SOLVE_TIME_LIMIT,
        metavar="S",
        help=f"seconds before the solve is failed (0: none; default {SOLVE_TIME_LIMIT:g})",
    )
    _memory_flag(s)
    s.set_defaults(func=cmd_solve)
    rc = sub.add_parser("recommend", help="the cheapest model within a tolerance for one case")
    rc.add_argument("case", help="catalog name or path to a .toml case file")
    rc.add_argument(
        "--tol",
        default=None,
        help="error allowed, relative to each output's own excursion: 1%%, 1e-3 or "
        "tip.uy=0.5%%,tip.rot=abs:1e-3 (default: the case's [[tolerances]], else 1%%)",
    )
    rc.add_argument("--json", action="store_true", help="print the contract JSON object")
    rc.set_defaults(func=cmd_recommend)
    cl = sub.add_parser("claims", help="published validity claims, judged on their own terms")
    cl.add_argument("--json", action="store_true", help="print the contract JSON object")
    cl.add_argument("--id", help="only this claim (e.g. howell-prb-1r)")
    cl.set_defaults(func=cmd_claims)
    te = sub.add_parser("teach", help="write the teaching page (atlases, which model to use)")
    te.add_argument("--out", default="out", help="output directory (default: out)")
    te.add_argument("--cases", help="catalog globs for the worked recommendations (default: all)")
    te.add_argument("--quick", action="store_true", help="20 x 21 atlases, 1 %% only")
    te.add_argument("--workers", type=int, default=2, help="processes for the atlases")
    te.set_defaults(func=cmd_teach)
    r = sub.add_parser("run", help="run the case x model matrix and render the report")
    r.add_argument("--cases", help="comma-separated catalog globs or .toml paths (default: all)")
    r.add_argument("--models", help="comma-separated model names (default: case list + defaults)")
    r.add_argument("--out", default="out", help="output directory (default: out)")
    r.add_argument("--quick", action="store_true", help="fewer load steps and timing repeats")
    r.add_argument("--workers", type=int, help="local processes (default: CPU count)")
    r.add_argument("--dask", metavar="ADDRESS", help="run on a dask.distributed scheduler")
    r.add_argument("--history", help="SQLite history file (default: OUT/history.sqlite)")
    r.add_argument("--fresh", action="store_true", help="ignore finished pairs in OUT")
    r.add_argument(
        "--time-limit",
        type=float,
        metavar="S",
        help=f"seconds per pair before it is failed (0: none; default {DEFAULT_TIME_LIMIT:g},"
        f" --quick {QUICK_TIME_LIMIT:g})",
    )
    r.add_argument("--no-report", action="store_true", help="results only, no HTML/MD/PNG")
    _memory_flag(r)
    r.add_argument("--wait", action="store_true", help="wait for another run using --out")
    r.add_argument("--tol", help="grade every model against this tolerance (default: per family)")
    r.set_defaults(func=cmd_run)
    c = sub.add_parser("compare", help="regression check of CURRENT against BASE")
    c.add_argument("base", help="BASE results.json (or its directory)")
    c.add_argument("current", help="CURRENT results.json (or its directory)")
    c.add_argument("--abs-tol", type=float, default=DEFAULT_ABS_TOL, help="error always allowed")
    c.add_argument(
        "--rel-factor", type=float, default=DEFAULT_REL_FACTOR, help="allowed error growth factor"
    )
    c.set_defaults(func=cmd_compare)
    rp = sub.add_parser("report", help="re-render the report of a finished run")
    rp.add_argument("dir", help="run directory (or its results.json)")
    rp.add_argument(
        "--pyvista",
        action="store_true",
        help="require pyvista renders (default: pyvista when it works, else matplotlib)",
    )
    rp.set_defaults(func=cmd_report)
    from reports.history import add_parser as add_history

    add_history(sub)
    sub.choices["history"].set_defaults(func=cmd_history)
    sub.add_parser(
        "fit-prb", help="fit a PRB matrix (see flexbench fit-prb --help)", add_help=False
    )
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``flexbench`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    _CONTEXT.clear()
    try:
        if argv and argv[0] == "fit-prb":
            return cmd_fit_prb(argv[1:])
        args = build_parser().parse_args(argv)
        return int(args.func(args))
    except BrokenPipeError:  # `flexbench cases | head`
        return 0
    except KeyboardInterrupt:  # `run` says more itself; elsewhere nothing is left half-done
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug of ours: one line (the traceback with --debug), exit 3
        # the user-error classes are looked up only now: their modules (the run journal and
        # its store) cost a solve of a reduced model more than the solve itself
        if isinstance(exc, _user_errors()):
            return _fail(str(exc))
        return _internal(exc, debug)


def _internal(exc: Exception, debug: bool) -> int:
    if debug:
        import traceback

        traceback.print_exc()
    where = f"case {_CONTEXT.get('case', '-')}, model {_CONTEXT.get('model', '-')}"
    text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
    print(
        f"{PROG}: internal error ({where}): {text}; please report this with the output of "
        "the same command run with --debug",
        file=sys.stderr,
    )
    return 3


if __name__ == "__main__":
    sys.exit(main())
