"""Hostile case files and internal errors: one line naming file, key and reason, exit 2 (or 3
for a bug of ours), never a traceback, a hang or an exhausted memory.

Each class of the issue-15 findings is reproduced with a file written here (huge integers,
deep nesting, 100k outputs, 1e7 steps, negative factor_end, E*A underflow, bad options).
"""

from __future__ import annotations

import re
import time

import pytest

import cases
from cases import limits
from reports import cli

BASE = (cases.CATALOG / "cantilever-tip-load.toml").read_text()
HEAD = BASE.split("[[references]]")[0].split("# Mattiasson")[0]  # no references


def edit(old: str, new: str, text: str = HEAD) -> str:
    assert old in text
    return text.replace(old, new, 1)


def outputs(n: int) -> str:
    return HEAD + "".join(f'[[outputs]]\nname = "o{i}"\nnode = "B"\n' for i in range(n))


HOSTILE = [
    # (id, text, key named, reason fragment)
    ("400-digit-E", edit("E = 1.0", "E = 1" + "0" * 400), "members[0].E", "exceeds the limit"),
    ("E-A-underflow", edit("A = 1.0e4", "A = 1e-300"), "members[0].A", "below 1e-30"),
    ("huge-load", edit("fy = -10.0", "fy = -1e300"), "loads[0].fy", "exceeds the limit"),
    (
        "deep-array",
        HEAD + '[[models]]\nname = "elastica"\noptions = { x = ' + "[" * 5000 + "]" * 5000 + " }\n",
        "(toml)",
        "nested deeper",
    ),
    (
        "deep-inline-table",
        HEAD + '[[models]]\nname = "elastica"\noptions = ' + "{a = " * 3000 + "1" + "}" * 3000,
        "(toml)",
        "nested deeper",
    ),
    (
        "deep-dotted-keys",
        HEAD + '[[models]]\nname = "elastica"\n[models.options]\n' + ".".join("k" * 40) + " = 1\n",
        "models[0].options",
        "nested deeper",
    ),
    ("100k-outputs", outputs(100_001), "(file)", "exceeds the limit"),
    ("600-outputs", outputs(600), "outputs", "exceed the limit of 500"),
    ("steps-1e7", edit("steps = 20", "steps = 10000000"), "analysis.steps", "limit of 10000"),
    ("steps-float", edit("steps = 20", "steps = 1e9"), "analysis.steps", "integer"),
    ("steps-zero", edit("steps = 20", "steps = 0"), "analysis.steps", ">= 1"),
    (
        "factor-end-negative",
        edit("steps = 20", "steps = 20\nfactor_end = -1"),
        "analysis.factor_end",
        "must be > 0",
    ),
    (
        "factor-end-zero",
        edit("steps = 20", "steps = 20\nfactor_end = 0.0"),
        "analysis.factor_end",
        "must be > 0",
    ),
    (
        "max-steps-huge",
        edit("steps = 20", "steps = 20\nmax_steps = 99999999"),
        "max_steps",
        "10000",
    ),
    ("nan-option", HEAD + '[[models]]\nname = "x"\noptions = { k = nan }\n', "options.k", "finite"),
    (
        "-inf-option",
        HEAD + '[[models]]\nname = "x"\noptions = { k = -inf }\n',
        "options.k",
        "finite",
    ),
    ("inf-outside-options", edit("x = 1.0", "x = inf"), "nodes[1].x", "finite"),
    (
        "long-string",
        edit('units = "nondim"', 'units = "' + "x" * 20_000 + '"'),
        "case.units",
        "10000",
    ),
    (
        "path-without-load",
        edit('kind = "load"', 'kind = "path"', edit("fy = -10.0", "fy = 0.0")),
        "loads",
        "nonzero load",
    ),
    ("bool-as-number", edit("x = 1.0", "x = true"), "nodes[1].x", "number"),
    ("table-as-array", HEAD.replace("[[supports]]", "[supports]"), "supports", "array of tables"),
]


@pytest.mark.parametrize("text,key,reason", [h[1:] for h in HOSTILE], ids=[h[0] for h in HOSTILE])
def test_hostile_file_is_one_line_naming_file_key_reason(text, key, reason, tmp_path, capsys):
    path = tmp_path / "hostile.toml"
    path.write_text(text)
    t0 = time.perf_counter()
    code = cli.main(["solve", str(path), "--model", "linear-2", "--json"])
    assert time.perf_counter() - t0 < 5  # no quadratic check, no solve of an absurd file
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err, err[:500]
    assert str(path) in err and key in err and reason in err, err[:300]


