"""Bistable driver search and critical-load synthesis (issue 9, DAS-2D Ex. 4 / Ex. 6).

References (never the assembler's own numbers):
* closed form: Ex. 4's rocker is unstressed at crank rotations 0 and -90 deg (the coupler-length
  circle about the drawn node 3 cuts the crank circle there), so both are stable equilibria;
* fem-auto numbers quoted, with provenance, in cases/catalog/das2d-ex4-bistable-fourbar.toml
  and das2d-ex6-bistable-synthesis.toml (unstable -52.7278 deg, barrier 2.915972 N mm, critical
  torque 4.856951 N mm; synthesised EI 2026.73 N mm^2, barrier 3.00185 N mm);
* fem-auto re-solving each synthesised scene (``extras[...]["fem-auto"]``).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

import cases
import reports
from cases.schema import Driver, Load, Synthesis
from reports.render import synthnote
from reports.run.store import extras_json

EX4 = cases.load("das2d-ex4-bistable-fourbar")


def _search(stop: float = -120.0, steps: int = 48):
    a = dataclasses.replace(
        EX4.analysis,
        kind="synthesis",
        steps=steps,
        driver=dataclasses.replace(EX4.analysis.driver, stop=stop),
        synthesis=Synthesis("bistable", (), math.nan),
    )
    return dataclasses.replace(EX4, analysis=a)


def test_bistable_search_finds_both_stable_positions_and_barrier():
    sol = reports.solve(_search(), "cbcm-8")
    assert sol.status == "converged", sol.message
    b = sol.extras["bistable"]
    assert b["bistable"] and "bistable: stable at" in sol.message
    assert b["stable"] == pytest.approx([0.0, -90.0], abs=1e-6)  # closed form
    assert b["unstable"] == pytest.approx(-52.7278, abs=0.02)  # fem-auto (case provenance)
    assert b["barrier"]["forward"] == pytest.approx(2.915972, rel=2e-3)
    # both stable positions are unstressed: the barrier is the same both ways
    assert b["barrier"]["backward"] == pytest.approx(b["barrier"]["forward"], rel=1e-6)
    c = b["critical"]
    assert c["forward"] == pytest.approx(-4.856951, rel=2e-3)  # fem-auto extremum
    assert c["forward_at"] == pytest.approx(-28.5747, abs=0.3)
    # the search re-solves with fem-auto: its own equilibria and the switching load back
    fe = b["fem-auto"]
    assert fe["status"] == "converged" and fe["bistable"]["bistable"]
    assert fe["bistable"]["unstable"] == pytest.approx(b["unstable"], abs=0.05)
    assert c["backward"] > 0 > c["forward"]
    assert c["backward"] == pytest.approx(fe["bistable"]["critical"]["backward"], rel=3e-3)


def test_not_bistable_is_said():
    """Up to -40 deg the crank only climbs the first energy well: one stable equilibrium."""
    sol = reports.solve(_search(stop=-40.0, steps=16), "cbcm-4")
    assert sol.status == "converged", sol.message
    b = sol.extras["bistable"]
    assert b["bistable"] is False and "one stable equilibrium only" in b["reason"]
    assert sol.message.startswith("not bistable along this driver")


def test_critical_load_synthesis_reports_both_stable_positions_and_barrier():
    sol = reports.solve(cases.load("das2d-ex6-bistable-synthesis"), "cbcm-8")
    assert sol.status == "converged", sol.message
    syn, b = sol.extras["synthesis"], sol.extras["bistable"]
    assert syn["EI"]["rocker"] == pytest.approx(2026.73, rel=5e-4)  # fem-auto, scaled
    assert abs(b["critical"]["forward"]) == pytest.approx(5.0, rel=1e-9)  # the target
    assert b["stable"] == pytest.approx([0.0, -90.0], abs=1e-6)
    assert b["barrier"]["forward"] == pytest.approx(3.00185, rel=2e-3)
    fe = syn["fem-auto"]  # the synthesised EI re-solved by the FE meets the target
    assert fe["status"] == "converged" and fe["relative_error"] < 2e-3
    assert fe["bistable"]["stable"][0] == pytest.approx(0.0, abs=1e-9)
    lines = synthnote.notes(extras_json(sol.extras))  # what the report's model table shows
    assert any(ln.startswith("fem-auto on the synthesised scene: 5.0") for ln in lines)
    assert any(ln.startswith("bistable: stable at 0 and -90") for ln in lines)


def _toml(tmp_path, synthesis: str, driver: bool = True):
    text = (cases.CATALOG / "das2d-ex4-bistable-fourbar.toml").read_text()
    head, _, rest = text.partition("[analysis]")
    tail = "[[outputs]]" + rest.partition("[[outputs]]")[2]
    drv = '[analysis.driver]\nkind = "rotation"\nmember = "crank"\nstart = 0.0\nstop = -120.0\n'
    body = f'[analysis]\nkind = "synthesis"\nsteps = 24\n\n{drv if driver else ""}\n'
    p = tmp_path / "bad.toml"
    p.write_text(head + body + "[analysis.synthesis]\n" + synthesis + "\n\n" + tail)
    return p


@pytest.mark.parametrize(
    ("synthesis", "driver", "key"),
    [
        ('goal = "bistable"\ntarget = 5.0', True, "analysis.synthesis.target"),
        ('goal = "bistable"\nmembers = ["rocker"]', True, "analysis.synthesis.members"),
        ('goal = "critical-load"\nmembers = ["rocker"]\ntarget = 5.0', False, "analysis.driver"),
        ('goal = "critical-load"\nmembers = ["rocker"]', True, "analysis.synthesis.target"),
    ],
)
def test_bad_bistable_input_names_the_key(tmp_path, synthesis, driver, key):
    p = _toml(tmp_path, synthesis, driver)
    with pytest.raises(cases.CaseError) as exc:
        cases.load(str(p))
    msg = str(exc.value)
    assert str(p.name) in msg and key in msg and "\n" not in msg


def test_bistable_toml_loads(tmp_path):
    scene = cases.load(str(_toml(tmp_path, 'goal = "bistable"')))
    assert scene.analysis.synthesis.goal == "bistable"
    assert isinstance(scene.analysis.driver, Driver)
    example = cases.load(str(Path(__file__).parent / "fixtures" / "das2d-ex4-bistable-driver.toml"))
    assert example.analysis.synthesis.goal == "bistable" and example.nodes == EX4.nodes


def _pushed(scene, **analysis):
    """Ex. 4 with a dead force at the crank tip (150 deg: never along the crank over the
    sweep), so that load control defines a tangent verdict with the driver released."""
    b = math.radians(150.0)
    ld = Load(id="push", node="N2", fx=math.cos(b), fy=math.sin(b))
    a = dataclasses.replace(scene.analysis, **analysis)
    return dataclasses.replace(scene, loads=(ld,), analysis=a)


def test_ex4_verdicts_agree_at_every_equilibrium():
    """Reduced-Hessian verdict (driver released) at each reported equilibrium = the FE tangent
    verdict there (distance analysis landing on the equilibrium: load factor ~0, load control)
    = the replay's impulse probe for the stable ones (each drawn stress-free: the rocker is
    undeflected at 0 and -90 deg).  The unstable equilibrium cannot be held by a dynamic
    replay; the FE tangent judges it."""
    red = reports.solve(dataclasses.replace(EX4, analysis=_search().analysis), "cbcm-8")
    eq = red.extras["equilibria"]
    assert [e["kind"] for e in eq] == ["stable", "unstable", "stable"]
    for e in eq:
        c = e["coordinate"]
        drv = dataclasses.replace(EX4.analysis.driver, stop=c)
        n = max(1, math.ceil(abs(c) / 10.0))
        fe = reports.solve(_pushed(EX4, kind="distance", steps=n, driver=drv), "fem-16")
        assert fe.status == "converged", fe.message
        assert abs(fe.steps[-1].factor) < 0.05  # the FE is at (nearly) its own equilibrium
        assert fe.steps[-1].stable is (e["kind"] == "stable"), (c, fe.steps[-1].stable)
    n1 = EX4.node("N1")
    for c in (0.0, -90.0):  # the two stable positions, drawn
        x, y = n1.x - 15.0 * math.sin(math.radians(c)), n1.y + 15.0 * math.cos(math.radians(c))
        nodes = tuple(dataclasses.replace(n, x=x, y=y) if n.id == "N2" else n for n in EX4.nodes)
        drawn = _pushed(dataclasses.replace(EX4, nodes=nodes), kind="load", steps=1)
        drawn = dataclasses.replace(
            drawn, analysis=dataclasses.replace(drawn.analysis, factor_end=0.01, driver=None)
        )
        rep = reports.solve(drawn, "replay")
        assert rep.status == "converged", rep.message
        assert rep.extras["probes"][0]["stable"] is True and rep.steps[0].stable is not False
