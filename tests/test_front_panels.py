"""The front page's panels: where the run's CPU went, the sweep's stability-map thumbnail and
the families of cases."""

from __future__ import annotations

import json

import numpy as np
import pytest

from reports.render import families, sweep_map, timebudget


def test_pair_cpu_counts_first_solve_repeats_post_and_uncached_estimate():
    rec = {
        "timing": {
            "first_s": 0.012,
            "first_cpu_s": 0.010,
            "total_s": 0.024,  # > first_s: repeated
            "cpu_median_s": 0.002,
            "n_repeats": 5,
            "post_cpu_s": 0.001,
        },
        "cost": {"cpu_s": 0.0004, "noise_s": 0.0, "n": 3, "cached": False, "spent_s": 0.003},
    }
    solve, post, est = timebudget.pair_cpu(rec)
    assert solve == pytest.approx(0.010 + 5 * 0.002)
    assert post == 0.001
    assert est == 0.003  # what the sampling measured it spent
    slow = {"first_s": 0.5, "first_cpu_s": 0.4, "total_s": 0.5}
    one = {"cpu_s": 0.4, "noise_s": 0.0, "n": 1, "cached": False, "spent_s": 0.0}  # the first
    assert timebudget.pair_cpu({"timing": slow, "cost": one}) == (0.4, 0.0, 0.0)
    spent = {"cpu_s": 0.05, "noise_s": 0.01, "n": 3, "cached": False, "spent_s": 0.1}
    assert timebudget.pair_cpu({"timing": slow, "cost": spent})[2] == 0.1  # as measured
    rec["timing"]["total_s"] = rec["timing"]["first_s"]  # not repeated: the first call alone
    rec["cost"]["cached"] = True
    assert timebudget.pair_cpu(rec) == (0.010, 0.001, 0.0)


def test_time_panel_adds_up_to_the_measured_solving_stage(teaching_run):
    out, res, _ = teaching_run
    payload = json.loads((out / "results.json").read_text())
    cpu = payload["stats"]["cpu"]
    assert cpu["solve_stage_s"] > 0 and set(cpu["atlases_s"]) | set(cpu["atlases_reused"])
    body, total = timebudget.rows(payload, {"_render": {"cpu_s": 1.5}})
    secs = {row[0]: float(row[2]) for row in body}
    stage = sum(v for k, v in secs.items() if not k.startswith("rendering"))
    # rounded to 3 digits per row: the rows before rendering are the solving stage
    assert stage == pytest.approx(cpu["solve_stage_s"], rel=0.01)
    assert secs["rendering this report (figures, scenes, maps)"] == 1.5
    assert total == pytest.approx(cpu["solve_stage_s"] + 1.5, rel=0.01)
    assert {"elastica (exact, BVP)", "PRB models", "BCM", "linear beams"} <= set(secs)
    html = (out / "report.html").read_text()
    assert 'id="time">Where the time goes' in html and "validity atlases" in html


def test_sweep_thumbnail_puts_each_point_in_its_block_column_and_row():
    pts = [
        {"x.k1": a, "x.k2": b, "x.k3": c} for c in (1.0, 2.0) for b in (5.0, 6.0) for a in (0, 1)
    ]
    verdicts = ["stable"] * 8
    verdicts[pts.index({"x.k1": 1, "x.k2": 5.0, "x.k3": 2.0})] = "unstable"
    img = sweep_map.image(pts, verdicts)
    assert img.shape == (2, 2 * 3 - 1, 3)  # 2 blocks of 2 x 2, one white column between
    assert np.allclose(img[:, 2], 1.0)  # the gap
    # block 1 (k3 = 2), column 1 (k1 = 1), bottom row (k2 = 5: the lowest value)
    assert tuple(img[1, 3 + 1]) == sweep_map.COLOURS["unstable"]
    n_red = sum(tuple(px) == sweep_map.COLOURS["unstable"] for px in img.reshape(-1, 3))
    assert n_red == 1


@pytest.mark.parametrize(
    "case, fam",
    [
        ({"tags": ["single-beam"]}, "beams"),
        ({"tags": ["arch", "hard"], "undeformed": {"a": 0, "b": 0}}, "beams"),
        ({"tags": ["mechanism", "six-bar", "deploy"]}, "deployables"),
        ({"tags": [], "analysis": {"kind": "deploy"}}, "deployables"),
        ({"tags": ["mechanism"]}, "mechanisms"),
        ({"tags": [], "undeformed": {"left": 0, "right": 0}}, "mechanisms"),  # untagged
        ({"tags": [], "undeformed": {"beam": 0}}, "beams"),
    ],
)
def test_family_from_tags_else_from_the_scene(case, fam):
    assert families.family(case) == fam


def test_time_panel_rows_from_hand_made_records():
    def rec(model, first, post, cost=None):
        t = {"first_s": first, "first_cpu_s": first, "total_s": first, "post_cpu_s": post}
        return {"model": model, "timing": t, "cost": cost}

    payload = {
        "results": [
            rec("prb-1r", 0.2, 0.1, {"cpu_s": 0.01, "n": 10, "cached": False, "spent_s": 0.1}),
            rec("prb-3r", 0.3, 0.0),
            # a solve past the sampling budget is its own estimate: no sample to add
            rec("fem-auto", 2.0, 0.0, {"cpu_s": 2.0, "n": 1, "cached": False, "spent_s": 0.0}),
            rec("replay", 5.0, 0.0) | {"cached": True},  # an earlier run's solve: 0 s here
            {"model": "bcm", "status": "not-applicable"},  # no timing: not a row
        ],
        "stats": {
            "cpu": {
                "solve_stage_s": 10.0,
                "atlases_s": {"force": 4.0},
                "atlases_reused": [],
                "figures_s": 1.0,
            }
        },
    }
    body, total = timebudget.rows(payload, {"_render": {"cpu_s": 2.0}})
    got = {row[0]: (row[1], float(row[2])) for row in body}
    assert got == {
        "reference: finite elements (fem-N, fem-auto)": ("1", 2.0),
        "PRB models": ("2", 0.2 + 0.1 + 10 * 0.01 + 0.3),
        "reference pairs reused from the cache": ("1", 0.0),
        "validity atlases (teaching page)": ("", 4.0),
        "rest of the solving stage": ("", 10.0 - 2.0 - 0.7 - 4.0 - 1.0),
        "per-case figures drawn while solving": ("", 1.0),
        "rendering this report (figures, scenes, maps)": ("", 2.0),
    }
    assert total == pytest.approx(12.0)
