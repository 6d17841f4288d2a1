"""Mutated catalog cases for the fuzz test, and the oracle that judges one solve of them.

``mutate(rng)`` takes a catalog case and applies one to three mutations drawn from ``rng``
(a ``random.Random``; hypothesis passes its own): hostile values (wrong types, NaN, 1e300,
400-digit integers, tiny numbers, huge step counts), structure (deleted keys and entries,
duplicated entries, unknown keys, tables replaced by scalars), sizes (arrays grown by up to
6000 entries, options nested thousands deep) and syntax (truncation, stray characters,
duplicated or dropped lines).

``outcome(path, model)`` runs ``flexbench solve PATH --model MODEL --json`` in-process and
classifies the result into the three allowed outcomes -- ``error`` (exit 2, one line naming
the file), ``declined`` (``failed``/``not-applicable`` with a reason; ``time-limit`` counted
apart), ``converged`` (finite outputs on a scene the loader accepted) -- or ``BAD: ...``.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import random
import re
import time
import tomllib
from pathlib import Path
from typing import Any

import cases
from reports import cli

MODELS = ("elastica", "linear-4", "prb-3r", "cbcm-3", "fem-16", "replay")
TIME_LIMIT_S = 20.0  # per solve (--time-limit); the oracle allows 10 s more for start-up
HOSTILE = (
    0,
    -1,
    -0.0,
    1e300,
    -1e300,
    1e-300,
    10**400,
    -(10**30),
    math.nan,
    math.inf,
    -math.inf,
    10**7,
    10**9,
    1e9,
    "",
    "x",
    "<b>x</b>",
    True,
    [],
    {},
    [1, "a"],
    {"k": 1},
    1e30,
    1e-30,
    1e31,
    0.5,
    -2.5,
    1e6,
    1e-6,
)
SCALES = (-1.0, 0.0, 1e-9, 1e-3, 10.0, 1e6, 1e12)


# -- a small TOML writer (tomllib reads only) -----------------------------------------------------
def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dumps(data: dict) -> str:
    """TOML text of a parsed case (top-level scalars, tables, arrays of tables)."""
    lines = [f"{_key(k)} = {_value(v)}" for k, v in data.items() if not _is_table(v)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]"] + [f"{_key(a)} = {_value(b)}" for a, b in v.items()]
        elif _is_table(v):
            for item in v:
                lines += ["", f"[[{_key(k)}]]"]
                lines += [f"{_key(a)} = {_value(b)}" for a, b in item.items()]
    return "\n".join(lines) + "\n"


def _is_table(v: Any) -> bool:
    return isinstance(v, dict) or (
        isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)
    )


# -- mutations ---------------------------------------------------------------------------------
def _slots(obj: Any, leaves_only: bool) -> list[tuple[Any, Any]]:
    """(container, key) of every value in the tree (iterative)."""
    out, todo = [], [obj]
    while todo:
        c = todo.pop()
        items = c.items() if isinstance(c, dict) else enumerate(c)
        for k, v in items:
            if isinstance(v, dict | list):
                todo.append(v)
                if not leaves_only:
                    out.append((c, k))
            else:
                out.append((c, k))
    return out


def _arrays(data: dict) -> list[str]:
    """Names of the non-empty arrays of tables."""
    return [k for k, v in data.items() if _is_table(v) and isinstance(v, list)]


def _value_mutation(data: dict, rng: random.Random) -> None:
    slots = _slots(data, leaves_only=True)
    if not slots:
        return
    c, k = rng.choice(slots)
    if isinstance(c[k], int | float) and not isinstance(c[k], bool) and rng.random() < 0.5:
        c[k] = c[k] * rng.choice(SCALES)
    else:
        c[k] = rng.choice(HOSTILE)


def _analysis_mutation(data: dict, rng: random.Random) -> None:
    a = data.setdefault("analysis", {"kind": "load"})
    if isinstance(a, dict):
        key = rng.choice(("steps", "max_steps", "factor_end", "kind", "stop_value"))
        a[key] = rng.choice((*HOSTILE, 1, 2, 10_000, 10_001, -1, "path", "load", "sweep"))


def _delete(data: dict, rng: random.Random) -> None:
    if slots := _slots(data, leaves_only=False):
        c, k = rng.choice(slots)
        del c[k]


def _duplicate(data: dict, rng: random.Random) -> None:
    if arrays := _arrays(data):
        arr = data[rng.choice(arrays)]
        arr.append(json.loads(json.dumps(rng.choice(arr), default=str)))


def _unknown_key(data: dict, rng: random.Random) -> None:
    tables = [c[k] for c, k in _slots(data, leaves_only=False) if isinstance(c[k], dict)]
    target = rng.choice(tables) if tables else data
    target[rng.choice(("bogus", "E", "id", "kind", "node", "name"))] = rng.choice(HOSTILE)


def _retype(data: dict, rng: random.Random) -> None:
    key = rng.choice(list(data) or ["case"])
    data[key] = rng.choice(("x", 1, [], [1, 2], {}, [{}]))


def _grow(data: dict, rng: random.Random) -> None:
    if arrays := _arrays(data):
        name = rng.choice(arrays)
        n = rng.choice((10, 100, 501, 600, 6000))
        base = data[name][-1]
        for i in range(n):
            item = dict(base)
            for key in ("id", "name"):
                if isinstance(item.get(key), str) and rng.random() < 0.9:
                    item[key] = f"{item[key]}{i}"
            data[name].append(item)


STRUCTURAL = (_value_mutation, _analysis_mutation, _delete, _duplicate, _unknown_key, _retype)


def _text_mutation(text: str, rng: random.Random) -> str:
    kind = rng.randrange(6)
    pos = rng.randrange(len(text) + 1)
    lines = text.splitlines()
    i = rng.randrange(len(lines)) if lines else 0
    if kind == 0:
        return text[:pos]
    if kind == 1:
        stray = rng.choice(("[", "]", "{", '"', "=", "\\", "\x00", "é", "\n"))
        return text[:pos] + stray + text[pos:]
    if kind == 2 and lines:
        return "\n".join(lines[: i + 1] + lines[i:]) + "\n"
    if kind == 3 and lines:
        return "\n".join(lines[:i] + lines[i + 1 :]) + "\n"
    if kind == 4:
        depth = rng.choice((2, 20, 300, 3000))
        deep = "[" * depth + "]" * depth
        return text + f'\n[[models]]\nname = "elastica"\noptions = {{x = {deep}}}\n'
    return text + '\n[[models]]\nname = "elastica"\n' + "[models.options]\n" + "a." * 50 + "b = 1\n"


def mutate(rng: random.Random) -> tuple[str, str, list[str]]:
    """A mutated catalog case: (case name, TOML text, names of the mutations applied)."""
    name = rng.choice(cases.catalog_names())
    data = tomllib.loads((cases.CATALOG / f"{name}.toml").read_text())
    applied = []
    for _ in range(rng.randint(1, 3)):
        roll = rng.random()
        if roll < 0.6:
            m = rng.choice(STRUCTURAL)
            m(data, rng)
        elif roll < 0.7:
            m = _grow
            m(data, rng)
        else:
            m = None
        applied.append(m.__name__.strip("_") if m else "text")
    text = dumps(data)
    if "text" in applied:
        text = _text_mutation(text, rng)
    return name, text, applied


# -- the oracle ------------------------------------------------------------------------------------
def outcome(path: Path, model: str, time_limit: float = TIME_LIMIT_S) -> str:
    """One allowed outcome (``error``, ``declined``, ``time-limit``, ``converged``) or
    ``BAD: why`` for anything else (a traceback, exit 3, a hang, a non-finite answer)."""
    out, err = io.StringIO(), io.StringIO()
    argv = ["solve", str(path), "--model", model, "--json", "--time-limit", str(time_limit)]
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    wall = time.perf_counter() - t0
    out, err = out.getvalue(), err.getvalue()
    if wall > time_limit + 10:
        return f"BAD: ran {wall:.0f} s past the {time_limit:g} s limit"
    if code == 2:
        one_line = err.count("\n") == 1 and "Traceback" not in err
        return "error" if one_line and str(path) in err else f"BAD: exit 2 but {err[:300]!r}"
    if code != 0:
        return f"BAD: exit {code}: {err[:300]!r}"
    sol = json.loads(out)
    if sol["status"] in ("failed", "not-applicable"):
        if not sol["message"].strip():
            return "BAD: no reason given"
        return "time-limit" if "time limit" in sol["message"] else "declined"
    values = [v for s in sol["steps"] for v in (s["factor"], *s["outputs"].values())]
    if not sol["steps"] or any(v is None for v in values):
        return "BAD: converged with no steps or non-finite outputs"
    return "converged"
