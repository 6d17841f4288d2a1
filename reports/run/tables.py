"""Run files beside ``results.json`` that a reader or pandas takes directly, and the small
pieces of a pair record the report draws from (shapes along the path, how a scene is drawn).

``errors.csv`` (one row per pair and compared quantity; ``pandas.read_csv`` loads it)::

    case, model, role, status, basis, output, at_factor, error, error_unit, value_unit,
    wall_median_s, error_rel

* ``basis = "path"``: ``error`` is the largest deviation from the reference path over the
  load factors both reached (``reports.verdicts.errors``): translations divided by the length scale
  L (``error_unit = "L"``, value_unit = the case's length unit, ``1`` when
  dimensionless), rotations in rad, anything
  else relative to its largest reference magnitude (``"rel"``).
* ``basis = "published"``: one row per published/closed-form reference check, ``error``
  relative (``"rel"``) unless the reference gives an absolute tolerance (``"abs"``).

``results.json`` stays the nested record of the whole run (``json.load`` it;
``pandas.json_normalize(data["results"])`` flattens the pair records).
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cases.schema import Scene
from reports.verdicts import errors as E

ERRORS_CSV_COLUMNS = (
    "case",
    "model",
    "role",
    "status",
    "basis",
    "output",
    "at_factor",
    "error",
    "error_unit",
    "value_unit",
    "wall_median_s",
    "error_rel",
)
SHAPE_STEPS = 6  # deformed shapes kept per pair along the path (last step always)
MAX_SHAPE_POINTS = 64


def unit_names(units: str) -> dict[str, str]:
    """Length, force and energy unit names of a case's declared unit system.

    ``"mm-N-MPa"`` -> ``{"length": "mm", "force": "N", "energy": "N mm"}``; ``"nondim"``
    (or anything unparsed) -> empty strings.
    """
    parts = (units or "").split("-")
    if len(parts) < 2:
        return {"length": "", "force": "", "energy": "", "moment": ""}
    length, force = parts[0], parts[1]
    return {"length": length, "force": force, "energy": f"{force} {length}", "moment": ""}


def _quantity_units(key: str, units: str) -> tuple[str, str]:
    """(error unit, value unit) of an output key in a case with ``units``."""
    q = key.rsplit(".", 1)[-1]
    u = unit_names(units)
    if key != "factor" and q in E.TRANSLATIONS:
        return "L", u["length"] or "1"
    if q == "rot":
        return "rad", "rad"
    if key.startswith("driver.force"):
        return "rel", u["force"] or "1"
    return "rel", ""


def error_rows(payload: Mapping) -> list[dict[str, Any]]:
    """Rows of ``errors.csv`` (see module docstring)."""
    rows = []
    for rec in payload.get("results", []):
        case = payload.get("cases", {}).get(rec["case"], {})
        units = case.get("units", "")
        base = {
            "case": rec["case"],
            "model": rec["model"],
            "role": "reference" if rec.get("is_reference") else rec.get("role", "model"),
            "status": rec["status"],
            "wall_median_s": (rec.get("timing") or {}).get("median_s"),
            "error_rel": rec.get("error_rel"),
        }
        for key, err in sorted(((rec.get("errors") or {}).get("per_output") or {}).items()):
            eu, vu = _quantity_units(key, units)
            more = {"output": key, "at_factor": None, "error": err}
            rows.append({**base, **more, "basis": "path", "error_unit": eu, "value_unit": vu})
        for c in rec.get("refchecks") or []:
            more = {"output": c["output"], "at_factor": c.get("at_factor"), "error": c.get("error")}
            more["error_unit"] = "abs" if c.get("abs_tolerance") else "rel"
            more["value_unit"] = _quantity_units(c["output"], units)[1]
            rows.append({**base, **more, "basis": "published"})
    return rows


def write_errors_csv(path: Path, payload: Mapping) -> Path:
    """Write ``errors.csv`` (columns ``ERRORS_CSV_COLUMNS``; empty cell = not available)."""
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=ERRORS_CSV_COLUMNS)
        w.writeheader()
        for row in error_rows(payload):
            w.writerow({k: ("" if row.get(k) is None else row[k]) for k in ERRORS_CSV_COLUMNS})
    return path


def results_from_argv(argv: list[str], module: str) -> dict | None:
    """The ``results.json`` named by a module's one command-line argument, or None after
    printing the usage or the reason it cannot be read (one line on stderr)."""
    import sys

    if len(argv) != 1:
        print(f"usage: python -m {module} OUT/results.json", file=sys.stderr)
        return None
    try:
        return json.loads(Path(argv[0]).read_text())
    except (OSError, ValueError) as exc:
        print(f"{argv[0]}: cannot read results: {exc}", file=sys.stderr)
        return None


def previous_records(path: Path) -> list[dict]:
    """Pair records of a finished run's ``results.json`` (resume after ``partial.jsonl`` was
    removed); empty when there is none or it is unreadable."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return []
    recs = data.get("results") if isinstance(data, dict) else None
    return [r for r in recs if isinstance(r, dict)] if isinstance(recs, list) else []


