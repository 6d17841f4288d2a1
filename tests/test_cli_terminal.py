"""The terminal (issue 24): --version, every option in --help, "did you mean" for model and
case names (one line, exit 2), one default output folder shared by README and CLI, the
models listing aligned with each model's own summary, and the run's first line."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from reports import cli
from reports.cli_args import DEFAULT_OUT, build_parser

ROOT = Path(__file__).resolve().parents[1]


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    version = re.search(r'^version = "(.+)"', (ROOT / "pyproject.toml").read_text(), re.M)[1]
    assert capsys.readouterr().out.strip() == f"flexbench {version}"


def test_help_lists_every_option_and_debug():
    parser = build_parser(cli.COMMANDS)
    top = parser.format_help()
    assert "--version" in top and "--debug" in top
    subs = next(a for a in parser._actions if a.dest == "command").choices
    for name, sub in subs.items():
        if name == "fit-prb":  # its own parser (reduced_models.beam.prb_fit)
            continue
        text = sub.format_help()
        for action in sub._actions:
            for flag in action.option_strings:
                assert flag in text, (name, flag)
        assert "--debug" in text, name


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["solve", "cantilever-tip-load", "--model", "prb3r"],
            "flexbench: error: unknown model 'prb3r' (did you mean 'prb-3r'?); known: ",
        ),
        (
            ["run", "--models", "prb3r", "--out", "{tmp}"],
            "flexbench: error: unknown model 'prb3r' (did you mean 'prb-3r'?); known: ",
        ),
        (
            ["solve", "cantilever-tip-lod", "--model", "prb-3r"],
            "flexbench: error: cantilever-tip-lod: not a catalog case or a file "
            "(did you mean 'cantilever-tip-load'?) (see `flexbench cases`)",
        ),
        (
            ["recommend", "cantilever-tip-lod"],
            "flexbench: error: cantilever-tip-lod: not a catalog case or a file "
            "(did you mean 'cantilever-tip-load'?) (see `flexbench cases`)",
        ),
        (
            ["run", "--cases", "cantilever-tip-lod", "--out", "{tmp}"],
            "flexbench: error: --cases: no catalog case matches 'cantilever-tip-lod' "
            "(did you mean 'cantilever-tip-load'?)",
        ),
        (
            ["solve", "zzzz", "--model", "bcm"],
            "flexbench: error: zzzz: not a catalog case or a file (see `flexbench cases`)",
        ),
    ],
)
def test_did_you_mean_in_one_line(argv, line, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path / "out")) for a in argv]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(line)
    assert not (tmp_path / "out").exists()


def test_default_out_is_the_readme_folder():
    assert DEFAULT_OUT == "flexbench-out"
    parser = build_parser(cli.COMMANDS)
    assert parser.parse_args(["run"]).out == DEFAULT_OUT
    assert parser.parse_args(["teach"]).out == DEFAULT_OUT
    assert parser.parse_args(["history"]).path == DEFAULT_OUT
    readme = (ROOT / "README.md").read_text()
    assert f"flexbench run --out {DEFAULT_OUT}" in readme
    assert not re.search(r"flexbench (run|teach|history)\b[^\n`]*\b--out out\b", readme)


def test_models_listing_aligned_with_each_models_own_summary(capsys):
    assert cli.main(["models"]) == 0
    lines = capsys.readouterr().out.splitlines()
    head, rows = lines[0], [ln for ln in lines[1:] if not ln.startswith("warning:")]
    start = head.index("summary")
    for row in rows:  # the summary column starts at the same place on every row
        assert row[start - 1] == " " and row[start] != " ", row
    summary = {r.split()[0].rstrip("*"): r[start:] for r in rows}
    # Su 2009: Eq. (27) is the tip-force stiffness set, Eq. (25) the end-moment one
    assert "Eq. (27)" in summary["prb-3r-force"] and "tip force" in summary["prb-3r-force"]
    assert "Eq. (25)" in summary["prb-3r-moment"] and "end moment" in summary["prb-3r-moment"]
    assert summary["prb-3r-force"] != summary["prb-3r"] != summary["prb-3r-moment"]


def test_run_says_what_runs_before_it_solves(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "reports.cli", "run", "--cases", "cantilever-tip-load",
         "--models", "linear-1", "--out", str(out), "--quick", "--workers", "1", "--no-report"],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    # the start line on stdout (bad input found while planning stays one line on stderr)
    assert proc.stdout.splitlines()[0] == (
        f"flexbench: run: 1 case; models: linear-1; 1 worker; out {out}"
    )
    err = proc.stderr.splitlines()
    assert err[0].startswith("flexbench: solving 3 pairs (1 case x 3 models) on 1 worker")
    assert err[-1].startswith("flexbench: 3/3 pairs")
