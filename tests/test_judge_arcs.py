"""Circular-arc members (``sweep_deg``) and the path contract (issue 11, items 5-7)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import cases
import reports
from cases.arc import arc_length, arc_points

DATA = Path(__file__).parent / "data"

ARC_CANTILEVER = """
[case]
name = "arc-unrolls"
title = "Quarter-circle cantilever straightened by an end moment EI/R"
units = "nondim"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 1.0
y = 1.0

[[members]]
id = "arc"
from = "A"
to = "B"
kind = "flexible"
sweep_deg = {sweep}
E = 1.0
I = 1.0
A = 1.0e8

[[supports]]
node = "A"
type = "clamp"

[[loads]]
node = "B"
moment = {moment}

[analysis]
kind = "load"
steps = 4

[[outputs]]
name = "tip"
node = "B"
"""


def test_arc_geometry_is_exact():
    s = np.linspace(0.0, arc_length(math.sqrt(2.0), 90.0), 7)
    p = arc_points((0.0, 0.0), (1.0, 1.0), 90.0, s)
    # a quarter circle of radius 1 centred at (0, 1), counter-clockwise from A to B
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1] - 1.0), 1.0, atol=1e-14)
    np.testing.assert_allclose(p[-1], [1.0, 1.0], atol=1e-14)
    assert arc_length(math.sqrt(2.0), 90.0) == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("sweep", [90.0, -90.0])
def test_fem_auto_straightens_an_arc_under_the_unrolling_moment(sweep):
    """Curvature 1/R minus M/EI: with M = EI/R (sign of the turn) the arc becomes the straight
    segment of length R |theta| along its initial tangent (exact)."""
    R, th = 1.0, math.radians(sweep)
    scene = cases.loads(ARC_CANTILEVER.format(sweep=sweep, moment=-math.copysign(1.0 / R, th)))
    assert scene.member_length("arc") == pytest.approx(R * abs(th))
    sol = reports.solve(scene, "fem-auto")
    assert sol.status == "converged"
    phi = math.pi / 4 - th / 2  # initial tangent: chord direction turned by -theta/2
    L = R * abs(th)
    tip = sol.steps[-1].outputs
    got = np.array([tip["tip.x"], tip["tip.y"]])
    err = float(np.max(np.abs(got - L * np.array([math.cos(phi), math.sin(phi)]))))
    est = max(sol.extras["error_estimate"]["tip.x"], sol.extras["error_estimate"]["tip.y"])
    assert err <= est + 1e-7 and err < 1e-6  # the geometry is refined with the mesh
    assert abs(sol.extras["observed_order"]["tip.x"] - 2.0) < 0.2


def test_single_beam_models_decline_arcs():
    scene = cases.loads(ARC_CANTILEVER.format(sweep=90.0, moment=-1.0))
    for model in ("elastica", "linear-8", "cbcm-4", "prb-3r"):
        sol = reports.solve(scene, model)
        assert sol.status == "not-applicable" and "arc" in sol.message


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ('kind = "rigid"\nsweep_deg = 30.0', "only flexible members are arcs"),
        ("sweep_deg = 400.0", "sweep_deg"),
    ],
)
def test_bad_sweep_is_one_line(text, why):
    bad = ARC_CANTILEVER.format(sweep=0.0, moment=1.0).replace("sweep_deg = 0.0", "")
    bad = bad.replace('kind = "flexible"\n', "").replace("E = 1.0\n", text + "\nE = 1.0\n")
    with pytest.raises(cases.CaseError, match=why):
        cases.loads(bad)


def test_dadeppo_arch_limit_load():
    """Clamped-hinged 215 deg arch: limit load P R^2/EI = 8.97 (DaDeppo & Schmidt 1975, three
    printed digits).  The FE on exact arcs converges at order 2 and its error estimate covers
    the published value up to the printed rounding (0.005)."""
    sol = reports.solve("dadeppo-arch-215", "fem-auto")
    assert sol.status == "converged"
    first = sol.extras["limit_points"][0]
    assert first["kind"] == "max"
    assert abs(first["order"] - 2.0) < 0.2
    assert abs(first["factor_extrapolated"] - 8.97) <= first["error"] + 0.005
    assert first["error"] < 1e-3  # and it is not a vacuous bar


def test_lee_frame_written_per_the_path_contract_passes_both_limit_points():
    """DESIGN.md: stop_output / stop_value without factor_end traces on to the stop value."""
    scene = cases.load(str(DATA / "path" / "lee-frame-contract.toml"))
    assert math.isinf(scene.analysis.factor_end)
    sol = reports.solve(scene, "fem-16")
    assert sol.status == "converged"
    assert sol.steps[-1].outputs["corner.uy"] == pytest.approx(-100.0)
    kinds = [lp["kind"] for lp in sol.extras["limit_points"]]
    assert kinds == ["max", "min"]
    # fem-16 (no extrapolation) is 0.5 % above the published 18.5
    assert sol.extras["limit_points"][0]["factor"] == pytest.approx(18.5, rel=1e-2)
