"""Runner: pair records, errors against a known reference, timing fields, resume, pool, Dask.

The runner mechanics are tested with tiny dummy models defined here (registered for the test
only, importable as ``tests.test_runner:...`` by pool and Dask workers) whose errors are known
in closed form: ``dummy-scaled`` is the exact linear cantilever with every displacement scaled
by ``1 + eps``, so its path error is exactly ``eps * max|u_ref|`` (translations / L) and
``eps * max|rot_ref|`` (rad).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import time

import numpy as np
import pytest

import cases
from reduced_models import registry
from reduced_models.base import ModelCard, Solution, Step, load_factors
from reports.run import pool, runner, store
from reports.verdicts import errors

# -- dummy models (small-deflection cantilever: uy = P L^3 / 3EI, rot = P L^2 / 2EI) -----------


class LinearTip:
    """Linear-theory cantilever; ``scale`` multiplies every displacement (a wrong model)."""

    card = ModelCard(
        name="dummy-exact",
        family="dummy",
        summary="test dummy: linear cantilever tip formula",
        assumptions=("small deflections",),
        validity="tests only",
        references=("Timoshenko & Gere, Theory of Elastic Stability",),
    )

    def __init__(self, scale: float = 1.0, stop_after: int | None = None):
        self.scale, self.stop_after = scale, stop_after
        self.name = "dummy"

    def applies_to(self, scene):
        return None if len(scene.members) == 1 else "single member only"

    def solve(self, scene):
        m = scene.members[0]
        L, EI = scene.member_length(m.id), m.EI
        P = sum(ld.fy for ld in scene.loads)
        steps = []
        for i, lam in enumerate(load_factors(scene)):
            if self.stop_after is not None and i > self.stop_after:
                return Solution(scene.name, self.name, "failed", "stopped on purpose", tuple(steps))
            uy = self.scale * lam * P * L**3 / (3 * EI)
            rot = self.scale * lam * P * L**2 / (2 * EI)
            s = np.linspace(0, 1, 11)
            shape = np.column_stack([s * L, uy * (3 * s**2 - s**3) / 2])
            out = {"tip.x": L, "tip.y": uy, "tip.ux": 0.0, "tip.uy": uy, "tip.rot": rot}
            steps.append(
                Step(
                    factor=float(lam),
                    outputs=out,
                    energy=0.5 * lam * P * uy,
                    iterations=1,
                    stable=True,
                    shapes={m.id: shape},
                )  # fmt: skip
            )
        return Solution(scene.name, self.name, "converged", "closed form", tuple(steps))


class Scaled(LinearTip):
    """The exact dummy with a deliberate relative error (case option ``scale``)."""


class Half(LinearTip):
    """Converges on the first half of the path, then reports ``failed`` honestly."""

    def __init__(self) -> None:
        super().__init__(stop_after=4)


class Crash(LinearTip):
    """Raises inside solve (the runner must record ``failed``, not crash)."""

    def solve(self, scene):
        raise RuntimeError("boom in the dummy")


class Picky(LinearTip):
    """Never applies."""

    def applies_to(self, scene):
        return "dummy declines every scene"


class Killer(LinearTip):
    """Kills its worker process (a segfault stand-in)."""

    def solve(self, scene):
        os._exit(13)


class Sleeper(LinearTip):
    """Takes far too long (the soft time limit interrupts it)."""

    def solve(self, scene):
        time.sleep(60)


class Deaf(LinearTip):
    """Takes far too long and ignores the soft limit (the worker must be killed)."""

    def solve(self, scene):
        signal.signal(signal.SIGALRM, signal.SIG_IGN)
        time.sleep(60)


DUMMIES = {
    "dummy-sleep": "tests.test_runner:Sleeper",
    "dummy-deaf": "tests.test_runner:Deaf",
    "dummy-exact": "tests.test_runner:LinearTip",
    "dummy-scaled": "tests.test_runner:Scaled",
    "dummy-half": "tests.test_runner:Half",
    "dummy-crash": "tests.test_runner:Crash",
    "dummy-na": "tests.test_runner:Picky",
    "dummy-killer": "tests.test_runner:Killer",
}
EPS = 0.01
P = 0.3

CASE_TOML = """
[case]
name = "{name}"
title = "Dummy cantilever {name}"
units = "nondim"
tags = ["test"]
reference_model = "dummy-exact"
description = "A tiny case for runner tests."

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 1.0
y = 0.0

