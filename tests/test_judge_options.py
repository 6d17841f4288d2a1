"""Model options are checked against each model's declaration (issue 11, item 4)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import cases
import reports
from reduced_models.options import Option, OptionError, validate

TRAP = Path(__file__).parent / "data" / "traps" / "trap-inclined-clamp.toml"


def test_every_registered_model_declares_its_options():
    for key in reports.api.model_names():
        _, _, target = reports.api.resolve(key.replace("-N", "-4"))
        declared = getattr(reports.api.factory(target), "OPTIONS", None)
        assert isinstance(declared, dict), f"{key}: no OPTIONS declaration"


def bad_case(tmp_path: Path, options: str) -> Path:
    case = tmp_path / "bad.toml"
    case.write_text(TRAP.read_text() + f'\n[[models]]\nname = "fem-auto"\noptions = {options}\n')
    return case


@pytest.mark.parametrize(
    ("options", "why"),
    [
        ("{ rtol = 1e10 }", "must be in [1e-14"),
        ("{ rtol = inf }", "must be finite"),
        ("{ rtl = 1e-9 }", "unknown option 'rtl'"),
        ("{ max_iter = 2.5 }", "must be an integer"),
        ('{ stability = "yes" }', "must be true or false"),
        ("{ sequence = [16, 8] }", "strictly increasing"),
    ],
)
def test_bad_fem_auto_options_are_one_line_naming_the_file(tmp_path, options, why):
    case = bad_case(tmp_path, options)
    with pytest.raises(OptionError) as err:
        reports.api.make_model("fem-auto", cases.load(str(case)))
    line = str(err.value)
    assert "\n" not in line and str(case) in line and why in line, line


@pytest.mark.parametrize("cmd", ["solve", "run"])
def test_cli_exits_2_on_bad_options(tmp_path, cmd):
    case = bad_case(tmp_path, "{ rtol = 1e10 }")
    args = ["solve", str(case), "--model", "fem-auto"]
    if cmd == "run":
        args = ["run", "--cases", str(case), "--models", "fem-auto", "--out", str(tmp_path / "o")]
    p = subprocess.run(
        [sys.executable, "-m", "reports.cli", *args],
        capture_output=True,
        text=True,
        cwd=Path(__file__).parents[1],
        timeout=120,
    )
    line = p.stderr.strip()
    assert p.returncode == 2 and "\n" not in line and str(case) in line, line


def test_declared_ranges_types_and_choices():
    decl = {
        "a": Option("float", 0.0, 1.0),
        "s": Option("str", choices=("x", "y")),
        "n": ("int", 1, 5),
    }
    validate("m", decl, {"a": 0.5, "s": "x", "n": 3})
    for bad in ({"a": 2.0}, {"a": True}, {"s": "z"}, {"n": 0}, {"n": 2.0}, {"b": 1}):
        with pytest.raises(OptionError):
            validate("m", decl, bad)


def test_good_options_still_reach_the_model():
    m = reports.api.make_model("fem-auto", options={"sequence": [4, 8, 16], "rtol": 1e-10})
    assert m.sequence == (4, 8, 16) and m.options == {"rtol": 1e-10}
