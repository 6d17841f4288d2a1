"""Rigid stays rigid, strains stay small, no static verdict under follower loads (issue 11,
item 7)."""

from __future__ import annotations

from pathlib import Path

import cases
import reports
from cases.schema import Driver
from tests.test_verify_linear_bcm import beam_scene

TRAPS = Path(__file__).parent / "data" / "traps"


def test_driver_beyond_the_reach_of_rigid_links_fails_with_the_reason():
    """DAS-2D Ex. 5 slider pushed to 150 mm while crank + coupler reach 147.3 mm."""
    sol = reports.solve(cases.load(str(TRAPS / "driver-beyond-reach.toml")), "fem-8")
    assert sol.status == "failed"
    assert "rigid links" in sol.message and "reach" in sol.message
    # it fails where the links run out of reach (147.3 - 140.0 = 7.29 mm), not before
    assert sol.steps[-1].outputs["slider.ux"] >= 7.0
    trap = cases.load(str(TRAPS / "driver-beyond-reach.toml"))
    stiff = reports.solve(trap, "fem-8", options={"rigid_links": "stiff"})
    assert stiff.status == "failed"
    assert "rigid link" in stiff.message and "stretched" in stiff.message


def test_the_catalog_slider_crank_keeps_its_links_rigid():
    sol = reports.solve("das2d-ex5-constant-force", "fem-8")
    assert sol.status == "converged"


def test_tip_driven_to_500_percent_strain_fails():
    import dataclasses

    scene = beam_scene(1.0, 0.0, A=1.0, steps=4)
    a = dataclasses.replace(
        scene.analysis,
        kind="distance",
        driver=Driver("displacement", 0.0, 5.0, node="B", direction="x"),
    )
    sol = reports.solve(dataclasses.replace(scene, analysis=a), "fem-8")
    assert sol.status == "failed" and "moderate-strain" in sol.message


def test_follower_loads_get_no_static_stability_verdict():
    sol = reports.solve("cantilever-follower-load", "fem-8")
    assert sol.status == "converged"
    assert all(s.stable is None for s in sol.steps)
    dead = reports.solve("cantilever-tip-load", "fem-8")
    assert all(s.stable is True for s in dead.steps)
