"""Sweep cases in the benchmark matrix: one scene (and one stored row per model) per grid point.

``cases.sweep.expand`` does the expansion (pure scene data); this module decides what the
runner does with it: point scenes run the models their parent case names (plus the
reference), not the whole default list, so a 125-point grid costs 125 x (a few) solves; each
point's meta carries its parent and coordinates so the report can draw stability maps.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from cases.schema import Scene
from cases.sweep import expand


def expand_all(scenes: Sequence[Scene]) -> list[Scene]:
    """Every sweep scene replaced by its point scenes (others unchanged, order kept)."""
    return [p for s in scenes for p in expand(s)]


def point_meta(scene: Scene) -> dict[str, Any]:
    """``{"sweep": {"parent", "point": {key: value}}}`` for a point scene, else ``{}``."""
    if scene.sweep_parent is None:
        return {}
    return {"sweep": {"parent": scene.sweep_parent, "point": dict(scene.sweep_point)}}


def uses_defaults(scene: Scene) -> bool:
    """Whether the default model list is added for this scene (not for sweep points)."""
    return scene.sweep_parent is None


def single_shot(scene: Scene, policy: Any) -> Any:
    """Sweep points are timed once (the sweep's total is the figure of merit, not the
    median of repeats of one point): ``policy`` with no repeats for points."""
    if scene.sweep_parent is None or policy is None:
        return policy
    return dataclasses.replace(policy, cold_cap_s=0.0, max_runs=1, min_runs=1)


def export_for(scene: Scene, policy: Any) -> Any:
    """No ParaView series or GIFs per sweep point (hundreds of them): None for points."""
    return policy if scene.sweep_parent is None else None


def bench(case: str, model: str, workers: int = 2, dask: bool = False) -> dict[str, Any]:
    """Run one sweep case with one model through the runner (local pool, or a 2-worker Dask
    ``LocalCluster``); wall time of the solving (no report) and the verdicts per point."""
    import tempfile
    import time

    import cases
    from reports import runner

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
    """``python -m reports.sweep CASE MODEL [--dask]``: time a sweep, print verdict counts."""
    import collections

    if len(argv) < 2:
        print("usage: python -m reports.sweep CASE MODEL [--dask]")
        return 2
    out = bench(argv[0], argv[1], dask="--dask" in argv)
    counts = collections.Counter(out["verdicts"].values())
    backend = "dask LocalCluster(2)" if "--dask" in argv else "local pool(2)"
    print(f"{argv[0]} x {argv[1]} on {backend}: {out['points']} points in {out['wall_s']:.2f} s")
    for (status, stable), n in sorted(counts.items(), key=str):
        print(f"  {status:<10} stable={stable}: {n}")
    return 0


if __name__ == "__main__":
    import sys

    raise SystemExit(main(sys.argv[1:]))
