"""The deploy part of the report: verdict table, sweep counts, stability maps, explanation."""

from __future__ import annotations

import cases
from reports.render import stability_maps, textcheck
from reports.render.md import to_markdown
from reports.run import runner

BASE = (cases.CATALOG / "thesis-sixbar-config4-sweep-rest.toml").read_text()


def small_sweep():
    text = BASE.replace("values = [20.0, 25.0, 30.0, 35.0, 40.0]", "values = [20.0, 40.0]")
    text = text.replace("values = [110.0, 115.0, 120.0, 125.0, 130.0]", "values = [110.0, 130.0]")
    return cases.loads(text, source="small-sweep.toml")


def test_report_has_verdicts_and_maps(tmp_path):
    scenes = [small_sweep()]
    res = runner.run_matrix(
        scenes,
        ["thesis-force-method", "kinetostatic"],
        tmp_path,
        workers=1,
        export=None,
        render=False,
        progress=False,
    )
    with textcheck.checking() as found:  # margins fixed in inches: nothing cut or overlapping
        md = to_markdown(stability_maps.blocks(res.payload, tmp_path))
    maps = {k: v for k, v in found.items() if "stability-thesis-sixbar" in k}
    assert len(maps) == 2 and not any(maps.values()), maps
    assert "stability verdicts side by side" in md
    assert "Sweep thesis-sixbar-config4-sweep-rest: 8 points" in md
    assert "reduced Hessian" in md and "basis" in md
    figs = {p.name for p in (tmp_path / "figures").glob("stability-*.png")}
    assert any(f.endswith("-slices.png") for f in figs) and any(f.endswith("-3d.png") for f in figs)
    rows = [r for r in res.payload["results"] if r["model"] == "kinetostatic"]
    assert len(rows) == 8 and all(r["status"] == "converged" for r in rows)
