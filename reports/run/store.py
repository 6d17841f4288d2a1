"""Results on disk: ``partial.jsonl`` (resume), ``results.json``, ``results.csv``, SQLite history.

``results.json`` layout::

    {"format": "flexbench-results/1",
     "environment": {...},              # see environment()
     "config": {...},                   # how the run was asked for
     "cases": {name: case meta},        # title, tags, references with provenance, L, ...
     "models": {name: model card},
     "results": [pair record, ...]}     # one per (case, model), see reports.run.runner

Non-finite floats are written as ``null`` (strict JSON).
"""

from __future__ import annotations

import csv
import datetime as _dt
import importlib.metadata
import json
import math
import os
import platform
import sqlite3
import subprocess
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from reduced_models.base import Solution
from reports.verdicts import errors, grading

FORMAT = "flexbench-results/1"
PACKAGES = (
    "flexbench",
    "numpy",
    "scipy",
    "scikit-fem",
    "matplotlib",
    "meshio",
    "pyvista",
    "dask",
    "distributed",
)
CSV_COLUMNS = (
    "case",
    "model",
    "role",
    "status",
    "n_steps",
    "wall_median_s",
    "wall_min_s",
    "wall_max_s",
    "wall_spread_s",
    "n_repeats",
    "error_rel",
    "error_L",
    "summary_basis",
    "speedup_vs_reference",
    "refs_passed",
    "refs_total",
    "message",
)
# grading.py: the pair's grade against its tolerance and the model's own validity warning
GRADE_COLUMNS = ("grade", "tolerance", "validity_warning")


def jsonable(obj: Any) -> Any:
    """Recursively convert numpy scalars/arrays, tuples and non-finite floats (-> None)."""
    t = type(obj)  # exact built-in types first: the ABC check below is slow on 40 MB payloads
    if t is str or obj is None or t is bool or t is int:
        return obj
    if t is float:
        return obj if math.isfinite(obj) else None
    if t is list:
        return [jsonable(v) for v in obj]
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


