"""Reference pairs kept across runs (``reports.run.refcache``): a run into a new folder takes
an earlier run's reference records and exported files instead of solving them again."""

import json

import cases
from reports.run.runner import run_matrix


def test_second_run_takes_references_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FLEXBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("FLEXBENCH_NO_PAIR_CACHE", raising=False)
    scene = cases.load("cantilever-tip-load")
    kw = {"models": ["prb-1r"], "render": False, "progress": False, "teaching": None}
    first = run_matrix([scene], out_dir=tmp_path / "a", **kw)
    second = run_matrix([scene], out_dir=tmp_path / "b", **kw)
    refs = [r for r in first.payload["results"] if r["role"] == "reference"]
    assert len(refs) == 1 and first.payload["stats"]["cached"] == 0
    assert second.payload["stats"]["cached"] == 1  # the reference, not the model
    again = {r["key"]: r for r in second.payload["results"]}[refs[0]["key"]]
    assert again["cached"] is True and again["steps"] == refs[0]["steps"]
    for entry in again["exports"].values():  # its ParaView files are in the new folder
        if isinstance(entry, dict):
            assert (tmp_path / "b" / entry["pvd"]).is_file()
    model = [r for r in second.payload["results"] if r["role"] == "model"][0]
    assert "cached" not in model
    saved = json.loads((tmp_path / "b" / "results.json").read_text())
    assert saved["stats"]["cached"] == 1


def test_no_pair_cache_solves_every_pair(tmp_path, monkeypatch):
    monkeypatch.setenv("FLEXBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("FLEXBENCH_NO_PAIR_CACHE", "1")
    scene = cases.load("cantilever-tip-load")
    kw = {"models": ["prb-1r"], "render": False, "progress": False, "teaching": None}
    run_matrix([scene], out_dir=tmp_path / "a", **kw)
    second = run_matrix([scene], out_dir=tmp_path / "b", **kw)
    assert second.payload["stats"]["cached"] == 0
