"""The case format: every catalog case loads; every user mistake is rejected with the key named."""

from __future__ import annotations

import math
import re

import pytest

import cases
from cases.schema import NODE_QUANTITIES

GOOD = """
[case]
name = "ok-case"
title = "A valid cantilever"
units = "m-N-Pa"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 1.0
y = 0.0

[[members]]
id = "beam"
from = "A"
to = "B"
kind = "flexible"
E = 1.0
I = 1.0
A = 1.0e4

[[supports]]
node = "A"
type = "clamp"

[[loads]]
node = "B"
fy = -1.0

[analysis]
kind = "load"
steps = 10

[[outputs]]
name = "tip"
node = "B"
"""


def edit(old: str, new: str, text: str = GOOD) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def test_good_case_loads():
    scene = cases.loads(GOOD, source="good.toml")
    assert scene.name == "ok-case"
    assert scene.members[0].EI == 1.0
    assert scene.output_keys() == [f"tip.{q}" for q in NODE_QUANTITIES]


def test_width_thickness_give_I_and_A():
    text = edit("I = 1.0\nA = 1.0e4", "width = 10.0\nthickness = 2.0")
    m = cases.loads(text).members[0]
    assert m.I == pytest.approx(10.0 * 2.0**3 / 12.0)
    assert m.A == pytest.approx(20.0)


@pytest.mark.parametrize("name", cases.catalog_names())
def test_catalog_case_loads(name):
    scene = cases.load(name)
    assert scene.name == name, "file name and case.name must agree"
    assert scene.title and scene.description, "catalog cases say what they are"
    for ref in scene.references:
        assert ref.source.strip() and ref.rationale.strip(), "provenance and tolerance rationale"
        assert math.isfinite(ref.value)


def test_catalog_has_the_issue_cases():
    names = set(cases.catalog_names())
    for required in (
        "cantilever-tip-load",
        "cantilever-inclined-tension",
        "cantilever-inclined-compression",
        "pure-moment-rollup",
        "cantilever-follower-load",
        "fixed-guided-beam",
        "column-postbuckling",
        "das2d-ex2-parallelogram",
        "das2d-ex5-constant-force",
    ):
        assert required in names


