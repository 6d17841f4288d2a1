"""The ``flexbench`` argument parser: every subcommand, its flags and their defaults.

``reports.cli`` holds the commands and passes them in (``build_parser(commands)``); a parse
error is a ``UsageError`` (one line, exit 2), never argparse's usage text over several lines.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping

from reports.run.compare import DEFAULT_ABS_TOL, DEFAULT_REL_FACTOR
from reports.run.timing import DEFAULT_TIME_LIMIT, QUICK_TIME_LIMIT  # not the runner: lazy

PROG = "flexbench"
DEFAULT_OUT = "flexbench-out"  # run/teach/history folder; README's commands use the same
SOLVE_TIME_LIMIT = 600.0  # s: `flexbench solve` ends a model that runs away


class UsageError(Exception):
    """A user's mistake: printed as one line, exit 2."""


class _Parser(argparse.ArgumentParser):
    """argparse that raises instead of printing usage + error over several lines."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)


class _Version(argparse.Action):
    """``--version``: the version is looked up when asked for, not for every command
    (``importlib.metadata`` costs a one-off solve 10-30 ms to import)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: object) -> None:
        super().__init__(
            option_strings, argparse.SUPPRESS, nargs=0, help="show the version and exit"
        )

    def __call__(self, parser: argparse.ArgumentParser, *args: object) -> None:
        print(f"{PROG} {version()}")
        parser.exit()


def _memory_flag(p: argparse.ArgumentParser) -> None:
    from reports.run.limits import DEFAULT_MEMORY_LIMIT_MB

    p.add_argument(
        "--memory-limit",
        type=float,
        default=DEFAULT_MEMORY_LIMIT_MB,
        metavar="MB",
        help=f"memory per solve before it is failed (0: none; default {DEFAULT_MEMORY_LIMIT_MB:g})",
    )


def build_parser(
    commands: Mapping[str, Callable[[argparse.Namespace], int]],
) -> argparse.ArgumentParser:
    """The ``flexbench`` argument parser; each subcommand's ``func`` is ``commands[name]``
    (the ``cmd_*`` functions of ``reports.cli``)."""
    p = _Parser(prog=PROG, description="FEA-validated benchmark of reduced compliant-beam models")
    p.add_argument("--version", action=_Version)
    _debug_flag(p)
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    sub.add_parser("cases", help="list the case catalog").set_defaults(func=commands["cases"])
    sub.add_parser("models", help="list the models").set_defaults(func=commands["models"])
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
    s.set_defaults(func=commands["solve"])
    rc = sub.add_parser("recommend", help="the cheapest model within a tolerance for one case")
    rc.add_argument("case", help="catalog name or path to a .toml case file")
    rc.add_argument(
        "--tol",
        default=None,
        help="error allowed, relative to each output's own excursion: 1%%, 1e-3 or "
        "tip.uy=0.5%%,tip.rot=abs:1e-3 (default: the case's [[tolerances]], else 1%%)",
    )
    rc.add_argument("--json", action="store_true", help="print the contract JSON object")
    rc.set_defaults(func=commands["recommend"])
    cl = sub.add_parser("claims", help="published validity claims, judged on their own terms")
    cl.add_argument("--json", action="store_true", help="print the contract JSON object")
    cl.add_argument("--id", help="only this claim (e.g. howell-prb-1r)")
    cl.set_defaults(func=commands["claims"])
    te = sub.add_parser("teach", help="write the teaching page (atlases, which model to use)")
    te.add_argument("--out", default=DEFAULT_OUT, help=f"output directory (default: {DEFAULT_OUT})")
    te.add_argument("--cases", help="catalog globs for the worked recommendations (default: all)")
    te.add_argument("--quick", action="store_true", help="20 x 21 atlases, 1 %% only")
    te.add_argument("--workers", type=int, default=2, help="processes for the atlases")
    te.set_defaults(func=commands["teach"])
    r = sub.add_parser("run", help="run the case x model matrix and render the report")
    r.add_argument("--cases", help="comma-separated catalog globs or .toml paths (default: all)")
    r.add_argument("--models", help="comma-separated model names (default: case list + defaults)")
    r.add_argument("--out", default=DEFAULT_OUT, help=f"output directory (default: {DEFAULT_OUT})")
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
    r.set_defaults(func=commands["run"])
    c = sub.add_parser("compare", help="regression check of CURRENT against BASE")
    c.add_argument("base", help="BASE results.json (or its directory)")
    c.add_argument("current", help="CURRENT results.json (or its directory)")
    c.add_argument("--abs-tol", type=float, default=DEFAULT_ABS_TOL, help="error always allowed")
    c.add_argument(
        "--rel-factor", type=float, default=DEFAULT_REL_FACTOR, help="allowed error growth factor"
    )
    c.set_defaults(func=commands["compare"])
    rp = sub.add_parser("report", help="re-render the report of a finished run")
    rp.add_argument("dir", help="run directory (or its results.json)")
    rp.add_argument(
        "--pyvista",
        action="store_true",
        help="require pyvista renders (default: pyvista when it works, else matplotlib)",
    )
    rp.set_defaults(func=commands["report"])
    from reports.run.history import add_parser as add_history

    add_history(sub)
    sub.choices["history"].set_defaults(func=commands["history"])
    for parser in sub.choices.values():
        _debug_flag(parser)
    sub.add_parser(
        "fit-prb", help="fit a PRB matrix (see flexbench fit-prb --help)", add_help=False
    )
    return p


def _debug_flag(p: argparse.ArgumentParser) -> None:
    """``--debug`` for the help text: ``reports.cli.main`` takes it off the command line
    wherever it stands, before parsing."""
    p.add_argument(
        "--debug", action="store_true", help="show the traceback of an internal error (exit 3)"
    )


def version() -> str:
    """The installed distribution's version (``pyproject.toml``'s when not installed)."""
    from importlib import metadata

    try:
        return metadata.version("flexbench")
    except metadata.PackageNotFoundError:
        import tomllib
        from pathlib import Path

        pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
        return tomllib.loads(pyproject.read_text())["project"]["version"]
