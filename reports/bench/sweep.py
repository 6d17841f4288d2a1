"""``python -m reports.bench.sweep CASE MODEL [--dask]``: one sweep case with one model through
the runner, on the local pool or a 2-worker Dask ``LocalCluster``; wall time and verdict
counts."""

from __future__ import annotations

import collections
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

import cases
from reports.run import runner


def bench(case: str, model: str, workers: int = 2, dask: bool = False) -> dict[str, Any]:
    """Run one sweep case with one model through the runner (local pool, or a 2-worker Dask
    ``LocalCluster``); wall time of the solving (no report) and the verdicts per point."""
    scene = cases.load(case)
    cluster = None
    address = None
    if dask:
        from distributed import LocalCluster

        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        )
        address = cluster.scheduler_address
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            res = runner.run_matrix(
                [scene], [model], tmp, workers=workers, dask=address, render=False,
                export=None, progress=False, fresh=True,
            )  # fmt: skip
            wall = time.perf_counter() - t0
    finally:
        if cluster is not None:
            cluster.close()
    rows = [r for r in res.payload["results"] if r["model"] == model]
    verdicts = {
        r["case"]: (r["status"], r["steps"][-1]["stable"] if r.get("steps") else None) for r in rows
    }
    return {"wall_s": wall, "points": len(rows), "verdicts": verdicts}


def main(argv: Sequence[str]) -> int:
    """``python -m reports.bench.sweep CASE MODEL [--dask]``: time a sweep, print verdict counts."""
    if len(argv) < 2:
        print("usage: python -m reports.bench.sweep CASE MODEL [--dask]")
        return 2
    out = bench(argv[0], argv[1], dask="--dask" in argv)
    counts = collections.Counter(out["verdicts"].values())
    backend = "dask LocalCluster(2)" if "--dask" in argv else "local pool(2)"
    print(f"{argv[0]} x {argv[1]} on {backend}: {out['points']} points in {out['wall_s']:.2f} s")
    for (status, stable), n in sorted(counts.items(), key=str):
        print(f"  {status:<10} stable={stable}: {n}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
