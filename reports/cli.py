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
    flexbench --version                      the installed version

``run``, ``teach`` and ``history`` default to the folder ``flexbench-out`` (``DEFAULT_OUT``).

Exit codes: 0 success, 1 regression (compare) or a report that could not be rendered (run),
2 bad input (one line ``flexbench: error: ...`` on stderr, never a traceback; an unwritable
or full --out included), 3 an internal error (one line naming case, model and exception type;
``--debug`` anywhere on the line shows the traceback), 130 interrupted (finished pairs are
kept in DIR/partial.jsonl; rerun to resume).

The commands are here (``COMMANDS``); their flags are in ``reports.cli_args``, the ``solve
--json`` object in ``reports.api.solution_json``.
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
from reports import api
from reports.api import solution_json
from reports.cli_args import PROG, UsageError, build_parser
from reports.run import timing

# what the command was working on, for the one-line internal-error message
_CONTEXT: dict[str, str] = {}


def _fail(message: str) -> int:
    text = " ".join(str(message).split())  # exactly one line
    print(f"{PROG}: error: {text}", file=sys.stderr)
    return 2


def _user_errors() -> tuple[type[BaseException], ...]:
    from reports.run.journal import LockedError, OutputError

    errs: list[type[BaseException]] = [UsageError, api.UnknownModelError, api.OptionError]
    errs += [OutputError, LockedError]
    try:
        import cases

        errs.append(cases.CaseError)
    except (ImportError, AttributeError):
        pass
    return tuple(errs)


