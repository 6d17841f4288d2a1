"""Faults around a run: limits per pair on every backend, kill -9, a full disk, a second run
into the same directory, torn journal lines and the SQLite history of resumed runs.

Nothing finished may be lost and no pair may be recorded twice.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
import types
from pathlib import Path

import numpy as np
import pytest

from reduced_models import registry
from reports import cli
from reports.run import journal, limits, runner
from tests.test_runner import DUMMIES, LinearTip, dummy_scene

ROOT = Path(__file__).resolve().parents[1]


class Spinner(LinearTip):
    """Runs away in Python code (every backend's time limit must end it)."""

    def solve(self, scene):
        while True:
            time.sleep(0.005)


class Hog(LinearTip):
    """Allocates 32 MB blocks; gives up by itself at 2 GB so a broken limit cannot hurt."""

    def solve(self, scene):
        blocks = []
        for _ in range(64):
            blocks.append(np.ones(2**22))
        return super().solve(scene).__class__(scene.name, self.name, "failed", "hog survived")


class Slow(LinearTip):
    """1.1 s per solve, above the timing policy's cold cap: solved once, killable mid-run."""

    def solve(self, scene):
        time.sleep(1.1)
        return super().solve(scene)


MINE = {
    "dummy-spin": "tests.test_input_faults:Spinner",
    "dummy-hog": "tests.test_input_faults:Hog",
    "dummy-slow": "tests.test_input_faults:Slow",
}


def register_dummies(monkeypatch):
    for name, target in {**DUMMIES, **MINE}.items():
        monkeypatch.setitem(registry.MODELS, name, target)


@pytest.fixture
def dummies(monkeypatch):
    register_dummies(monkeypatch)


def by_model(res):
    return {r["model"]: r for r in res.payload["results"]}


# -- limits per pair -----------------------------------------------------------------------------
@pytest.mark.parametrize("workers", [1, 2])
def test_time_and_memory_limits_local(dummies, tmp_path, workers):
    models = ["dummy-spin", "dummy-hog", "dummy-scaled"]
    res = runner.run_matrix([dummy_scene()], models, tmp_path, workers=workers, render=False,
                            time_limit=3, memory_limit=100)  # fmt: skip
    recs = by_model(res)
    assert recs["dummy-spin"]["status"] == "failed"
    assert "time limit of 3 s exceeded" in recs["dummy-spin"]["message"]
    assert recs["dummy-hog"]["status"] == "failed"
    assert "memory limit of 100 MB exceeded" in recs["dummy-hog"]["message"]
    assert recs["dummy-scaled"]["status"] == "converged"  # the run went on


def test_time_and_memory_limits_on_dask(dummies, tmp_path):
    """Dask runs pairs in threads: the watchdog ends them (memory: growth of the worker
    process, so a pair is judged alone only with one thread per worker, as used here)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        t0 = time.monotonic()
        res = runner.run_matrix([dummy_scene()], ["dummy-spin", "dummy-hog", "dummy-scaled"],
                                tmp_path, dask=cluster.scheduler_address, render=False,
                                time_limit=3, memory_limit=100)  # fmt: skip
        assert time.monotonic() - t0 < 60
    recs = by_model(res)
    assert "time limit of 3 s exceeded" in recs["dummy-spin"]["message"]
    assert "memory limit of 100 MB exceeded" in recs["dummy-hog"]["message"]
    assert recs["dummy-scaled"]["status"] == "converged"


def test_watchdog_stops_a_thread_and_leaves_no_pending_exception():
    out = {}

    def work(seconds):
        try:
            with limits.guard(seconds):
                while True:
                    time.sleep(0.001)
        except limits.LimitExceeded as exc:
            out["exc"] = str(exc)
        with limits.guard(5.0):  # a short block afterwards is not hit by a stale exception
            out["after"] = sum(range(1000))

    t = threading.Thread(target=work, args=(0.2,))
    t.start()
    t.join(10)
    assert out == {"exc": "time limit of 0.2 s exceeded", "after": 499500}


_TRACED_GUARDS = """
import sys, threading, time
from reports.run import limits

def tracer(frame, event, arg):
    return tracer

def work():
    sys.settrace(tracer)
    try:
        with limits.guard(0.2):
            while True:
                time.sleep(0.001)
    except limits.LimitExceeded:
        pass
    with limits.guard(5.0):
        pass
    print(sum(range(10)))

thread = threading.Thread(target=work)
thread.start()
thread.join()
"""


def test_watchdog_works_under_a_tracer():
    """Coverage and debuggers trace: a guard ended in a traced thread must leave the
    interpreter usable (clearing the pending exception with ``SetAsyncExc(id, NULL)`` left the
    eval breaker set, and the next Python call under the tracer spun forever)."""
    out = subprocess.run([sys.executable, "-c", _TRACED_GUARDS], cwd=ROOT, capture_output=True,
                         text=True, timeout=30)  # fmt: skip
    assert (out.returncode, out.stdout) == (0, "45\n"), out.stderr


# -- journal -------------------------------------------------------------------------------------
def test_torn_last_line_is_cut_off_so_the_next_record_survives(tmp_path):
    p = tmp_path / "partial.jsonl"
    journal.append(p, {"key": "a"})
    journal.append(p, {"key": "b"})
    with p.open("ab") as fh:
        fh.write(b'{"key": "c", "sta')  # killed mid-write
    assert [r["key"] for r in journal.read(p)] == ["a", "b"]
    journal.append(p, {"key": "d"})
    assert [r["key"] for r in journal.read(p)] == ["a", "b", "d"]


def test_disk_full_rolls_the_record_back_and_is_one_line(dummies, tmp_path, monkeypatch, capsys):
    """A patched writer: the third record hits ENOSPC after writing half of itself."""
    calls = {"n": 0}

    def write(fd, data):
        calls["n"] += 1
        if calls["n"] >= 3:
            os.write(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")
        return os.write(fd, data)

    monkeypatch.setattr(journal, "os", types.SimpleNamespace(**{**vars(os), "write": write}))
    case = tmp_path / "c.toml"
    case.write_text(_case_text("full"))
    out = tmp_path / "out"
    argv = ["run", "--cases", str(case), "--models", "dummy-scaled,dummy-half,dummy-crash",
            "--out", str(out), "--workers", "1", "--no-report"]  # fmt: skip
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "disk full" in _error_line(err)
    assert (out / "partial.jsonl").read_bytes().endswith(b"}\n")  # the half record rolled back
    assert len(journal.read(out / "partial.jsonl")) == 2  # whole records only
    monkeypatch.undo()
    register_dummies(monkeypatch)
    assert cli.main(argv) == 0
    assert "2 resumed" in capsys.readouterr().out
    _assert_no_duplicates(out, pairs=4)


def test_file_size_limit_is_a_real_write_failure(dummies, tmp_path, monkeypatch):
    """RLIMIT_FSIZE in a child: the kernel refuses the write half-way (EFBIG), as a full disk."""
    sizes, append = [], journal.append

    def spy(path, record):  # the same run in-process: how long are its journal lines?
        append(path, record)
        sizes.append(len(path.read_bytes().splitlines()[-1]) + 1)

    monkeypatch.setattr(journal, "append", spy)
    models = "dummy-scaled,dummy-half"  # + the reference dummy-exact: three records
    runner.run_matrix([dummy_scene("fsize")], models.split(","), tmp_path / "free", workers=1,
                      render=False)  # fmt: skip
    sizes.sort()
    assert len(sizes) == 3
    fsize = sizes[1] + sizes[2] + sizes[0] // 2  # any two records fit, three do not
    case = tmp_path / "c.toml"
    case.write_text(_case_text("fsize"))
    out = tmp_path / "out"
    child = _flexbench_child(case, out, models, fsize=fsize)
    assert child.returncode == 2, child.stderr
    assert "cannot write" in _error_line(child.stderr)
    kept = journal.read(out / "partial.jsonl")
    assert len(kept) == 2
    again = _flexbench_child(case, out, models)
    assert again.returncode == 0, again.stderr
    assert f"{len(kept)} resumed" in again.stdout


def test_kill_9_then_resume_loses_nothing_and_duplicates_nothing(tmp_path):
    out = tmp_path / "out"
    paths = []
    for i in range(6):
        paths.append(tmp_path / f"c{i}.toml")
        paths[-1].write_text(_case_text(f"kill-{i}"))
    args = _child_args(",".join(map(str, paths)), out, "dummy-slow")
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    part = out / "partial.jsonl"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(journal.read(part)) < 8:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = {r["key"] for r in journal.read(part)}
    assert 8 <= len(finished) < 12
    for _ in range(2):  # resume, then resume a finished run: history keeps one copy
        again = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=120)
        assert again.returncode == 0, again.stderr
    assert "12 resumed" in again.stdout
    _assert_no_duplicates(out, pairs=12)


def test_second_run_refuses_or_waits_and_stale_locks_are_taken_over(dummies, tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_text(_case_text("lock"))
    out = tmp_path / "out"
    argv = ["run", "--cases", str(case), "--models", "dummy-scaled", "--out", str(out),
            "--workers", "1", "--no-report"]  # fmt: skip
    with journal.RunLock(out):
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert f"pid {os.getpid()}" in _error_line(err) and "--wait" in err
        holder = journal.RunLock(out)
    timer = threading.Timer(0.5, holder.__exit__, (None, None, None))
    holder.__enter__()
    timer.start()
    t0 = time.monotonic()
    assert cli.main([*argv, "--wait"]) == 0  # waits for the holder, then runs
    assert time.monotonic() - t0 >= 0.4
    (out / journal.LOCK_NAME).write_text("999999999\n")  # left by a dead run: no flock held
    assert cli.main(argv) == 0


def test_unwritable_out_is_one_line_exit_2(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    for out in (blocker / "sub", Path("/proc/flexbench-nope")):
        assert cli.main(["run", "--cases", "cantilever-tip-load", "--models", "linear-2",
                         "--out", str(out), "--no-report"]) == 2  # fmt: skip
        err = capsys.readouterr().err
        assert str(out) in _error_line(err)


# -- helpers -------------------------------------------------------------------------------------
def _error_line(err: str) -> str:
    """The one error line of a run's stderr (progress lines may come before it)."""
    errors = [line for line in err.splitlines() if line.startswith("flexbench: error:")]
    assert len(errors) == 1 and err.endswith(errors[0] + "\n") and "Traceback" not in err, err
    return errors[0]


def _case_text(name: str) -> str:
    from tests.test_runner import CASE_TOML, EPS, P

    return CASE_TOML.format(name=name, P=P, scale=1 + EPS)


def _child_args(cases_arg: str, out: Path, models: str) -> list[str]:
    code = (
        "import sys, json; from reduced_models import registry; "
        f"registry.MODELS.update(json.loads({json.dumps(json.dumps({**DUMMIES, **MINE}))})); "
        "from reports.cli import main; sys.exit(main(sys.argv[1:]))"
    )
    return [sys.executable, "-c", code, "run", "--cases", cases_arg, "--models", models,
            "--out", str(out), "--workers", "1", "--no-report"]  # fmt: skip


def _flexbench_child(case: Path, out: Path, models: str, fsize: int | None = None):
    def limit():
        import resource

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    return subprocess.run(_child_args(str(case), out, models), cwd=ROOT, capture_output=True,
                          text=True, timeout=120, preexec_fn=limit if fsize else None)  # fmt: skip


def _assert_no_duplicates(out: Path, pairs: int) -> None:
    con = sqlite3.connect(out / "history.sqlite")
    try:
        runs = con.execute("SELECT id FROM runs").fetchall()
        rows = con.execute("SELECT run_id, case_name, model FROM results").fetchall()
    finally:
        con.close()
    assert len(runs) == 1 and len(rows) == pairs == len(set(rows))