def step_shapes(sol: Any, n: int = SHAPE_STEPS) -> dict[str, dict[str, np.ndarray]]:
    """Deformed shapes of up to ``n`` steps spread along the path, the last one included:
    step index (as a string) -> member id -> (m, 2) points (at most ``MAX_SHAPE_POINTS``)."""
    steps = [i for i, s in enumerate(sol.steps) if s.shapes]
    if not steps:
        return {}
    picks = sorted({steps[round(j)] for j in np.linspace(0, len(steps) - 1, min(n, len(steps)))})
    out = {}
    for i in picks:
        shapes = {}
        for member, pts in sol.steps[i].shapes.items():
            p = np.asarray(pts, dtype=float).reshape(-1, 2)
            if len(p) > MAX_SHAPE_POINTS:
                p = p[np.linspace(0, len(p) - 1, MAX_SHAPE_POINTS).round().astype(int)]
            shapes[str(member)] = p
        out[str(i)] = shapes
    return out


def scene_drawing(scene: Scene) -> dict[str, Any]:
    """What the report needs to draw a scene: member kinds, supports and pinned joints."""
    pos = {n.id: (n.x, n.y) for n in scene.nodes}
    pins = sorted(
        {m.a for m in scene.members if m.end_a == "pin"}
        | {m.b for m in scene.members if m.end_b == "pin"}
    )
    return {
        "member_kinds": {m.id: m.kind for m in scene.members},
        "supports": [
            {"node": s.node, "type": s.type, "xy": list(pos[s.node])}
            for s in scene.supports
            if s.node in pos
        ],
        "pins": [list(pos[p]) for p in pins if p in pos],
    }


def scene_hash(scene: Scene) -> str:
    """Content hash of a scene (its repr covers every field, options included)."""
    return hashlib.sha1(repr(scene).encode()).hexdigest()[:12]


def case_meta(scene: Scene) -> dict[str, Any]:
    """What the report and ``compare`` need to know about a case without loading it."""
    lengths = [scene.member_length(m.id) for m in scene.members]
    length = max(lengths, default=0.0) or 1.0
    undeformed = {}
    for m in scene.members:
        a, b = scene.node(m.a), scene.node(m.b)
        undeformed[m.id] = [[a.x, a.y], [b.x, b.y]]
    return {
        "name": scene.name,
        "title": scene.title,
        "units": scene.units,
        "tags": list(scene.tags),
        "description": scene.description,
        "path": scene.path,
        "reference_model": scene.reference_model,
        "length_scale": length,
        "analysis": dataclasses.asdict(scene.analysis),
        "outputs": [dataclasses.asdict(o) for o in scene.outputs],
        "primary_output": scene.outputs[0].name if scene.outputs else None,
        "references": [dataclasses.asdict(r) for r in scene.references],
        "tolerances": [dataclasses.asdict(t) for t in scene.tolerances],
        "undeformed": undeformed,
        **scene_drawing(scene),
        "scene_hash": scene_hash(scene),
    }


def code_hash() -> str:
    """Hash of the solver packages' sources: a resumed run never reuses stale answers."""
    import importlib

    h = hashlib.sha1()
    for name in ("cases", "reduced_models", "fem_reference"):
        try:
            pkg = importlib.import_module(name)
        except ImportError:
            continue
        for base in getattr(pkg, "__path__", []):
            for f in sorted(Path(base).rglob("*.py")):
                h.update(str(f.relative_to(base)).encode())
                h.update(f.read_bytes())
    return h.hexdigest()[:12]