MB = (
    '[[members]]\nid = "beam"\nfrom = "A"\nto = "B"\nkind = "flexible"\nE = 1.0\nI = 1.0\nA = 1.0e4'
)
BAD = [
    # (id, text, key expected in the message, words expected in the reason)
    ("toml-syntax", GOOD + "\n[[nodes]\n", "(toml)", "toml"),
    ("unknown-top-table", GOOD + "\n[solver]\nx = 1\n", "solver", "unknown table"),
    (
        "missing-case",
        GOOD.replace(
            '[case]\nname = "ok-case"\ntitle = "A valid cantilever"\nunits = "m-N-Pa"\n', ""
        ),
        "case",
        "missing",
    ),
    ("missing-name", edit('name = "ok-case"\n', ""), "case.name", "missing"),
    ("bad-name", edit('"ok-case"', '"Not Kebab"'), "case.name", "kebab"),
    ("unknown-units", edit('"m-N-Pa"', '"furlongs"'), "case.units", "unknown value"),
    (
        "unknown-case-key",
        edit('units = "m-N-Pa"', 'units = "m-N-Pa"\nauthor = "me"'),
        "case.author",
        "unknown key",
    ),
    ("no-nodes", re.sub(r"\[\[nodes\]\][^\[]*", "", GOOD), "nodes", "missing"),
    ("node-missing-y", edit("x = 1.0\ny = 0.0", "x = 1.0"), "nodes[1].y", "missing"),
    ("node-nan", edit("x = 1.0", "x = nan"), "nodes[1].x", "finite"),
    ("node-inf", edit("y = 0.0\n\n[[members]]", "y = inf\n\n[[members]]"), "nodes[1].y", "finite"),
    ("node-string-coord", edit("x = 1.0", 'x = "one"'), "nodes[1].x", "number"),
    ("duplicate-node", edit('id = "B"', 'id = "A"'), "nodes[1].id", "duplicate"),
    ("member-unknown-node", edit('to = "B"', 'to = "C"'), "members[0].to", "unknown node"),
    ("member-same-node", edit('to = "B"', 'to = "A"'), "members[0].to", "different"),
    ("zero-length", edit("x = 1.0", "x = 0.0"), "members[0].to", "zero-length"),
    (
        "unknown-kind",
        edit('kind = "flexible"', 'kind = "rubber"'),
        "members[0].kind",
        "unknown value",
    ),
    ("negative-E", edit("E = 1.0", "E = -1.0"), "members[0].E", "> 0"),
    ("zero-I", edit("I = 1.0", "I = 0.0"), "members[0].I", "> 0"),
    ("nan-A", edit("A = 1.0e4", "A = nan"), "members[0].A", "finite"),
    ("inf-E", edit("E = 1.0", "E = inf"), "members[0].E", "finite"),
    ("missing-E", edit("E = 1.0\n", ""), "members[0].E", "missing"),
    ("missing-I", edit("I = 1.0\n", ""), "members[0].I", "missing"),
    ("unknown-member-key", edit("E = 1.0", "E = 1.0\nG = 2.0"), "members[0].G", "unknown key"),
    (
        "bad-end",
        edit("A = 1.0e4", 'A = 1.0e4\nend_b = "glue"'),
        "members[0].end_b",
        "unknown value",
    ),
    ("spring-without-k", edit('kind = "flexible"', 'kind = "spring"'), "members[0].k", "missing"),
    ("k-on-beam", edit("A = 1.0e4", "A = 1.0e4\nk = 5.0"), "members[0].k", "only spring"),
    ("duplicate-member", GOOD + "\n" + MB + "\n", "members[1].id", "duplicate"),
    ("no-supports", edit('[[supports]]\nnode = "A"\ntype = "clamp"\n', ""), "supports", "missing"),
    (
        "support-unknown-node",
        edit('node = "A"\ntype', 'node = "Z"\ntype'),
        "supports[0].node",
        "unknown node",
    ),
    (
        "support-unknown-type",
        edit('type = "clamp"', 'type = "glue"'),
        "supports[0].type",
        "unknown value",
    ),
    ("pin-only-rotates", edit('type = "clamp"', 'type = "pin"'), "supports", "rigid-body"),
    ("slider-only", edit('type = "clamp"', 'type = "slider"'), "supports", "rigid-body"),
    (
        "two-supports-one-node",
        edit('type = "clamp"\n', 'type = "clamp"\n\n[[supports]]\nnode = "A"\ntype = "pin"\n'),
        "supports[1].node",
        "already has",
    ),
    (
        "angle-on-clamp",
        edit('type = "clamp"', 'type = "clamp"\nangle_deg = 10.0'),
        "supports[0].angle_deg",
        "only a slider",
    ),
    (
        "load-unknown-node",
        edit('node = "B"\nfy', 'node = "Q"\nfy'),
        "loads[0].node",
        "unknown node",
    ),
    (
        "load-node-and-member",
        edit('node = "B"\nfy', 'node = "B"\nmember = "beam"\nfy'),
        "loads[0].node",
        "exactly one",
    ),
    ("load-no-target", edit('node = "B"\nfy', "fy"), "loads[0].node", "exactly one"),
    (
        "member-load-no-fraction",
        edit('node = "B"\nfy', 'member = "beam"\nfy'),
        "loads[0].fraction",
        "missing",
    ),
    (
        "fraction-out-of-range",
        edit('node = "B"\nfy', 'member = "beam"\nfraction = 1.5\nfy'),
        "loads[0].fraction",
        "[0, 1]",
    ),
    (
        "load-unknown-member",
        edit('node = "B"\nfy', 'member = "arm"\nfraction = 0.5\nfy'),
        "loads[0].member",
        "unknown member",
    ),
    ("load-nan", edit("fy = -1.0", "fy = nan"), "loads[0].fy", "finite"),
    (
        "follower-not-bool",
        edit("fy = -1.0", 'fy = -1.0\nfollower = "yes"'),
        "loads[0].follower",
        "true or false",
    ),
    ("unknown-analysis", edit('kind = "load"', 'kind = "magic"'), "analysis.kind", "unknown value"),
    ("zero-steps", edit("steps = 10", "steps = 0"), "analysis.steps", ">= 1"),
    ("float-steps", edit("steps = 10", "steps = 2.5"), "analysis.steps", "integer"),
    (
        "stop-output-unknown",
        edit("steps = 10", 'steps = 10\nstop_output = "tip.zz"\nstop_value = 1.0'),
        "analysis.stop_output",
        "not an output",
    ),
    (
        "stop-value-alone",
        edit("steps = 10", "steps = 10\nstop_value = 1.0"),
        "analysis.stop_value",
        "go together",
    ),
    (
        "distance-without-driver",
        edit('kind = "load"', 'kind = "distance"'),
        "analysis.driver",
        "missing",
    ),
    ("no-outputs", edit('[[outputs]]\nname = "tip"\nnode = "B"\n', ""), "outputs", "missing"),
    (
        "output-unknown-node",
        edit('name = "tip"\nnode = "B"', 'name = "tip"\nnode = "X"'),
        "outputs[0].node",
        "unknown node",
    ),
    ("output-bad-name", edit('name = "tip"', 'name = "tip point"'), "outputs[0].name", "letters"),
    (
        "reference-unknown-output",
        GOOD + '\n[[references]]\noutput = "root.uy"\nvalue = 1.0\nkind = "closed-form"\n'
        'source = "x"\nrationale = "y"\ntolerance = 0.1\n',
        "references[0].output",
        "not an output key",
    ),
    (
        "reference-no-rationale",
        GOOD + '\n[[references]]\noutput = "tip.uy"\nvalue = 1.0\nkind = "closed-form"\n'
        'source = "x"\ntolerance = 0.1\n',
        "references[0].rationale",
        "missing",
    ),
    (
        "reference-zero-tolerance",
        GOOD + '\n[[references]]\noutput = "tip.uy"\nvalue = 1.0\nkind = "closed-form"\n'
        'source = "x"\nrationale = "y"\ntolerance = 0.0\n',
        "references[0].tolerance",
        "> 0",
    ),
    (
        "torsion-spring-wrong-node",
        GOOD + '\n[[torsion_springs]]\nid = "t"\nnode = "Z"\nmember_a = "beam"\nstiffness = 1.0\n',
        "torsion_springs[0].node",
        "unknown node",
    ),
    (
        "torsion-spring-negative",
        GOOD + '\n[[torsion_springs]]\nid = "t"\nnode = "A"\nmember_a = "beam"\nstiffness = -1.0\n',
        "torsion_springs[0].stiffness",
        "> 0",
    ),
    (
        "disconnected",
        edit("[[supports]]", '[[nodes]]\nid = "C"\nx = 5.0\ny = 5.0\n\n[[supports]]'),
        "nodes[2]",
        "disconnected",
    ),
    (
        "model-options-nan",
        GOOD + '\n[[models]]\nname = "prb-custom"\n[models.options]\nmatrix = [[nan, 1.0, 0.5]]\n',
        "models[0].options.matrix[0][0]",
        "NaN",
    ),
]


