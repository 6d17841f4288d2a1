"""README.md's Python examples run (as scikit-fem tests its examples): every ```python block,
in order, in one namespace, in a folder holding a small run at ``flexbench-out`` (the
README's output folder) so the run-folder examples have something to load."""

import re
from pathlib import Path

import matplotlib
import pytest

import cases
from reports.run import runner

matplotlib.use("Agg")

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks(text: str) -> list[str]:
    """The bodies of the ```python fenced blocks, in order."""
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)


def test_the_readme_has_python_examples():
    blocks = python_blocks(README.read_text())
    assert len(blocks) >= 4
    assert any("to_frame" in b for b in blocks) and any("load_run" in b for b in blocks)


@pytest.fixture()
def run_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    kw = dict(quick=True, workers=1, render=False, progress=False, export=None)
    runner.run_matrix([cases.load("cantilever-tip-load")], ["linear-1"], "flexbench-out", **kw)
    return tmp_path / "flexbench-out"


def test_readme_python_examples_run(run_folder):
    import matplotlib.pyplot as plt

    namespace: dict = {"__name__": "readme"}
    for i, block in enumerate(python_blocks(README.read_text())):
        code = compile(block, f"README.md python block {i + 1}", "exec")
        exec(code, namespace)  # noqa: S102  (the README's own examples)
    plt.close("all")
    assert namespace["sol"].status == "converged"
    assert namespace["tip"]["factor"].iloc[-1] == 1.0
