"""The report's thesis section (issue 25): Table 4-8 beside thesis-force-method, the settled
angles against the quasi-static ones, the figures written."""

from __future__ import annotations

import pytest

import cases
from reports import api
from reports.render import thesis_dynamics as td
from reports.run.store import extras_json


def _record(sol: object) -> dict:
    steps = [{"factor": s.factor, "outputs": dict(s.outputs), "stable": s.stable}
             for s in sol.steps]  # fmt: skip
    return {"case": sol.case, "model": sol.model, "status": sol.status, "steps": steps,
            "extras": extras_json(dict(sol.extras))}  # fmt: skip


@pytest.fixture(scope="module")
def payload() -> dict:
    scene = cases.load("thesis-sixbar-config4")
    recs = [_record(api.solve(scene, m)) for m in ("kinetostatic", "thesis-force-method", "replay")]
    return {"cases": {scene.name: {"analysis": {"kind": "deploy"}}}, "results": recs}


def test_table_4_8_printed_beside_ours(payload):
    rows = td.table_rows(payload["results"][1], "4-8")
    f4y = next(r for r in rows if r[:2] == ["Part 1", "J4.y"])
    assert float(f4y[2]) == -235.439776978666  # Table 4-8 as printed
    assert float(f4y[5]) >= 11.0  # digits reproduced
    assert len(rows) == 20  # five joints, x and y, Parts 1 and 2


def test_blocks_draw_the_figures_and_settled_angles(payload, tmp_path):
    blocks = td.blocks(payload, tmp_path)
    imgs = [b[1] for b in blocks if b[0] == "img"]
    assert any(i.endswith("-deploy-history.png") for i in imgs)
    assert any(i.endswith("-deploy.gif") for i in imgs)
    for i in imgs:
        assert (tmp_path / i).stat().st_size < 200_000  # small files
    settled = next(b for b in blocks if b[0] == "table" and b[1][0] == "joint")
    j1 = next(r for r in settled[2] if r[0] == "J1")
    assert float(j1[1]) == pytest.approx(30.0, abs=1e-5)  # the closed-form deployed pose
    assert abs(float(j1[3])) < 1e-5