@pytest.mark.parametrize("case_id,text,key,reason", BAD, ids=[b[0] for b in BAD])
def test_bad_case_rejected_with_key(case_id, text, key, reason):
    with pytest.raises(cases.CaseError) as info:
        cases.loads(text, source="bad.toml")
    msg = str(info.value)
    assert msg.startswith("bad.toml: "), msg
    assert f": {key}: " in msg, f"expected key {key!r} in {msg!r}"
    assert reason.lower() in msg.lower(), f"expected {reason!r} in {msg!r}"
    assert "\n" not in msg, "one line"


def test_at_least_30_distinct_mistakes():
    assert len({b[2] + b[3] for b in BAD}) >= 30


def test_missing_file_and_unknown_name():
    with pytest.raises(cases.CaseError, match="no such case file"):
        cases.load("/nonexistent/case.toml")
    with pytest.raises(cases.CaseError, match="not a catalog case"):
        cases.load("no-such-case-anywhere")


def test_scene_is_frozen():
    scene = cases.loads(GOOD)
    with pytest.raises(AttributeError):
        scene.name = "x"  # type: ignore[misc]


def test_ground_torsion_spring_restrains_rotation():
    pinned = edit('type = "clamp"', 'type = "pin"')
    with pytest.raises(cases.CaseError, match="rigid-body"):
        cases.loads(pinned)
    held = pinned + (
        '\n[[torsion_springs]]\nid = "t"\nnode = "A"\nmember_a = "beam"\nstiffness = 5.0\n'
    )
    assert cases.loads(held).torsion_springs[0].member_b is None