def test_duplicate_checks_are_linear():
    """5000 nodes in a chain with 500 outputs: well under a second (was quadratic)."""
    n = limits.MAX_COUNT["nodes"]
    parts = ['[case]\nname = "chain"\ntitle = "t"\nunits = "nondim"\n']
    parts += [f'[[nodes]]\nid = "n{i}"\nx = {i}.0\ny = 0.0\n' for i in range(n)]
    parts += [
        f'[[members]]\nid = "m{i}"\nfrom = "n{i}"\nto = "n{i + 1}"\nE = 1.0\nI = 1.0\nA = 1.0\n'
        for i in range(n - 1)
    ]
    parts += ['[[supports]]\nnode = "n0"\ntype = "clamp"\n']
    parts += [f'[[outputs]]\nname = "o{i}"\nnode = "n{i}"\n' for i in range(499)]
    t0 = time.perf_counter()
    scene = cases.loads("".join(parts))
    assert len(scene.nodes) == n and time.perf_counter() - t0 < 5
    with pytest.raises(cases.CaseError, match=r"outputs\[499\].name: duplicate"):
        cases.loads("".join(parts) + '[[outputs]]\nname = "o0"\nnode = "n1"\n')


def test_bounds_keep_the_catalog_valid():
    for name in cases.catalog_names():
        cases.load(name)


def test_sweep_grid_size_is_bounded():
    """A sweep grid is the product of its axes: 100 x 5 x 5 scenes is refused, by name."""
    text = (cases.CATALOG / "thesis-sixbar-config4-sweep-rest.toml").read_text()
    values = ", ".join(f"{20 + 0.2 * i:.1f}" for i in range(100))
    big = edit("values = [20.0, 25.0, 30.0, 35.0, 40.0]", f"values = [{values}]", text)
    with pytest.raises(cases.CaseError, match=r"analysis.grid: 2500 sweep scenes exceed .* 2000"):
        cases.loads(big)


def test_bad_model_option_names_the_file(tmp_path, capsys):
    path = tmp_path / "opts.toml"
    path.write_text(HEAD + '[[models]]\nname = "linear-2"\noptions = { no_such_option = 1 }\n')
    assert cli.main(["solve", str(path), "--model", "linear-2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{path}: models[0].options" in err


def test_internal_error_is_one_line_exit_3_and_debug_shows_traceback(monkeypatch, capsys):
    def broken(*args, **kwargs):
        raise KeyError("planted bug")

    monkeypatch.setattr(cli, "solution_json", broken)
    argv = ["solve", "cantilever-tip-load", "--model", "linear-2", "--json"]
    assert cli.main(argv) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(r"case cantilever-tip-load, model linear-2\): KeyError: .*report", err)
    assert cli.main([*argv, "--debug"]) == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and "planted bug" in err and err.strip().endswith("--debug")


def test_solve_time_limit_fails_a_runaway_model(tmp_path, monkeypatch, capsys):
    from tests.test_input_faults import register_dummies

    register_dummies(monkeypatch)
    path = tmp_path / "c.toml"
    path.write_text(HEAD)
    t0 = time.perf_counter()
    assert cli.main(["solve", str(path), "--model", "dummy-spin", "--time-limit", "0.3"]) == 0
    assert time.perf_counter() - t0 < 10
    assert "failed" in capsys.readouterr().out
    argv = ["solve", str(path), "--model", "dummy-hog", "--memory-limit", "100", "--json"]
    assert cli.main(argv) == 0
    assert "memory limit of 100 MB exceeded" in capsys.readouterr().out


def test_markdown_escapes_user_text_and_file_names_are_sanitised(monkeypatch, tmp_path):
    from reports.render import build_document, slug
    from reports.render.md import to_markdown
    from reports.run import exports, runner
    from tests.test_input_faults import register_dummies
    from tests.test_runner import CASE_TOML

    register_dummies(monkeypatch)
    evil = '<img src=x onerror="alert(1)"> [click](javascript:alert(2)) `code`'
    text = CASE_TOML.format(name="evil", P=0.3, scale=1.0)
    text = text.replace('title = "Dummy cantilever evil"', f"title = '{evil}'")
    text = text.replace('tags = ["test"]', "tags = ['<b>bold</b>']")
    scene = cases.loads(text)
    res = runner.run_matrix([scene], ["dummy-crash"], tmp_path, workers=1, render=False)
    md = to_markdown(build_document(res.payload, {}))
    assert "<img" not in md and "<b>" not in md
    assert not re.search(r"(?<!\\)\]\(javascript:", md)  # no live link
    assert '&lt;img src=x onerror="alert(1)"&gt; \\[click\\](javascript:alert(2))' in md
    for bad in ("..", ".", "../../etc/passwd", "a/b\\c", "x\0y"):
        for name in (slug(bad), exports._slug(bad)):
            assert name not in (".", "..") and "/" not in name and "\\" not in name
            assert "\0" not in name
