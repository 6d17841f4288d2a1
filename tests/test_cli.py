"""The ``flexbench`` CLI: the ``solve --json`` contract, bad input (exit 2, one line, no
traceback), listing commands and a small ``run``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import types
from pathlib import Path

import pytest

import cases
from reduced_models import registry
from reduced_models.base import Solution, Step
from reports import cli
from tests.test_runner import CASE_TOML, DUMMIES, EPS, P

ROOT = Path(__file__).resolve().parents[1]
REAL_MODEL = "linear-2"  # a registered real model (the contract must hold for any model)
STEP_KEYS = {"factor", "outputs", "energy", "iterations", "stable"}
TOP_KEYS = {"case", "model", "status", "message", "steps", "wall_s"}


class NanModel:
    """Returns a step with non-finite numbers (they must become null)."""

    name = "dummy-nan"

    def applies_to(self, scene):
        return None

    def solve(self, scene):
        out = {"tip.uy": math.nan, "tip.rot": math.inf, "tip.ux": 0.0}
        steps = (
            Step(0.0, {"tip.uy": 0.0, "tip.rot": 0.0, "tip.ux": 0.0}, 0.0, 1, True),
            Step(1.0, out, energy=math.nan, iterations=3, stable=None),
        )
        # failed: a converged answer with a NaN output is refused (reports.api.checked); the
        # states of a failed run still reach the JSON, NaN as null
        return Solution(scene.name, self.name, "failed", "diverged", steps)


@pytest.fixture
def case_file(tmp_path):
    p = tmp_path / "dummy.toml"
    p.write_text(CASE_TOML.format(name="dummy-cli", P=P, scale=1 + EPS))
    return p


@pytest.fixture
def dummies(monkeypatch):
    for name, target in {**DUMMIES, "dummy-nan": "tests.test_cli:NanModel"}.items():
        monkeypatch.setitem(registry.MODELS, name, target)


def flexbench(*args: str) -> subprocess.CompletedProcess:
    """The real entry point in a fresh interpreter (what a user's shell runs)."""
    return subprocess.run(
        [sys.executable, "-c", "import sys; from reports.cli import main; sys.exit(main())", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


def check_contract(obj: dict) -> None:
    # the contract keys, plus the optional "extras" extension (error estimates, limit points)
    assert TOP_KEYS <= set(obj) <= TOP_KEYS | {"extras"}
    assert all(isinstance(obj[k], str) for k in ("case", "model", "status", "message"))
    assert obj["status"] in ("converged", "failed", "not-applicable")
    assert isinstance(obj["wall_s"], float) and obj["wall_s"] >= 0
    assert isinstance(obj["steps"], list)
    for s in obj["steps"]:
        assert set(s) == STEP_KEYS
        assert isinstance(s["factor"], float)
        assert isinstance(s["iterations"], int) and not isinstance(s["iterations"], bool)
        assert s["stable"] in (True, False, None)
        assert s["energy"] is None or isinstance(s["energy"], float)
        assert all(isinstance(k, str) for k in s["outputs"])
        assert all(v is None or isinstance(v, float) for v in s["outputs"].values())


def _strict(text: str) -> dict:
    def no_nan(c):
        raise AssertionError(f"non-JSON constant {c}")

    return json.loads(text, parse_constant=no_nan)


@pytest.mark.parametrize("model", ["elastica", REAL_MODEL])
def test_solve_json_contract_real_process(model):
    r = flexbench("solve", "cantilever-tip-load", "--model", model, "--json")
    assert r.returncode == 0, r.stderr
    obj = _strict(r.stdout)
    check_contract(obj)
    assert (obj["case"], obj["model"]) == ("cantilever-tip-load", model)
    scene = cases.load("cantilever-tip-load")
    if obj["status"] == "converged":
        assert len(obj["steps"]) == scene.analysis.steps + 1
        assert obj["steps"][0]["factor"] == 0.0
        assert set(obj["steps"][-1]["outputs"]) >= {"tip.ux", "tip.uy", "tip.rot"}
    assert r.stdout.count("\n") == 1  # one object, one line


def test_solve_json_nan_becomes_null_and_not_applicable(dummies, case_file, capsys):
    assert cli.main(["solve", str(case_file), "--model", "dummy-nan", "--json"]) == 0
    obj = _strict(capsys.readouterr().out)
    check_contract(obj)
    last = obj["steps"][-1]
    assert last["outputs"] == {"tip.uy": None, "tip.rot": None, "tip.ux": 0.0}
    assert last["energy"] is None and last["stable"] is None and last["iterations"] == 3

    assert cli.main(["solve", str(case_file), "--model", "dummy-na", "--json"]) == 0
    obj = _strict(capsys.readouterr().out)
    check_contract(obj)
    assert obj["status"] == "not-applicable" and obj["steps"] == []
    assert obj["message"] == "dummy declines every scene"

    assert cli.main(["solve", str(case_file), "--model", "dummy-crash", "--json"]) == 0
    obj = _strict(capsys.readouterr().out)
    assert obj["status"] == "failed" and "boom in the dummy" in obj["message"]


GOOD = CASE_TOML.format(name="dummy-bad", P=P, scale=1.0)
BAD_CASE = GOOD.replace("x = 1.0\ny = 0.0", "x = 0.0\ny = 0.0")  # zero-length member
BAD_OPTIONS = GOOD.replace('name = "dummy-scaled"', f'name = "{REAL_MODEL}"').replace(
    "scale =", "no_such_option ="
)
BAD = [
    (["solve", "no-such-case", "--model", REAL_MODEL], "no-such-case"),
    (["solve", "{bad}", "--model", REAL_MODEL], "members"),
    (["solve", "{missing}", "--model", REAL_MODEL], "missing.toml"),
    (["solve", "{opts}", "--model", REAL_MODEL], "bad options"),
    (["solve", "cantilever-tip-load", "--model", "no-such-model"], "no-such-model"),
    (["solve", "cantilever-tip-load", "--model", "linear-0"], "linear-0"),
    (["solve", "cantilever-tip-load"], "--model"),
    (["solve", "cantilever-tip-load", "--model", REAL_MODEL, "--bogus"], "--bogus"),
    ([], "COMMAND"),
    (["frobnicate"], "frobnicate"),
    (["run", "--workers", "0"], "--workers"),
    (["run", "--workers", "two"], "two"),
    (["run", "--cases", "no-such-*"], "no-such-*"),
    (["run", "--cases", "{bad}", "--out", "{out}"], "members"),
    (["run", "--models", f"{REAL_MODEL},nope", "--out", "{out}"], "nope"),
    (["run", "--models", ",", "--out", "{out}"], "--models"),
    (["run", "--time-limit", "-1", "--out", "{out}"], "--time-limit"),
    (["compare", "{missing}", "{missing}"], "missing.toml"),
    (["compare", "{bad}", "{bad}"], "not a readable results file"),
    (["compare", "{notresults}", "{notresults}"], "not a FlexBench results file"),
    (["compare", "{notresults}", "{notresults}", "--rel-factor", "0.5"], "--rel-factor"),
    (["report", "{out}"], "no such results file"),
]


@pytest.mark.parametrize(("argv", "named"), BAD, ids=[" ".join(a) or "(none)" for a, _ in BAD])
def test_bad_input_exits_2_with_one_line(argv, named, tmp_path, capsys):
    files = {
        "bad": tmp_path / "bad.toml",
        "missing": tmp_path / "missing.toml",
        "opts": tmp_path / "opts.toml",
        "notresults": tmp_path / "x.json",
        "out": tmp_path / "out",
    }
    files["bad"].write_text(BAD_CASE)
    files["opts"].write_text(BAD_OPTIONS)
    files["notresults"].write_text('{"hello": 1}')
    files["out"].mkdir()
    argv = [a.format(**files) for a in argv]
    assert cli.main(argv) == 2
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("flexbench: error: "), cap.err
    assert named in lines[0]
    assert "Traceback" not in cap.err + cap.out
    assert not (files["out"] / "partial.jsonl").exists()  # nothing started


def test_bad_input_real_process_one_line_no_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(BAD_CASE)
    for args in (
        ["solve", str(bad), "--model", REAL_MODEL, "--json"],
        ["solve", "cantilever-tip-load", "--model", "no-such-model", "--json"],
    ):
        r = flexbench(*args)
        assert r.returncode == 2
        assert r.stdout == "" and "Traceback" not in r.stderr
        assert len(r.stderr.splitlines()) == 1 and r.stderr.startswith("flexbench: error: ")
    assert str(bad) in flexbench("solve", str(bad), "--model", REAL_MODEL).stderr


def test_fit_prb_delegates_or_says_unavailable(monkeypatch, capsys):
    seen = []
    fake = types.ModuleType("reduced_models.beam.prb_fit")
    fake.fit_prb_cli = lambda argv: seen.append(argv) or 0
    monkeypatch.setitem(sys.modules, "reduced_models.beam.prb_fit", fake)
    assert cli.main(["fit-prb", "3", "--alpha-max", "5"]) == 0
    assert seen == [["3", "--alpha-max", "5"]]
    monkeypatch.setitem(sys.modules, "reduced_models.beam.prb_fit", None)  # import fails
    assert cli.main(["fit-prb", "3"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "fit-prb is not available" in err[0]


def test_cases_and_models_listings(capsys):
    assert cli.main(["cases"]) == 0
    out = capsys.readouterr().out
    for name in cases.catalog_names():
        assert name in out
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert "linear-N" in out and "elastica" in out


def test_run_quick_on_a_case_file(dummies, case_file, tmp_path, capsys):
    out = tmp_path / "run"
    hist = str(tmp_path / "h.db")
    argv = ["run", "--cases", str(case_file), "--models", "dummy-scaled,dummy-crash",
            "--out", str(out), "--quick", "--workers", "1", "--history", hist]  # fmt: skip
    assert cli.main(argv) == 0
    text = capsys.readouterr().out
    assert "3 pairs (3 solved, 0 resumed, 1 failed)" in text
    for f in ("results.json", "results.csv", "errors.csv", "report.html", "report.md"):
        assert (out / f).exists(), f
    assert not (out / "partial.jsonl").exists()  # temporary: removed once results.json is written
    assert (tmp_path / "h.db").exists() and not (out / "history.sqlite").exists()
    data = json.loads((out / "results.json").read_text())
    assert data["config"]["quick"] is True
    assert data["cases"]["dummy-cli"]["analysis"]["steps"] == 4  # 8 steps -> quick 4
    assert cli.main(argv) == 0
    assert "(0 solved, 3 resumed" in capsys.readouterr().out


def test_fem_auto_json_carries_error_estimates():
    """Issue 3: `solve CASE --model fem-auto --json` gives values with error estimates."""
    res = flexbench("solve", "lee-frame", "--model", "fem-auto", "--json")
    assert res.returncode == 0, res.stderr
    obj = json.loads(res.stdout)
    check_contract(obj)
    est = obj["extras"]["error_estimate"]
    assert set(obj["steps"][-1]["outputs"]) <= set(est) | {"factor"}
    first = obj["extras"]["limit_points"][0]
    # Lee's frame first limit load 18.5 (published, 3 digits) within 0.5 %
    assert abs(first["factor_extrapolated"] - 18.5) / 18.5 < 5e-3
    assert first["error"] < 0.01
