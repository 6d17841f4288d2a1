"""Issue-9 schema additions: per-member models, kinematics, synthesis and MA analyses.

Good files load into the documented dataclasses; every mistake names file, key and reason
(the examples mirror /work/issues/mech-schema.md).
"""

from __future__ import annotations

import pytest

import cases

FOURBAR = """
[case]
name = "four-bar"
title = "Rigid four-bar crank-rocker"
units = "mm-N-MPa"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 0.0
y = 20.0

[[nodes]]
id = "C"
x = 60.0
y = 40.0

[[nodes]]
id = "D"
x = 60.0
y = 0.0

[[members]]
id = "crank"
from = "A"
to = "B"
kind = "rigid"
end_b = "pin"

[[members]]
id = "coupler"
from = "B"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "rocker"
from = "C"
to = "D"
kind = "flexible"
E = 1400.0
width = 5.0
thickness = 1.5
end_a = "pin"
model = "cbcm-2"

[[supports]]
node = "A"
type = "pin"

[[supports]]
node = "D"
type = "clamp"

[[outputs]]
name = "coupler"
node = "C"
"""

KINEMATICS = """
[analysis]
kind = "kinematics"
steps = 36
mobility = 1

[analysis.driver]
kind = "rotation"
member = "crank"
start = 0.0
stop = 90.0
"""

STIFFNESS = """
[[loads]]
id = "push"
node = "C"
fx = 1.0

[analysis]
kind = "synthesis"
steps = 10

[analysis.synthesis]
goal = "stiffness"
members = ["rocker"]
output = "coupler.ux"
target = 2.0
"""

CRITICAL = """
[analysis]
kind = "synthesis"
steps = 120

[analysis.driver]
kind = "rotation"
member = "crank"
start = -30.0
stop = 90.0

[analysis.synthesis]
goal = "critical-load"
members = ["rocker"]
target = 5.0
"""

ENERGY_MA = """
[analysis]
kind = "energy"
steps = 20

[analysis.driver]
kind = "rotation"
member = "crank"
start = 0.0
stop = 30.0

[analysis.ma]
output = "coupler"
direction = "x"
input = "driver"
"""


def test_per_member_model_and_kinematics_load():
    s = cases.loads(FOURBAR + KINEMATICS, source="k.toml")
    assert s.member("rocker").model == "cbcm-2"
    assert s.member("crank").model is None
    assert s.analysis.kind == "kinematics" and s.analysis.mobility == 1


def test_synthesis_and_ma_load():
    s = cases.loads(FOURBAR + STIFFNESS)
    assert s.analysis.synthesis.goal == "stiffness"
    assert s.analysis.synthesis.members == ("rocker",)
    assert s.analysis.synthesis.output == "coupler.ux"
    s = cases.loads(FOURBAR + CRITICAL)
    assert s.analysis.synthesis.target == 5.0 and s.analysis.synthesis.output is None
    s = cases.loads(FOURBAR + ENERGY_MA)
    assert (s.analysis.ma.output, s.analysis.ma.direction, s.analysis.ma.input) == (
        "coupler",
        "x",
        "driver",
    )


BAD = [
    (
        FOURBAR.replace('model = "cbcm-2"', 'model = "fem-32"') + KINEMATICS,
        "members[2].model",
        "not a reduced beam model",
    ),
    (
        FOURBAR.replace('kind = "rigid"\nend_b', 'kind = "rigid"\nmodel = "bcm"\nend_b')
        + KINEMATICS,
        "members[0].model",
        "only flexible members",
    ),
    (
        FOURBAR + KINEMATICS.replace("mobility = 1", "mobility = -1"),
        "analysis.mobility",
        ">= 0",
    ),
    (
        FOURBAR
        + KINEMATICS.replace(
            '[analysis.driver]\nkind = "rotation"\nmember = "crank"\nstart = 0.0\nstop = 90.0\n', ""
        ),
        "analysis.driver",
        "missing",
    ),
    (
        FOURBAR + STIFFNESS.replace('members = ["rocker"]', 'members = ["crank"]'),
        "analysis.synthesis.members",
        "not a flexible member",
    ),
    (
        FOURBAR + STIFFNESS.replace('output = "coupler.ux"\n', ""),
        "analysis.synthesis.output",
        "needs an output",
    ),
    (
        FOURBAR + STIFFNESS.replace('goal = "stiffness"', 'goal = "weight"'),
        "analysis.synthesis.goal",
        "unknown value",
    ),
    (
        FOURBAR + CRITICAL.replace("target = 5.0", "target = -5.0"),
        "analysis.synthesis.target",
        "> 0",
    ),
    (
        FOURBAR + STIFFNESS.replace('kind = "synthesis"', 'kind = "load"'),
        "analysis.synthesis",
        "only a 'synthesis' analysis",
    ),
    (
        FOURBAR + ENERGY_MA.replace('direction = "x"', 'direction = "z"'),
        "analysis.ma.direction",
        "unknown value",
    ),
    (
        FOURBAR + ENERGY_MA.replace('output = "coupler"', 'output = "nowhere"'),
        "analysis.ma.output",
        "not an [[outputs]] name",
    ),
    (
        FOURBAR + ENERGY_MA.replace('input = "driver"', 'input = "nosuchload"'),
        "analysis.ma.input",
        "neither 'driver' nor a load id",
    ),
]


@pytest.mark.parametrize("text,key,reason", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_bad_issue9_keys(text, key, reason):
    with pytest.raises(cases.CaseError) as info:
        cases.loads(text, source="bad.toml")
    msg = str(info.value)
    assert msg.startswith("bad.toml: "), msg
    assert f": {key}: " in msg, f"expected key {key!r} in {msg!r}"
    assert reason in msg, msg
    assert "\n" not in msg