def did_you_mean(name: str, known: Sequence[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest of ``known`` (difflib), else ``""``."""
    import difflib

    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _model(name: str) -> str:
    """``name`` when a registry knows it; a ``UsageError`` with the closest name otherwise."""
    try:
        api.resolve(name)
    except api.UnknownModelError as exc:
        hint = did_you_mean(name, api.model_names())
        text = str(exc)
        raise UsageError(text.replace(f"model {name!r}", f"model {name!r}{hint}", 1)) from None
    return name


def _load(case: str) -> Any:
    import cases

    if not case.endswith(".toml") and not os.path.exists(case):
        names = cases.catalog_names()
        if case not in names:  # a typo of a catalog name (a missing file: the loader says)
            hint = did_you_mean(case, names)
            raise UsageError(f"{case}: not a catalog case or a file{hint} (see `{PROG} cases`)")
    try:
        return cases.load(case)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        raise UsageError(f"{case}: cannot read case file ({exc.strerror or exc})") from None


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


def _own_card(key: str) -> Any:
    """The model's card as its instance states it: a registry entry that is a preset of a
    class (``prb-3r-force`` of ``prb-3r``) has its own summary there, not the class's."""
    card = api.card_of(key)
    if card is not None and card.name != key and not key.endswith("-N"):
        try:
            card = api.make_model(key).card
        except Exception:  # the class's card is still an answer; the row says nothing wrong
            pass
    return card


def cmd_models(args: argparse.Namespace) -> int:
    table = api.registry_table()
    defaults = set(api.default_names())
    rows = []
    for key in sorted(table):
        card = _own_card(key)
        family = key[:-2] if key.endswith("-N") else None
        default = key in defaults or any(
            family and re.fullmatch(rf"{re.escape(family)}-\d+", d) for d in defaults
        )
        if card is None:
            rows.append((key, default, "?", f"(card unavailable: {table[key]} not importable)"))
        else:
            rows.append((key, default, card.family, card.summary))
    wide = max(len(r[0]) for r in rows) + 1  # the name and its default-run star
    fam = max(len("family"), *(len(r[2]) for r in rows))
    print(f"{'name':<{wide}} {'family':<{fam}} summary   (* = in the default run)")
    for key, default, family, summary in rows:
        print(f"{key + ('*' if default else ''):<{wide}} {family:<{fam}} {summary}")
    for warning in api.REGISTRY_WARNINGS:
        print(f"warning: {warning}")
    return 0


def _option_key(scene: Any, model: str) -> str:
    """Where a model's options come from: ``FILE: models[i].options``."""
    i = next((i for i, s in enumerate(scene.models) if s.name == model), None)
    return f"{scene.path}: " + ("(no options given)" if i is None else f"models[{i}].options")


def cmd_solve(args: argparse.Namespace) -> int:
    from reports.run import limits

    _CONTEXT.update(case=args.case, model=args.model)
    _check_limits(args)
    scene = _load(args.case)
    _model(args.model)
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
    from reports.verdicts.recommend import recommend
    from reports.verdicts.recommendation import format_text
    from reports.verdicts.tolerance import ToleranceError, parse_tolerance

    try:
        tol = None if args.tol is None else parse_tolerance(args.tol)
        result = recommend(_load(args.case), tol)
    except ToleranceError as exc:
        raise UsageError(str(exc)) from None
    print(json.dumps(result.as_json(), allow_nan=False) if args.json else format_text(result))
    return 0


def cmd_claims(args: argparse.Namespace) -> int:
    from reports.verdicts import claims

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
                hint = did_you_mean(pat, cases.catalog_names())
                raise UsageError(f"--cases: no catalog case matches {pat!r}{hint}")
        names += [n for n in found if n not in names]
    return [_load(n) for n in names]


def _check_limits(args: argparse.Namespace) -> None:
    for flag, v in (("--time-limit", args.time_limit), ("--memory-limit", args.memory_limit)):
        if v is not None and not (0 <= v < math.inf):
            raise UsageError(f"{flag} must be a finite number >= 0, got {v:g}")


def cmd_run(args: argparse.Namespace) -> int:
    from reports.run import journal, runner

    _CONTEXT.update(case=args.cases or "(catalog)", model=args.models or "(defaults)")
    _check_limits(args)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be >= 1, got {args.workers}")
    models = [m.strip() for m in args.models.split(",") if m.strip()] if args.models else None
    if args.models is not None and not models:
        raise UsageError("--models: empty list")
    for name in models or ():
        _model(name)
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
        from reports.verdicts.tolerance import ToleranceError, parse_tolerance

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


def _say_start(args: argparse.Namespace, scenes: list, models: list[str] | None) -> None:
    """The run's first line, before the pairs are planned (a few seconds for the catalog):
    what runs, on what, where to."""
    from reports.run.progress import plural

    sweeps = sum(s.analysis.kind == "sweep" for s in scenes)
    what = plural(len(scenes), "case")
    if sweeps:
        what += f" ({plural(sweeps, 'sweep')}, expanded to their points)"
    with_models = ", ".join(models) if models else "the default models + each case's own"
    where = f"dask {args.dask}" if args.dask else plural(args.workers or os.cpu_count(), "worker")
    line = f"{PROG}: run: {what}; models: {with_models}; {where}; out {args.out}"
    # stdout, as the summary: model options are checked while planning, and bad input must
    # stay one line on stderr
    print(line, flush=True)


def _run(
    args: argparse.Namespace, runner: Any, scenes: list, models: Any, out: Path, tol: Any
) -> Any:
    from reports.run import journal

    journal.prepare(out)  # an unwritable --out is one line, before the start line
    _say_start(args, scenes, models)
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
        + (f", {stats['cached']} references from the cache" if stats.get("cached") else "")
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
    from reports.run import compare, store

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
    from reports.render import render_report
    from reports.run import store

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
    from reports.run import history

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


COMMANDS = {
    "cases": cmd_cases,
    "models": cmd_models,
    "solve": cmd_solve,
    "recommend": cmd_recommend,
    "claims": cmd_claims,
    "teach": cmd_teach,
    "run": cmd_run,
    "compare": cmd_compare,
    "report": cmd_report,
    "history": cmd_history,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``flexbench`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    _CONTEXT.clear()
    try:
        if argv and argv[0] == "fit-prb":
            return cmd_fit_prb(argv[1:])
        args = build_parser(COMMANDS).parse_args(argv)
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
