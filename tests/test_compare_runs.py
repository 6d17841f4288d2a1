"""``reports.bench.compare_runs``: two runs' answers compared number by number."""

from __future__ import annotations

import copy
import json

import pytest

from reports.bench import compare_runs


def _payload() -> dict:
    steps = [
        {"factor": 0.0, "energy": 0.0, "stable": True, "outputs": {"tip.uy": 0.0, "tip.rot": 0.0}},
        {"factor": 1.0, "energy": 2.5, "stable": True, "outputs": {"tip.uy": -4.0, "tip.rot": 0.3}},
    ]
    return {
        "cases": {"c": {"length_scale": 10.0}},
        "results": [{"case": "c", "model": "m", "status": "converged", "steps": steps}],
    }


def test_identical_runs_agree():
    out = compare_runs.compare(_payload(), _payload(), 1e-12)
    assert (out.pairs, out.numbers, out.worst, out.differences) == (1, 10, 0.0, [])


def test_a_change_above_the_tolerance_is_named_with_its_size():
    b = _payload()
    b["results"][0]["steps"][1]["outputs"]["tip.uy"] = -4.0 * (1 + 1e-9)
    out = compare_runs.compare(_payload(), b, 1e-12)
    assert out.worst == pytest.approx(4e-9 / 10.0, rel=1e-6)  # at the length scale 10
    assert len(out.differences) == 1 and "tip.uy[1]" in out.differences[0]
    # scaled by the output's size over the path: a change of 1e-13 of it passes at 1e-12
    b["results"][0]["steps"][1]["outputs"]["tip.uy"] = -4.0 * (1 + 1e-13)
    assert compare_runs.compare(_payload(), b, 1e-12).differences == []


def test_round_off_of_an_output_zero_by_symmetry_is_judged_at_the_length_scale():
    a, b = _payload(), _payload()
    a["results"][0]["steps"][1]["outputs"]["tip.ux"] = 1e-20
    b["results"][0]["steps"][1]["outputs"]["tip.ux"] = 3e-20
    a["results"][0]["steps"][0]["outputs"]["tip.ux"] = b["results"][0]["steps"][0]["outputs"][
        "tip.ux"
    ] = 0.0
    out = compare_runs.compare(a, b, 1e-12)
    assert out.differences == [] and out.worst == pytest.approx(2e-20 / 10.0)


def test_status_steps_and_missing_pairs(tmp_path, capsys):
    b = copy.deepcopy(_payload())
    b["results"][0]["status"], b["results"][0]["message"] = "failed", "time limit of 20 s"
    b["results"].append({"case": "d", "model": "m", "status": "converged", "steps": []})
    pa, pb = tmp_path / "a.json", tmp_path / "b.json"
    pa.write_text(json.dumps(_payload()))
    pb.write_text(json.dumps(b))
    assert compare_runs.main([str(pa), str(pb)]) == 1
    text = capsys.readouterr().out
    assert (
        "status converged -> failed (time limit of 20 s)" in text
        and "only in one run: d x m" in text
    )
