"""Reference pairs kept across runs: a rerun into a new folder does not solve them again.

The references (``fem-auto``, the ``replay``, a sweep's reference model) are the dearest
pairs of a case and do not change while neither the scene nor the code does.  A finished
reference record is written to ``$FLEXBENCH_CACHE/pairs-<version>/<key hash>.json.gz``
(``reports.verdicts.cost.cache_dir``) with the ParaView / GIF files it exported; a later run
whose task has the same key (scene content, model, options, quick, timing policy and the
solver packages' code hash: ``runner.plan``) takes the record and copies the files into its
own folder instead of solving.  ``<version>`` hashes the sources that build and serialise a
record (``reports/api.py``, ``reports/run``, ``reports/verdicts``), so a change there starts
a new cache; older versions are removed.  The record says ``"cached": true``; its timing is
the one measured when it was solved (same code, same machine's cache folder).
Set ``FLEXBENCH_NO_PAIR_CACHE=1`` to solve every pair.
"""

from __future__ import annotations

import functools
import gzip
import hashlib
import json
import os
import shutil
from pathlib import Path

from reports.verdicts.cost import cache_dir

KEEP_VERSIONS = 2  # cache folders of other code versions kept (branches switched back and forth)


def cacheable(task: dict) -> bool:
    """A reference pair (or an FE / replay pair, the references' own models) of a
    non-sweep case or a sweep point."""
    return task["role"] == "reference" or task["model"].startswith(("fem-", "replay"))


@functools.cache
def version() -> str:
    """Hash of the sources that build and serialise a pair record."""
    root = Path(__file__).resolve().parents[1]  # reports/
    h = hashlib.sha1()
    for f in [root / "api.py", *sorted((root / "run").glob("*.py"))]:
        h.update(f.name.encode() + f.read_bytes())
    for f in sorted((root / "verdicts").glob("*.py")):
        h.update(f.name.encode() + f.read_bytes())
    return h.hexdigest()[:12]


def _folder() -> Path | None:
    if os.environ.get("FLEXBENCH_NO_PAIR_CACHE"):
        return None
    return cache_dir() / f"pairs-{version()}"


def _name(key: str) -> str:
    return hashlib.sha1(key.encode()).hexdigest()[:20]


def _export_files(rec: dict) -> list[str]:
    """Relative paths of every file a record's exports name (ParaView folders included)."""
    out: list[str] = []
    for entry in (rec.get("exports") or {}).values():
        vals = entry.values() if isinstance(entry, dict) else [entry]
        out += [v for v in vals if isinstance(v, str) and "/" in v]
    return out


def _copy(rel_paths: list[str], src: Path, dst: Path) -> None:
    for rel in rel_paths:
        a, b = src / rel, dst / rel
        if a.is_dir():
            shutil.copytree(a, b, dirs_exist_ok=True)
        elif a.is_file():
            b.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(a, b)


def lookup(task: dict, out: Path) -> dict | None:
    """The cached record of ``task`` with its exported files copied into ``out``, or None."""
    folder = _folder()
    if folder is None or not cacheable(task):
        return None
    path = folder / f"{_name(task['key'])}.json.gz"
    try:
        with gzip.open(path, "rt") as fh:
            rec = json.load(fh)
        if rec.get("key") != task["key"]:  # a hash collision, however unlikely
            return None
        _copy(_export_files(rec), folder / "files", out)
    except (OSError, ValueError, EOFError):
        return None
    return rec | {"cached": True}


def store(task: dict, rec: dict, out: Path) -> None:
    """Keep ``rec`` (a finished, not retried reference pair) and its exported files; a cache
    that cannot be written is skipped silently (the run's own results are unaffected)."""
    folder = _folder()
    if folder is None or not cacheable(task) or rec.get("retry") or rec.get("cached"):
        return
    try:
        if not folder.is_dir():
            folder.mkdir(parents=True, exist_ok=True)
            _prune(folder)
        _copy(_export_files(rec), out, folder / "files")
        path = folder / f"{_name(task['key'])}.json.gz"
        tmp = path.with_suffix(f".tmp{os.getpid()}")
        with gzip.open(tmp, "wt", compresslevel=1) as fh:
            json.dump(rec, fh)
        os.replace(tmp, path)
    except OSError:
        return


def _prune(current: Path) -> None:
    """Remove all but the newest ``KEEP_VERSIONS`` other pair-cache folders."""
    others = [p for p in current.parent.glob("pairs-*") if p.is_dir() and p != current]
    others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for p in others[KEEP_VERSIONS:]:
        shutil.rmtree(p, ignore_errors=True)
