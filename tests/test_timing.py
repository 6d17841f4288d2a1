"""Pair timing: solve and post-processing timed apart, CPU beside wall, BLAS pinned, CPU ratios.

No timing is asserted (speed is measured by ``python -m reports.bench``, never in tests);
these tests check what the records say and that the timed call does not draw shapes.
"""

from __future__ import annotations

import cases
from reduced_models.base import Solution, Step
from reports import api
from reports.run import pair, runner, timing
from reports.verdicts import errors


class CountingModel:
    """A model whose solve and post-processing count their calls."""

    name = "counting"
    card = None

    def __init__(self) -> None:
        self.solves = self.posts = 0

    def applies_to(self, scene: cases.Scene) -> None:
        return None

    def solve(self, scene: cases.Scene) -> Solution:
        self.solves += 1
        return Solution(scene.name, self.name, "converged", "ok", (Step(0.0, {"tip.ux": 0.0}),))

    def postprocess(self, scene: cases.Scene, sol: Solution) -> Solution:
        self.posts += 1
        return sol


def test_api_solve_post_processes_and_the_runner_times_the_solve_alone():
    scene = cases.load("cantilever-tip-load")
    m = CountingModel()
    api.run_model(m, scene)
    assert (m.solves, m.posts) == (1, 1)
    api.run_model(m, scene, post=False)
    assert (m.solves, m.posts) == (2, 1)


def test_record_has_cpu_wall_noise_and_post_times_and_prb_shapes():
    scene = cases.load("cantilever-tip-load")
    task = {
        "key": "k",
        "case": scene.name,
        "model": "prb-3r",
        "role": "model",
        "scene": scene,
        "target": api.resolve("prb-3r")[2],
        "n": None,
        "options": {},
        "timing": runner.QUICK_TIMING,
    }
    rec = pair.solve_task(task)
    t = rec["timing"]
    for p in ("", "cpu_"):
        assert t[f"{p}min_s"] <= t[f"{p}median_s"] <= t[f"{p}max_s"]
    assert t["post_cpu_s"] >= 0.0 and t["post_s"] >= 0.0 and t["first_cpu_s"] >= 0.0
    # the post-processing ran once, after the timed solves: the PRB's own 5-point chain
    assert len(rec["shapes"]["beam"]) == 5


def test_blas_pinned_to_one_thread_in_the_worker():
    import scipy.linalg  # noqa: F401  (a second OpenBLAS is loaded by scipy)
    from threadpoolctl import threadpool_info

    timing.pin_blas()
    assert all(d["num_threads"] == 1 for d in threadpool_info() if d["user_api"] == "blas")


def test_ratios_use_cpu_time():
    rec = {"timing": {"median_s": 9.0, "cpu_median_s": 1.0}}
    old = {"timing": {"median_s": 2.0}}  # a record from before CPU times: its wall time
    assert errors.cost_s(rec) == 1.0 and errors.cost_s(old) == 2.0 and errors.cost_s(None) is None
