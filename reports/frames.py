"""A run folder as pandas DataFrames: ``reports.load_run(DIR)``.

``flexbench run --out DIR`` writes ``results.csv`` (one row per case x model, the documented
table), ``errors.csv`` (one row per compared output), ``results.json`` (everything, nested:
``pd.read_json`` cannot flatten it, hence this loader) and ``history.sqlite``.  ``load_run``
reads them into a ``RunFrames``::

    run = reports.load_run("flexbench-out")
    run.results                                   # results.csv
    run.steps.query("model == 'prb-3r'")          # tidy: one row per step and output
    run.path("cantilever-tip-load", "prb-3r")     # one pair, one row per step (wide)
"""

from __future__ import annotations

import dataclasses
import json
import sqlite3
from pathlib import Path
from typing import Any

import pandas as pd

STEP_COLUMNS = ["case", "model", "step", "factor", "energy", "iterations", "stable", "max_stress"]


@dataclasses.dataclass(frozen=True)
class RunFrames:
    """The tables of one run folder.

    Attributes
    ----------
    folder : the run folder.
    results : ``results.csv``: one row per (case, model); sweep points carry their parent
        (``sweep_parent``) and one column per swept parameter.
    errors : ``errors.csv``: one row per (case, model, compared output); empty if absent.
    steps : one row per (case, model, step, output): ``STEP_COLUMNS`` + ``output``,
        ``value`` (the case's units, ``cases`` gives them; rotations in rad).
    cases : one row per case: ``title``, ``units``, ``tags``, ``analysis``, ``sweep_parent``.
    history : ``history.sqlite``'s ``results`` table joined with its ``runs`` (``time``,
        ``git_commit``); empty if absent.
    """

    folder: Path
    results: pd.DataFrame
    errors: pd.DataFrame
    steps: pd.DataFrame
    cases: pd.DataFrame
    history: pd.DataFrame

    def path(self, case: str, model: str) -> pd.DataFrame:
        """One pair's steps, one row per step: ``step``, ``factor``, every output,
        ``energy``, ``iterations``, ``stable``, ``max_stress`` (as ``Solution.to_frame``).

        Raises
        ------
        KeyError
            When the run holds no steps of that pair.
        """
        rows = self.steps[(self.steps["case"] == case) & (self.steps["model"] == model)]
        if rows.empty:
            raise KeyError(f"{self.folder}: no steps of {case} / {model}")
        outputs = rows.pivot(index="step", columns="output", values="value")
        outputs = outputs[list(dict.fromkeys(rows["output"]))]  # the case's output order
        per_step = rows.drop_duplicates("step").set_index("step")
        tail = ["energy", "iterations", "stable", "max_stress"]
        wide = pd.concat([per_step[["factor"]], outputs, per_step[tail]], axis=1)
        wide.columns.name = None
        return wide.reset_index()


def _csv(path: Path) -> pd.DataFrame:
    return pd.read_csv(path) if path.is_file() else pd.DataFrame()


def _steps(records: list[dict[str, Any]]) -> pd.DataFrame:
    rows = []
    for rec in records:
        for i, s in enumerate(rec.get("steps") or ()):
            head = [rec["case"], rec["model"], i, s.get("factor"), s.get("energy")]
            head += [s.get("iterations"), s.get("stable"), s.get("max_stress")]
            rows += [(*head, k, v) for k, v in (s.get("outputs") or {}).items()]
    df = pd.DataFrame(rows, columns=[*STEP_COLUMNS, "output", "value"])
    return df.astype({"factor": float, "energy": float, "max_stress": float, "value": float})


def _cases(meta: dict[str, dict[str, Any]]) -> pd.DataFrame:
    rows = [
        {
            "case": name,
            "title": m.get("title"),
            "units": m.get("units"),
            "tags": ", ".join(m.get("tags") or ()),
            "analysis": (m.get("analysis") or {}).get("kind"),
            "sweep_parent": (m.get("sweep") or {}).get("parent"),
        }
        for name, m in meta.items()
    ]
    columns = ["case", "title", "units", "tags", "analysis", "sweep_parent"]
    return pd.DataFrame(rows, columns=columns)


def _history(path: Path) -> pd.DataFrame:
    if not path.is_file():
        return pd.DataFrame()
    with sqlite3.connect(path) as con:
        return pd.read_sql_query(
            "SELECT runs.time, runs.git_commit, results.* FROM results "
            "JOIN runs ON runs.id = results.run_id ORDER BY results.run_id",
            con,
        )


def load_run(folder: str | Path) -> RunFrames:
    """Read a ``flexbench run`` folder into DataFrames (see ``RunFrames``).

    Parameters
    ----------
    folder : the ``--out`` directory (or its ``results.json``).

    Raises
    ------
    FileNotFoundError
        When the folder has no ``results.json`` (a run that has not finished).
    """
    folder = Path(folder)
    if folder.is_file():
        folder = folder.parent
    source = folder / "results.json"
    if not source.is_file():
        raise FileNotFoundError(f"{folder}: no results.json (has the run finished?)")
    payload = json.loads(source.read_text())
    return RunFrames(
        folder=folder,
        results=_csv(folder / "results.csv"),
        errors=_csv(folder / "errors.csv"),
        steps=_steps(payload.get("results") or []),
        cases=_cases(payload.get("cases") or {}),
        history=_history(folder / "history.sqlite"),
    )
