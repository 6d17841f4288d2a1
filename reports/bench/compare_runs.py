"""``python -m reports.bench.compare_runs A/results.json B/results.json [--rtol 1e-12]``: are
two runs' answers the same?

For every (case, model) pair of either run: the status, the number of steps and, step by
step, the load factor, every output, the energy and the stability verdict.  Two numbers agree
when ``|a - b| <= rtol * scale``, ``scale`` being the largest magnitude of that quantity over
the pair's path in either run (so an output passing through zero is judged at the size it
has, not at the zero), and at least the case's length scale for a position or displacement
(``.x .y .ux .uy``) and 1 rad for a rotation (``.rot``): an output that is zero by symmetry
carries only round-off (1e-20 L), whose digits are not an answer.  Messages, timings and
extras are not answers and are not compared.

Prints the pairs compared, the numbers compared, the largest difference (relative to its
scale) and every pair that differs; exit 1 if any does, 2 on a missing or unreadable file.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Outcome:
    """Pairs and numbers compared, the largest scaled difference (and where), and the
    differences above the tolerance."""

    pairs: int = 0
    numbers: int = 0
    worst: float = 0.0
    worst_at: str = ""
    differences: list[str] = field(default_factory=list)
    only_in: list[str] = field(default_factory=list)


def _pairs(payload: Mapping) -> dict[tuple[str, str], Mapping]:
    return {(r["case"], r["model"]): r for r in payload.get("results", [])}


def _series(steps: Sequence[Mapping]) -> Iterator[tuple[str, list]]:
    """(quantity, values along the path) of a pair's steps."""
    yield "factor", [s.get("factor") for s in steps]
    yield "energy", [s.get("energy") for s in steps]
    yield "stable", [s.get("stable") for s in steps]
    keys = dict.fromkeys(k for s in steps for k in (s.get("outputs") or {}))
    for k in keys:
        yield k, [(s.get("outputs") or {}).get(k) for s in steps]


def _number(v: object) -> float | None:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None


def _floor(name: str, length: float) -> float:
    """Smallest scale of a quantity (module docstring)."""
    if name.endswith((".x", ".y", ".ux", ".uy")):
        return length
    return 1.0 if name.endswith(".rot") else 0.0


def compare(a: Mapping, b: Mapping, rtol: float) -> Outcome:
    """Compare the answers of two ``results.json`` payloads (module docstring)."""
    out = Outcome()
    pa, pb = _pairs(a), _pairs(b)
    out.only_in = [f"{c} x {m}" for c, m in sorted(set(pa) ^ set(pb))]
    for key in sorted(set(pa) & set(pb)):
        ra, rb = pa[key], pb[key]
        where = f"{key[0]} x {key[1]}"
        out.pairs += 1
        if ra["status"] != rb["status"]:
            why = rb["message"] if ra["status"] == "converged" else ra["message"]
            out.differences.append(
                f"{where}: status {ra['status']} -> {rb['status']} ({why.splitlines()[0][:80]})"
            )
            continue
        sa, sb = ra.get("steps") or [], rb.get("steps") or []
        if len(sa) != len(sb):
            out.differences.append(f"{where}: {len(sa)} -> {len(sb)} steps")
            continue
        series_b = dict(_series(sb))
        length = float((a.get("cases") or {}).get(key[0], {}).get("length_scale") or 0.0)
        for name, va in _series(sa):
            vb = series_b.get(name, [None] * len(va))
            nums = [abs(x) for x in map(_number, va + vb) if x is not None and math.isfinite(x)]
            scale = max(max(nums, default=0.0), _floor(name, length))
            for i, (x, y) in enumerate(zip(va, vb)):
                out.numbers += 1
                fx, fy = _number(x), _number(y)
                if fx is None or fy is None or not (math.isfinite(fx) and math.isfinite(fy)):
                    same = x == y or (fx is not None and fy is not None and fx != fx and fy != fy)
                    if not same:
                        out.differences.append(f"{where}: {name}[{i}] {x!r} -> {y!r}")
                    continue
                d = abs(fx - fy) / scale if scale else 0.0
                if d > out.worst:
                    out.worst, out.worst_at = d, f"{where}: {name}[{i}]"
                if d > rtol:
                    out.differences.append(f"{where}: {name}[{i}] {fx!r} -> {fy!r} ({d:.2e})")
    return out


def _load(path: str) -> Mapping:
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        print(f"compare_runs: {path}: {exc}", file=sys.stderr)
        raise SystemExit(2) from None


def main(argv: Sequence[str] | None = None) -> int:
    """Command line (module docstring)."""
    p = argparse.ArgumentParser(prog="python -m reports.bench.compare_runs", description=__doc__)
    p.add_argument("a", help="results.json of the first run")
    p.add_argument("b", help="results.json of the second run")
    p.add_argument("--rtol", type=float, default=1e-12, help="tolerance relative to scale")
    args = p.parse_args(argv)
    out = compare(_load(args.a), _load(args.b), args.rtol)
    print(
        f"{out.pairs} pairs, {out.numbers} numbers compared; largest difference "
        f"{out.worst:.3e} of scale ({out.worst_at or 'none'}); "
        f"{len(out.differences)} above rtol {args.rtol:g}"
    )
    for line in out.only_in:
        print(f"  only in one run: {line}")
    for line in out.differences:
        print(f"  {line}")
    return 1 if out.differences else 0


if __name__ == "__main__":
    sys.exit(main())
