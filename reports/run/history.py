"""``history.sqlite`` read back: the runs it holds and, per case and model, how error and
time moved from run to run (with the git commit of each run).

``flexbench history [PATH] [--case C] [--model M]`` lists the runs (newest last), or one
pair's trend; the report draws the trend per case (``trend_figure``) when the history holds
two or more runs of it.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import sqlite3

MAX_RUNS_DRAWN = 12  # the report's trend shows the last runs only


def _connect(path: Path) -> sqlite3.Connection:
    import sqlite3  # here: the CLI builds this subcommand's parser on every call

    if not Path(path).is_file():
        raise ValueError(f"{path}: no such history file")
    con = sqlite3.connect(f"file:{Path(path).resolve()}?mode=ro", uri=True, timeout=30)
    try:
        con.execute("SELECT id FROM runs LIMIT 1")
    except sqlite3.DatabaseError as exc:
        con.close()
        raise ValueError(f"{path}: not a FlexBench history file ({exc})") from None
    return con


def runs(path: Path) -> list[dict[str, Any]]:
    """Every run: id, time, commit (+ dirty flag), pairs, elapsed seconds, output folder."""
    con = _connect(path)
    try:
        rows = con.execute(
            "SELECT id, time, git_commit, git_dirty, n_pairs, elapsed_s, out_dir, cpu"
            " FROM runs ORDER BY id"
        ).fetchall()
    finally:
        con.close()
    keys = ("id", "time", "commit", "dirty", "pairs", "elapsed_s", "out_dir", "cpu")
    return [dict(zip(keys, r)) for r in rows]


def trends(path: Path, case: str, last: int = MAX_RUNS_DRAWN) -> dict[str, list[dict]]:
    """model -> [{"run", "time", "commit", "wall_s", "error", "status"}, ...] for one case
    over the last ``last`` runs that contain it (oldest first)."""
    con = _connect(path)
    try:
        ids = [
            r[0]
            for r in con.execute(
                "SELECT DISTINCT run_id FROM results WHERE case_name = ? ORDER BY run_id DESC"
                " LIMIT ?",
                (case, last),
            ).fetchall()
        ]
        if not ids:
            return {}
        marks = ",".join("?" * len(ids))
        rows = con.execute(
            "SELECT results.run_id, runs.time, runs.git_commit, runs.git_dirty, model,"
            " wall_median_s, error_rel, status FROM results JOIN runs"
            f" ON runs.id = results.run_id WHERE case_name = ? AND run_id IN ({marks})"
            " ORDER BY results.run_id",
            (case, *ids),
        ).fetchall()
    finally:
        con.close()
    out: dict[str, list[dict]] = {}
    for run_id, time, commit, dirty, model, wall, err, status in rows:
        out.setdefault(model, []).append(
            {
                "run": run_id,
                "time": time,
                "commit": short(commit, dirty),
                "wall_s": wall,
                "error": err,
                "status": status,
            }
        )
    return out


def short(commit: str | None, dirty: int | None = None) -> str:
    """``abc1234`` (``+`` when the tree had uncommitted changes)."""
    return (commit or "no-git")[:7] + ("+" if dirty else "")


def trend_figure(
    case: str, data: Mapping[str, Sequence[Mapping]], cmap: Mapping, path: Path
) -> Path | None:
    """Error and wall time per model over the stored runs (x: run id and commit); None with
    fewer than two runs."""
    from reports.render.figures import _save, plt

    run_ids = sorted({p["run"] for pts in data.values() for p in pts})
    if len(run_ids) < 2:
        return None
    commits = {p["run"]: p["commit"] for pts in data.values() for p in pts}
    fig, (ax_e, ax_t) = plt.subplots(1, 2, figsize=(10.0, 3.0))
    for model, pts in sorted(data.items()):
        xs = [run_ids.index(p["run"]) for p in pts]
        colour = cmap.get(model, "C0")
        err = [p["error"] if p["error"] and p["error"] > 0 else float("nan") for p in pts]
        ax_e.plot(xs, err, ".-", color=colour, lw=1, label=model)
        ax_t.plot(xs, [p["wall_s"] or float("nan") for p in pts], ".-", color=colour, lw=1)
    for ax, label in ((ax_e, "summary error (/L, rad)"), (ax_t, "wall time [s]")):
        ax.set_yscale("log")
        ax.set_xticks(range(len(run_ids)))
        ax.set_xticklabels([f"#{i}\n{commits[i]}" for i in run_ids], fontsize=6)
        ax.set_ylabel(label, fontsize=7)
        ax.tick_params(axis="y", labelsize=6)
        ax.grid(alpha=0.3)
    ax_e.set_title(f"{case}: error over stored runs (run id, commit)", fontsize=8)
    ax_t.set_title("wall time over stored runs", fontsize=8)
    fig.legend(
        *ax_e.get_legend_handles_labels(),
        loc="center left",
        bbox_to_anchor=(0.86, 0.5),
        fontsize=6,
        frameon=False,
    )
    fig.subplots_adjust(left=0.07, right=0.85, bottom=0.2, top=0.9, wspace=0.3)
    return _save(fig, path)


def cmd_history(args: argparse.Namespace) -> int:
    """``flexbench history``: the runs, or one pair's trend (``--case``, ``--model``)."""
    path = Path(args.path)
    if path.is_dir():
        path = path / "history.sqlite"
    if args.case:
        data = trends(path, args.case, last=10**9)
        if not data:
            raise ValueError(f"{path}: no runs of case {args.case!r}")
        for model, pts in sorted(data.items()):
            if args.model and model != args.model:
                continue
            for p in pts:
                err = "–" if p["error"] is None else f"{p['error']:.3e}"
                wall = "–" if p["wall_s"] is None else f"{p['wall_s']:.3e} s"
                print(
                    f"{model:<14} run {p['run']:>4}  {p['time']}  {p['commit']:<8}  "
                    f"error {err:>10}  wall {wall:>12}  {p['status']}"
                )
        return 0
    for r in runs(path):
        print(
            f"run {r['id']:>4}  {r['time']}  {short(r['commit'], r['dirty']):<8}  "
            f"{r['pairs']:>4} pairs  {r['elapsed_s']:8.1f} s  {r['out_dir']}"
        )
    return 0


def add_parser(sub: Any) -> None:
    """The ``history`` subcommand (``sub``: argparse subparsers)."""
    h = sub.add_parser("history", help="list the runs in a history.sqlite (or one pair's trend)")
    h.add_argument("path", nargs="?", default="flexbench-out", help="history file or run directory")
    h.add_argument("--case", help="show this case's error and time per run")
    h.add_argument("--model", help="with --case: only this model")
    h.set_defaults(func=cmd_history)