def _git(*args: str) -> str | None:
    root = Path(__file__).resolve().parents[2]
    try:
        out = subprocess.run(
            ["git", *args], cwd=root, capture_output=True, text=True, timeout=5, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def environment() -> dict[str, Any]:
    """Where and with what a run happened (git commit, versions, CPU, python, time, machine)."""
    versions = {}
    for pkg in PACKAGES:
        try:
            versions[pkg] = importlib.metadata.version(pkg)
        except importlib.metadata.PackageNotFoundError:
            versions[pkg] = None
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no")
    return {
        "time": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "git_commit": commit,
        "git_dirty": bool(status) if status is not None else None,
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "machine": platform.machine(),
        "platform": platform.platform(),
        "cpu": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "packages": versions,
    }


# -- pair records ---------------------------------------------------------------------------
MAX_SHAPE_POINTS = 64
MAX_HISTORY_POINTS = 400


def record(base: dict, status: str, message: str, **more: Any) -> dict:
    """A pair record with every field present (see ``reports.run.runner``)."""
    rec = {**base, "status": status, "message": message, "steps": [], "shapes": {}}
    rec.update({"extras": {}, "card": None, "timing": None, "warnings": [], "traceback": None})
    rec["exports"] = {}  # ParaView series / GIF paths relative to the run directory
    rec.update(more)
    return rec


def steps_json(sol: Solution) -> tuple[list[dict], dict, list[str]]:
    """JSON-level steps, last-step shapes (decimated) and warnings of a Solution."""
    steps, warnings = [], []
    for i, s in enumerate(sol.steps):
        outputs = {k: float(v) for k, v in s.outputs.items()}
        if sol.status == "converged" and not all(math.isfinite(v) for v in outputs.values()):
            warnings.append(f"converged step {i} has non-finite outputs")
        info = {k: v for k, v in s.info.items() if isinstance(v, (int, float, np.number))}
        steps.append(
            {
                "factor": float(s.factor),
                "outputs": outputs,
                "energy": float(s.energy),
                "iterations": int(s.iterations),
                "stable": s.stable,
                "max_stress": None if s.max_stress is None else float(s.max_stress),
                "info": info,
            }
        )
    shapes = {}
    if sol.steps:
        for member, pts in sol.steps[-1].shapes.items():
            pts = np.asarray(pts, dtype=float).reshape(-1, 2)
            if len(pts) > MAX_SHAPE_POINTS:
                pts = pts[np.linspace(0, len(pts) - 1, MAX_SHAPE_POINTS).round().astype(int)]
            shapes[str(member)] = pts
    return steps, shapes, warnings


def extras_json(extras: dict) -> dict:
    """JSON-safe subset: error estimate, time history (decimated) and small scalars/lists."""
    out = {}
    for k, v in extras.items():
        if k == "traceback":
            continue
        if k == "history" and isinstance(v, Mapping):
            hist = {str(h): np.asarray(a, dtype=float).ravel() for h, a in v.items()}
            step = max(1, max((a.size for a in hist.values()), default=0) // MAX_HISTORY_POINTS)
            out[k] = {h: a[::step] for h, a in hist.items()}
        elif isinstance(v, (int, float, str, bool, type(None), np.number)):
            out[k] = v
        elif isinstance(v, Mapping) or (isinstance(v, (list, tuple, np.ndarray)) and len(v) < 2000):
            out[k] = v
    return jsonable(out)


# -- results.json / csv ------------------------------------------------------------------------
def write_results(path: Path, payload: Mapping) -> Path:
    """Write ``results.json`` atomically (temp file + rename), one top-level key and one
    result record per line, each encoded on its own: the whole payload encoded at once (an
    indented ``dumps`` of ~40 MB) took ~250 MB and the pure-Python encoder's time."""
    tmp = path.with_suffix(".json.tmp")

    def enc(obj: Any) -> str:
        return json.dumps(jsonable(obj), allow_nan=False)

    with open(tmp, "w", encoding="utf-8") as f:
        f.write("{\n")
        for key, value in payload.items():
            if key != "results":
                f.write(f"{enc(key)}: {enc(value)},\n")
        f.write('"results": [')
        for i, rec in enumerate(payload.get("results", [])):
            f.write(("," if i else "") + "\n" + enc(rec))
        f.write("\n]\n}\n")
    tmp.replace(path)
    return path


def read_results(path: str | Path) -> dict[str, Any]:
    """Load ``results.json`` (a directory holding one is accepted).

    Raises
    ------
    ValueError
        The file is missing or not a FlexBench results file (message names it).
    """
    p = Path(path)
    if p.is_dir():
        p = p / "results.json"
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError:
        raise ValueError(f"{p}: no such results file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{p}: not a readable results file ({exc})") from None
    if isinstance(data, list):  # bare list of pair records
        data = {"results": data}
    if not isinstance(data, dict) or not isinstance(data.get("results"), list):
        raise ValueError(f"{p}: not a FlexBench results file (no 'results' list)")
    for rec in data["results"]:
        if not isinstance(rec, dict) or "case" not in rec or "model" not in rec:
            raise ValueError(f"{p}: results entries need 'case' and 'model'")
    return data


def csv_row(rec: Mapping) -> dict[str, Any]:
    """Flat CSV row of one pair record."""
    timing = rec.get("timing") or {}
    checks = rec.get("refchecks") or []
    return {
        "case": rec["case"],
        "model": rec["model"],
        "role": "reference" if rec.get("is_reference") else rec.get("role", "model"),
        "status": rec["status"],
        "n_steps": len(rec.get("steps") or ()),
        "wall_median_s": timing.get("median_s"),
        "wall_min_s": timing.get("min_s"),
        "wall_max_s": timing.get("max_s"),
        "wall_spread_s": timing.get("spread_s"),
        "n_repeats": timing.get("n_repeats"),
        "error_rel": rec.get("error_rel"),
        "error_L": rec.get("error_L"),
        "summary_basis": rec.get("summary_basis"),
        "speedup_vs_reference": rec.get("speedup_vs_reference"),
        "refs_passed": sum(1 for c in checks if c.get("passed")),
        "refs_total": len(checks),
        "message": (rec.get("message") or "").replace("\n", " ")[:300],
        "grade": (rec.get("grade") or {}).get("verdict"),
        "tolerance": (rec.get("grade") or {}).get("tolerance"),
        "validity_warning": (rec.get("grade") or {}).get("validity_warning"),
    }


def sweep_columns(cases: Mapping[str, Mapping] | None) -> dict[str, dict[str, Any]]:
    """Case name -> ``{"sweep_parent": parent, <parameter key>: value, ...}`` for the sweep
    points among ``cases`` (the run's case metadata; ``reports.run.sweep.point_meta``)."""
    out = {}
    for name, meta in (cases or {}).items():
        sw = meta.get("sweep") or {}
        if sw.get("parent"):
            out[name] = {"sweep_parent": sw["parent"], **dict(sw.get("point") or {})}
    return out


def write_csv(
    path: Path, records: Iterable[Mapping], cases: Mapping[str, Mapping] | None = None
) -> Path:
    """One row per pair (columns ``CSV_COLUMNS`` + ``GRADE_COLUMNS``, then, for a run with
    sweeps, ``sweep_parent`` and one column per swept parameter key, e.g.
    ``torsion_springs.S1.rest_angle_deg``; empty on the rows of other cases)."""
    points = sweep_columns(cases)
    params = list(dict.fromkeys(k for row in points.values() for k in row))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_COLUMNS + GRADE_COLUMNS + tuple(params))
        w.writeheader()
        for rec in records:
            row = csv_row(rec) | points.get(rec["case"], {})
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
    return path


# -- SQLite history ----------------------------------------------------------------------------
_SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    time TEXT, git_commit TEXT, git_dirty INTEGER, python TEXT, machine TEXT, cpu TEXT,
    cpu_count INTEGER, packages TEXT, config TEXT, out_dir TEXT, n_pairs INTEGER,
    elapsed_s REAL
);
CREATE TABLE IF NOT EXISTS results (
    run_id INTEGER NOT NULL REFERENCES runs(id),
    case_name TEXT NOT NULL, model TEXT NOT NULL, role TEXT, status TEXT, message TEXT,
    n_steps INTEGER, wall_median_s REAL, wall_min_s REAL, wall_max_s REAL, wall_spread_s REAL,
    n_repeats INTEGER, error_rel REAL, error_L REAL, summary_basis TEXT,
    speedup_vs_reference REAL,
    refs_passed INTEGER, refs_total INTEGER, errors TEXT,
    PRIMARY KEY (run_id, case_name, model)
);
CREATE INDEX IF NOT EXISTS results_case_model ON results (case_name, model);
"""


def _migrate(con: sqlite3.Connection) -> None:
    """Bring a history file written before the yardstick change up to the current schema:
    its ``summary_error`` held errors over L, so the column becomes ``error_L`` and an empty
    ``error_rel`` joins it (old runs have no own-scale errors; they are not invented)."""
    cols = {row[1] for row in con.execute("PRAGMA table_info(results)")}
    if "summary_error" in cols:
        con.execute("ALTER TABLE results RENAME COLUMN summary_error TO error_L")
        con.execute("ALTER TABLE results ADD COLUMN error_rel REAL")


def append_history(path: Path, payload: Mapping, out_dir: str, elapsed_s: float) -> int:
    """Append one run (``runs`` row) and its pairs (``results`` rows); returns the run id."""
    env = payload.get("environment", {})
    records = payload.get("results", [])
    path.parent.mkdir(parents=True, exist_ok=True)
    con = sqlite3.connect(path, timeout=30)
    try:
        with con:
            con.executescript(_SCHEMA)
            _migrate(con)
            cur = con.execute(
                "INSERT INTO runs (time, git_commit, git_dirty, python, machine, cpu, cpu_count,"
                " packages, config, out_dir, n_pairs, elapsed_s)"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    env.get("time"),
                    env.get("git_commit"),
                    None if env.get("git_dirty") is None else int(env["git_dirty"]),
                    env.get("python"),
                    env.get("machine"),
                    env.get("cpu"),
                    env.get("cpu_count"),
                    json.dumps(env.get("packages", {})),
                    json.dumps(jsonable(payload.get("config", {}))),
                    str(out_dir),
                    len(records),
                    float(elapsed_s),
                ),
            )
            run_id = int(cur.lastrowid)
            rows = []
            for rec in records:
                row = csv_row(rec)
                errors = (rec.get("errors") or {}).get("per_output")
                rows.append(
                    (run_id, *(row[c] for c in CSV_COLUMNS[:-1]), row["message"])
                    + (json.dumps(jsonable(errors)) if errors else None,)
                )
            con.executemany(
                "INSERT INTO results (run_id, case_name, model, role, status, n_steps,"
                " wall_median_s, wall_min_s, wall_max_s, wall_spread_s, n_repeats,"
                " error_rel, error_L, summary_basis, speedup_vs_reference, refs_passed,"
                " refs_total, message, errors) VALUES (" + ", ".join("?" * 19) + ")",
                rows,
            )
    finally:
        con.close()
    return run_id


def history_rows(path: Path, case: str, model: str) -> Sequence[tuple]:
    """(time, wall_median_s, error_rel, status) of a pair over all recorded runs."""
    con = sqlite3.connect(path)
    try:
        return con.execute(
            "SELECT runs.time, wall_median_s, error_rel, status FROM results"
            " JOIN runs ON runs.id = results.run_id WHERE case_name = ? AND model = ?"
            " ORDER BY runs.id",
            (case, model),
        ).fetchall()
    finally:
        con.close()


def assemble(
    records: Sequence[dict], metas: dict[str, dict], config: dict, env: dict | None = None
) -> dict[str, Any]:
    """Errors per case, cards, speed ratios, environment: the ``results.json`` payload."""
    order = {name: i for i, name in enumerate(metas)}
    records = sorted(records, key=lambda r: (order.get(r["case"], 1 << 30), r["model"]))
    cases = {}
    for name, meta in metas.items():
        mine = [r for r in records if r["case"] == name]
        cases[name] = {**meta, **errors.attach_errors(meta, mine)}
    for r in records:  # each result judged against a tolerance meant for it (grading.py)
        case_tols = (metas.get(r["case"]) or {}).get("tolerances") or ()
        r["grade"] = grading.grade(r, config.get("tolerance"), case_tols)
    cards = {}
    for r in records:
        if r.get("card") and r["model"] not in cards:
            cards[r["model"]] = r["card"]
    return {
        "format": FORMAT,
        "environment": env or environment(),
        "config": config,
        "cases": cases,
        "models": cards,
        "speed_ratios": errors.speed_ratios(records),
        "results": list(records),
    }