[[members]]
id = "beam"
from = "A"
to = "B"
kind = "flexible"
E = 1.0
I = 1.0
A = 1.0e4

[[supports]]
node = "A"
type = "clamp"

[[loads]]
node = "B"
fy = -{P}

[analysis]
kind = "load"
steps = 8

[[outputs]]
name = "tip"
node = "B"

[[references]]
output = "tip.uy"
value = -0.1
at_factor = 1.0
kind = "closed-form"
source = "P L^3 / (3 EI) with P = 0.3, L = EI = 1 (linear theory)"
rationale = "the dummy reference is exactly linear theory"
tolerance = 1.0e-3

[[models]]
name = "dummy-scaled"
options = {{ scale = {scale} }}
"""


def dummy_scene(name: str = "dummy-cantilever"):
    """A validated single-beam scene whose reference model is ``dummy-exact``."""
    return cases.loads(CASE_TOML.format(name=name, P=P, scale=1 + EPS), source=f"<{name}>")


@pytest.fixture
def dummies(monkeypatch):
    """Register the dummy models for one test only (the global registry is restored)."""
    for name, target in DUMMIES.items():
        monkeypatch.setitem(registry.MODELS, name, target)
    return DUMMIES


def by_model(result):
    return {r["model"]: r for r in result.payload["results"]}


# -- tests ------------------------------------------------------------------------------------
def test_errors_and_records_against_closed_form(dummies, tmp_path):
    models = ["dummy-scaled", "dummy-half", "dummy-crash", "dummy-na"]
    res = runner.run_matrix([dummy_scene()], models, tmp_path, workers=1, render=False)
    recs = by_model(res)
    assert set(recs) == {*models, "dummy-exact"}  # the reference model is added
    case = res.payload["cases"]["dummy-cantilever"]
    assert case["reference"] == "dummy-exact" and recs["dummy-exact"]["is_reference"]

    # known errors: uy_ref,max = P/3 = 0.1 (L = 1), rot_ref,max = P/2 = 0.15 rad; a model
    # scaled by 1 + EPS is EPS off on its own scale (error_rel) whatever P is, and
    # EPS P / 3 (of L) / EPS P / 2 (rad) on the classic yardstick (error_L)
    sc = recs["dummy-scaled"]
    per, per_L = sc["errors"]["per_output"], sc["errors"]["per_output_L"]
    assert per["tip.uy"] == pytest.approx(EPS, rel=1e-9)
    assert per["tip.rot"] == pytest.approx(EPS, rel=1e-9)
    assert per_L["tip.uy"] == pytest.approx(EPS * P / 3, rel=1e-9)
    assert per_L["tip.rot"] == pytest.approx(EPS * P / 2, rel=1e-9)
    assert per["tip.ux"] == 0.0
    assert sc["error_rel"] == pytest.approx(EPS, rel=1e-9)
    assert sc["error_L"] == pytest.approx(EPS * P / 2, rel=1e-9)
    assert sc["summary_basis"] == "path" and sc["errors"]["n_points"] == 9
    assert not sc["errors"]["interpolated"]
    # reference checks: the exact dummy passes, the scaled one is 1% off (> 1e-3): fails
    assert recs["dummy-exact"]["refchecks"][0]["passed"] is True
    assert recs["dummy-exact"]["refchecks"][0]["error"] < 1e-12
    chk = sc["refchecks"][0]
    assert chk["passed"] is False and chk["error"] == pytest.approx(EPS, rel=1e-9)
    assert chk["source"].startswith("P L^3")  # provenance travels with the check

    # honest failure: half path, errors over the converged part, coverage reported
    half = recs["dummy-half"]
    assert half["status"] == "failed" and len(half["steps"]) == 5
    assert half["errors"]["coverage"] == pytest.approx(0.5)
    assert half["error_rel"] == pytest.approx(0.0, abs=1e-15)
    assert half["refchecks"][0]["passed"] is None  # factor 1 never reached

    crash = recs["dummy-crash"]
    assert crash["status"] == "failed" and "RuntimeError: boom in the dummy" in crash["message"]
    assert "Traceback" in crash["traceback"]
    na = recs["dummy-na"]
    assert na["status"] == "not-applicable" and na["message"] == "dummy declines every scene"
    assert na["timing"] is None and na["error_rel"] is None

    t = sc["timing"]
    assert 1 <= t["n_repeats"] <= 5
    assert t["min_s"] <= t["median_s"] <= t["max_s"]
    assert t["spread_s"] == pytest.approx(t["max_s"] - t["min_s"])
    assert sc["speedup_vs_reference"] > 0
    assert sc["card"]["summary"] == "test dummy: linear cantilever tip formula"
    assert sc["steps"][-1]["outputs"]["tip.uy"] == pytest.approx(-(1 + EPS) * P / 3)

    saved = json.loads((tmp_path / "results.json").read_text())
    assert saved["format"] == store.FORMAT and len(saved["results"]) == 5
    assert {"git_commit", "cpu", "python", "packages", "time", "machine"} <= set(
        saved["environment"]
    )


def test_default_model_list_is_case_list_plus_defaults_plus_reference(dummies, monkeypatch):
    monkeypatch.setattr(runner.api, "default_names", lambda: ("dummy-na",))
    pairs = dict(runner.model_list(dummy_scene(), None, runner.api.registry_table()))
    assert pairs == {"dummy-scaled": "model", "dummy-na": "model", "dummy-exact": "reference"}


def test_unknown_user_model_is_rejected_before_solving(dummies, tmp_path):
    with pytest.raises(registry.UnknownModelError, match="no-such-model"):
        runner.run_matrix([dummy_scene()], ["no-such-model"], tmp_path, workers=1)
    assert not (tmp_path / "partial.jsonl").exists()


def test_resume_skips_finished_pairs(dummies, tmp_path):
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    models = ["dummy-scaled", "dummy-crash"]
    first = runner.run_matrix(scenes, models, tmp_path, workers=1, render=False)
    assert (first.solved, first.resumed) == (6, 0)
    again = runner.run_matrix(scenes, models, tmp_path, workers=1, render=False)
    assert (again.solved, again.resumed) == (0, 6)
    assert by_model(again)["dummy-scaled"]["error_rel"] == pytest.approx(EPS)

    # a finished run keeps no temporary file: it resumes from results.json
    assert not (tmp_path / "partial.jsonl").exists()
    # an interrupted run: two finished pairs and a half-written line, no results.json yet
    lines = [json.dumps(r) for r in first.payload["results"][:3]]
    (tmp_path / "results.json").unlink()
    (tmp_path / "partial.jsonl").write_text("\n".join(lines[:2]) + "\n" + lines[2][:40])
    third = runner.run_matrix(scenes, models, tmp_path, workers=1, render=False)
    assert (third.solved, third.resumed) == (4, 2)
    assert len(third.payload["results"]) == 6

    # a changed scene (different load) is not resumed; --fresh starts over
    quick = runner.run_matrix(scenes, models, tmp_path, workers=1, render=False, quick=True)
    assert quick.resumed == 0
    fresh = runner.run_matrix(scenes, models, tmp_path, workers=1, render=False, fresh=True)
    assert (fresh.solved, fresh.resumed) == (6, 0)


def test_process_pool_matches_serial_and_survives_a_dead_worker(dummies, tmp_path):
    scenes = [dummy_scene("dummy-a"), dummy_scene("dummy-b")]
    models = ["dummy-scaled", "dummy-killer", "dummy-na"]
    pool = runner.run_matrix(scenes, models, tmp_path / "p", workers=2, render=False)
    serial_models = ["dummy-scaled", "dummy-na"]
    serial = runner.run_matrix(scenes, serial_models, tmp_path / "s", workers=1, render=False)
    got = {(r["case"], r["model"]): r for r in pool.payload["results"]}
    assert len(got) == 8
    for r in serial.payload["results"]:
        g = got[(r["case"], r["model"])]
        assert g["status"] == r["status"]
        assert g["error_rel"] == r["error_rel"]  # deterministic: identical numbers
    for case in ("dummy-a", "dummy-b"):
        dead = got[(case, "dummy-killer")]
        assert dead["status"] == "failed" and "worker process died" in dead["message"]


def test_dask_localcluster_runs_the_same_tasks(dummies, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        res = runner.run_matrix(
            [dummy_scene()], ["dummy-scaled"], tmp_path, dask=cluster.scheduler_address,
            render=False,
        )  # fmt: skip
    recs = by_model(res)
    assert set(recs) == {"dummy-scaled", "dummy-exact"}
    assert all(r["status"] == "converged" for r in recs.values())
    assert recs["dummy-scaled"]["error_rel"] == pytest.approx(EPS, rel=1e-9)
    assert res.payload["config"]["dask"] == cluster.scheduler_address
    assert not (tmp_path / "partial.jsonl").exists()  # removed once results.json is written
    assert len(store.read_results(tmp_path)["results"]) == 2


def test_quick_scene_keeps_reference_factors_on_the_grid():
    sc = cases.loads(CASE_TOML.format(name="q", P=P, scale=1.0).replace("steps = 8", "steps = 20"))
    q = runner.quick_scene(sc)
    assert q.analysis.steps == 5 and q.analysis.factor_end == sc.analysis.factor_end
    ref = dataclasses.replace(sc.references[0], at_factor=0.1)
    off = dataclasses.replace(sc, references=(ref,))
    assert runner.quick_scene(off).analysis.steps == 10  # 0.1 must stay a step


def _steps(factors, uy):
    return [
        {"factor": f, "outputs": {"p.uy": u, "p.rot": 0.0}, "energy": 0.0}
        for f, u in zip(factors, uy)
    ]


def test_path_errors_interpolate_and_follow_snapback_by_stop_output():
    # reference on a fine grid, model on a different grid: linear reference -> exact interp
    ref = _steps(np.linspace(0, 1, 11), -np.linspace(0, 1, 11))
    mod = _steps([0.0, 0.25, 0.55, 0.95], [0.0, -0.25, -0.55, -0.95 * 1.1])
    e = errors.path_errors(mod, ref, length=2.0)
    assert e["interpolated"] and e["n_points"] == 4
    assert e["per_output"]["p.uy"] == pytest.approx(0.095 / 1.0)  # p moves 1.0 at most
    assert e["per_output_L"]["p.uy"] == pytest.approx(0.095 / 2.0)

    # limit point: factor rises then falls while uy decreases monotonically (snap-back-free
    # limit point traced by arc-length); comparison goes along uy, factor error normalised
    u = -np.linspace(0, 2, 21)
    lam = np.sin(np.pi * np.linspace(0, 1, 21) * 0.9)
    ref = _steps(lam, u)
    mod = _steps(lam + 0.02, u)
    e = errors.path_errors(mod, ref, length=1.0, stop_output="p.uy")
    assert e["abscissa"] == "p.uy"
    assert e["per_output"]["factor"] == pytest.approx(0.02 / lam.max())
    assert e["per_output"]["p.rot"] == 0.0


def test_reference_checks_abs_and_missing():
    steps = _steps([0.0, 0.5, 1.0], [0.0, -0.5, -1.0])
    refs = [
        {"output": "p.uy", "value": -1.0, "at_factor": None, "tolerance": 1e-9},
        {"output": "p.uy", "value": -0.25, "at_factor": 0.25, "tolerance": 1e-9},
        {
            "output": "p.rot",
            "value": 0.01,
            "at_factor": 1.0,
            "tolerance": 0.02,
            "abs_tolerance": True,
        },  # fmt: skip
        {"output": "p.uy", "value": -3.0, "at_factor": 3.0, "tolerance": 0.1},
    ]
    c = errors.reference_checks(refs, steps, complete=True)
    assert [x["passed"] for x in c] == [True, True, True, None]
    assert c[1]["note"] == "interpolated"
    assert c[2]["error"] == pytest.approx(0.01)
    assert c[3]["note"] == "factor 3 not reached"
    incomplete = errors.reference_checks(refs[:1], steps, complete=False)
    assert incomplete[0]["passed"] is None and incomplete[0]["note"] == "path incomplete"


def test_reference_falls_back_and_error_estimate_scales():
    meta = {"reference_model": "fem-auto"}
    recs = {"elastica": {"status": "converged", "steps": [1], "message": ""}}
    name, note = errors.choose_reference(meta, recs)
    assert name == "elastica" and "fem-auto" in note
    est = {"tip.uy": [0.0, 2e-6, 4e-6], "tip.rot": 1e-7, "tip.x": 1.0}
    ref = [{"factor": f, "outputs": {"tip.uy": -0.5 * f, "tip.rot": 0.1 * f}} for f in (0, 1)]
    stick = errors.reference_yardstick({"length_scale": 2.0}, ref)
    assert errors.estimate_scale(est, stick) == pytest.approx(8e-6)  # 4e-6 over 0.5
    assert errors.estimate_scale(est, stick, "error_L") == pytest.approx(2e-6)  # over L
    assert math.isnan(errors.values([{"factor": None}], "factor")[0])


def test_merged_registry_parses_parametrised_and_plain_names():
    table = {"prb-fsm-N": "m:F", "fem-auto": "m:A", "fem-N": "m:G"}
    assert runner.api.resolve("prb-fsm-12", table) == ("prb-fsm-N", 12, "m:F")
    assert runner.api.resolve("fem-auto", table) == ("fem-auto", None, "m:A")
    assert runner.api.resolve("fem-64", table) == ("fem-N", 64, "m:G")
    for bad in ("fem-0", "fem", "prb-fsm-x", "cbcm-3"):
        with pytest.raises(registry.UnknownModelError):
            runner.api.resolve(bad, table)
    assert set(registry.DEFAULT_NAMES) <= set(runner.api.default_names())
    assert set(registry.MODELS) <= set(runner.api.registry_table())


def test_progress_bar_on_a_terminal_and_silent_when_disabled():
    import io

    tty = io.StringIO()
    bar = runner.Progress(4, stream=tty, enabled=True)
    bar.update("case / model")
    bar.update("case / model")
    bar.close()
    text = tty.getvalue()
    assert "2/4" in text and "ETA" in text and text.endswith("\n")
    quiet = io.StringIO()
    bar = runner.Progress(4, stream=quiet, enabled=False)
    bar.update("x")
    bar.close()
    assert quiet.getvalue() == ""


def test_time_limit_soft_in_process_and_hard_kill_in_pool(dummies, tmp_path, monkeypatch):
    scene = dummy_scene()
    serial = runner.run_matrix(
        [scene], ["dummy-sleep"], tmp_path / "s", workers=1, render=False, time_limit=0.3
    )
    rec = by_model(serial)["dummy-sleep"]
    assert rec["status"] == "failed" and "time limit of 0.3 s exceeded" in rec["message"]
    assert by_model(serial)["dummy-exact"]["status"] == "converged"

    monkeypatch.setattr(pool, "KILL_GRACE_S", 0.5)
    models = ["dummy-sleep", "dummy-deaf", "dummy-scaled"]
    t0 = time.monotonic()
    res = runner.run_matrix([scene], models, tmp_path / "p", workers=2, render=False,
                            time_limit=0.5)  # fmt: skip
    assert time.monotonic() - t0 < 30  # nobody waited for the 60 s sleeps
    recs = by_model(res)
    assert "time limit of 0.5 s exceeded" in recs["dummy-sleep"]["message"]
    assert "time limit of 0.5 s exceeded (killed)" in recs["dummy-deaf"]["message"]
    assert recs["dummy-scaled"]["status"] == recs["dummy-exact"]["status"] == "converged"
    # lost pairs are not "finished": a rerun tries them again, the others are resumed
    again = runner.run_matrix([scene], models, tmp_path / "p", workers=2, render=False,
                              time_limit=0.5)  # fmt: skip
    assert (again.solved, again.resumed) == (2, 2)
