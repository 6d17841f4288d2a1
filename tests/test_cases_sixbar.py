"""Scene format of issue 10: booms, deploy, rest_angle_deg, sweep grids (good and bad files)."""

from __future__ import annotations

import pytest

import cases
from cases.sweep import expand, points

BASE = (cases.CATALOG / "thesis-sixbar-config4.toml").read_text()
F = "<string>"


def edit(old: str, new: str, text: str = BASE) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


GRID = edit(
    'kind = "deploy"\nsteps = 20\n',
    'kind = "sweep"\nsweep_of = "deploy"\nsteps = 4\n\n'
    '[[analysis.grid]]\nkeys = ["torsion_springs.S1.stiffness", "torsion_springs.S7.stiffness"]\n'
    "values = [40.0, 50.0]\n\n"
    '[[analysis.grid]]\nkey = "torsion_springs.S2.rest_angle_deg"\n'
    "values = [110.0, 120.0, 130.0]\n",
)


def test_rest_angle_becomes_free_angle():
    scene = cases.load("thesis-sixbar-config4")
    s1, s2, s7 = (scene.torsion_springs[i] for i in (0, 1, 5))
    # drawn: bar I at 5.7392 deg, bar II at 174.2608 deg, bar VI at -5.7392 deg
    assert s1.rest_angle_deg == 30.0 and s1.free_angle_deg == pytest.approx(30 - 5.7392)
    assert s2.free_angle_deg == pytest.approx(120 - (180 - 2 * 5.7392))
    assert s7.free_angle_deg == pytest.approx(-30 + 5.7392)
    assert scene.booms[0].force == 100.0 and scene.booms[0].length == 0.3
    assert "boom.length" in scene.output_keys()


def test_grid_expands_cartesian():
    scene = cases.loads(GRID)
    pts = points(scene)
    assert len(pts) == 6 and pts[0] == (
        ("torsion_springs.S1.stiffness", 40.0),
        ("torsion_springs.S7.stiffness", 40.0),
        ("torsion_springs.S2.rest_angle_deg", 110.0),
    )
    scenes = expand(scene)
    last = scenes[-1]
    assert last.analysis.kind == "deploy" and last.sweep_parent == scene.name
    assert last.name == f"{scene.name}/p005"
    sp = {t.id: t for t in last.torsion_springs}
    assert sp["S1"].stiffness == sp["S7"].stiffness == 50.0
    assert sp["S2"].rest_angle_deg == 130.0
    assert sp["S2"].free_angle_deg == pytest.approx(130 - (180 - 2 * 5.7392))


def test_one_axis_sweep_key_still_reads():
    text = edit(
        'kind = "deploy"\nsteps = 20\n',
        'kind = "sweep"\nsweep_of = "deploy"\nsweep_key = "booms.boom.force"\n'
        "sweep_values = [80.0, 100.0]\n",
    )
    assert [p[0][1] for p in points(cases.loads(text))] == [80.0, 100.0]


@pytest.mark.parametrize(
    "text, key",
    [
        (edit("force = 100.0", "force = -1.0"), "booms[0].force"),
        (edit('from = "C"\nto = "J4"', 'from = "J3"\nto = "J4"'), "booms[0].from"),
        (edit('to = "J4"\nforce', 'to = "Q"\nforce'), "booms[0].to"),
        (edit("length = 0.3", "length = 0.05"), "booms[0].length"),
        (edit("length = 0.3\n", ""), "booms[0].length"),
        (edit("length = 0.3\n", "length = 0.3\nspeed = 1.0\n"), "booms[0].speed"),
        (
            edit("rest_angle_deg = 30.0", "rest_angle_deg = 30.0\nfree_angle_deg = 1.0"),
            "torsion_springs[0].rest_angle_deg",
        ),
        (
            edit("rest_angle_deg = 30.0", 'rest_angle_deg = "x"'),
            "torsion_springs[0].rest_angle_deg",
        ),
        (edit('kind = "deploy"', 'kind = "sweep"'), "analysis.grid"),
        (edit("S1.stiffness", "S9.stiffness", GRID), "analysis.grid[0].keys"),
        (edit("S1.stiffness", "S1.colour", GRID), "analysis.grid[0].keys"),
        (edit("values = [40.0, 50.0]", "values = []", GRID), "analysis.grid[0].values"),
        (edit("values = [40.0, 50.0]", "values = [-40.0, 50.0]", GRID), "analysis.grid[0].values"),
        (
            edit(
                'key = "torsion_springs.S2.rest_angle_deg"\nvalues = [110.0, 120.0, 130.0]',
                'key = "booms.boom.length"\nvalues = [0.05, 0.3]',
                GRID,
            ),
            "analysis.grid[1].values",
        ),
        (edit('sweep_of = "deploy"', 'sweep_of = "path"', GRID), "analysis.sweep_of"),
        (
            edit(
                'keys = ["torsion_springs.S1.stiffness", "torsion_springs.S7.stiffness"]',
                'key = "a"\nkeys = ["b"]',
                GRID,
            ),
            "analysis.grid[0].key",
        ),
    ],
)
def test_bad_files_name_the_key(text: str, key: str):
    with pytest.raises(cases.CaseError) as err:
        cases.loads(text, source=F)
    msg = str(err.value)
    assert msg.startswith(f"{F}: {key}:"), msg
    assert "\n" not in msg


def test_deploy_needs_a_boom():
    text = BASE.split("[[booms]]")[0] + "[analysis]" + BASE.split("[analysis]")[1]
    with pytest.raises(cases.CaseError, match=r"<string>: booms: missing"):
        cases.loads(text)
