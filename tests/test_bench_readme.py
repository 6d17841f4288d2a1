"""README's speed table is one generated block (``reports.bench.speed.write_readme``)."""

import pytest

from reports.bench.speed import README_END, README_START, markdown, write_readme


def test_block_is_replaced_and_the_rest_kept(tmp_path):
    p = tmp_path / "README.md"
    p.write_text(f"intro\n{README_START}\nold table\n{README_END}\noutro\n")
    text = markdown(["head"], [("A", ["| x |", "|---|", "| 1 |"])], ["- t: met"])
    write_readme(str(p), text)
    got = p.read_text()
    assert got.startswith(f"intro\n{README_START}\n\nhead\n#### A\n\n| x |")
    assert "old table" not in got and got.endswith(f"- t: met\n\n{README_END}\noutro\n")
    write_readme(str(p), text)  # idempotent
    assert p.read_text() == got


def test_missing_block_is_an_error(tmp_path):
    p = tmp_path / "README.md"
    p.write_text("no markers\n")
    with pytest.raises(SystemExit, match="no"):
        write_readme(str(p), "x")
