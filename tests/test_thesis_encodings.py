"""One six-bar, four encodings, one answer (issue 25, deliverable 6).

Configuration 4 written as the catalog writes it; with every pin written as one member welded
and the other pinned at the joint (still a pin: only two welded ends make a rigid joint);
with every member reversed and listed in reverse order (the ground springs' rest angles, angles
of member directions, turned by 180 deg with them); and with its nodes renamed and
listed in another order, in millimetres.  Every model that takes booms must give the same
joint positions (and the thesis's force method the same load totals, Table 4-8's).
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

import cases
from reports import api

MODELS = ("kinetostatic", "thesis-force-method", "fem-auto", "replay")
RENAME = {f"J{i}": f"P{8 - i}" for i in range(1, 8)} | {"C": "Q"}


def to_toml(data: dict) -> str:
    """The case dict as TOML text (tables and arrays of tables of scalars)."""
    lines = []
    for key, val in data.items():
        for table in val if isinstance(val, list) else [val]:
            lines.append(f"[[{key}]]" if isinstance(val, list) else f"[{key}]")
            lines += [f"{k} = {json.dumps(v)}" for k, v in table.items() if k != "grid"]
    return "\n".join(lines) + "\n"


def encodings() -> dict[str, tuple[dict, float]]:
    """name -> (case dict, metres per length unit)."""
    path = cases.resolve("thesis-sixbar-config4")
    base = tomllib.loads(path.read_text())
    out = {"as catalogued": (base, 1.0)}
    welded = json.loads(json.dumps(base))
    for m in welded["members"]:
        m["end_b"] = "weld"  # J2, J3, J5, J6: weld + pin; J4 stays weld + weld
    out["weld + pin"] = (welded, 1.0)
    rev = json.loads(json.dumps(base))
    for m in rev["members"]:
        m["from"], m["to"], m["end_a"], m["end_b"] = m["to"], m["from"], m["end_b"], m["end_a"]
    rev["members"].reverse()
    for t in rev["torsion_springs"]:  # rest angles are between member directions: a ground
        if "member_b" not in t:  # spring's turns by 180 deg with its reversed member
            t["rest_angle_deg"] += 180.0
    out["reversed"] = (rev, 1.0)
    mm = json.loads(json.dumps(base))
    mm["case"]["units"] = "mm-N-MPa"
    mm["nodes"] = [
        {"id": RENAME[n["id"]], "x": 1e3 * n["x"], "y": 1e3 * n["y"]} for n in mm["nodes"][::-1]
    ]
    for m in mm["members"]:
        m["from"], m["to"] = RENAME[m["from"]], RENAME[m["to"]]
        m.update(E=m["E"] / 1e6, A=m["A"] * 1e6, I=m["I"] * 1e12)
    for t in mm["supports"] + mm["torsion_springs"] + mm["outputs"]:
        t["node"] = RENAME[t["node"]]
    for t in mm["torsion_springs"]:
        t["stiffness"] *= 1e3  # N mm / rad
    for b in mm["booms"]:
        b.update({"from": RENAME[b["from"]], "to": RENAME[b["to"]], "length": 1e3 * b["length"]})
    out["renamed, reordered, mm"] = (mm, 1e-3)
    return out


def positions(sol: object, scale: float) -> np.ndarray:
    """Final joint positions J2..J6 (m), in output order (output names are kept)."""
    assert sol.status == "converged", sol.message
    last = sol.steps[-1].outputs
    return scale * np.array([last[f"J{i}.{c}"] for i in range(2, 7) for c in "xy"])


@pytest.fixture(scope="module")
def solved() -> dict:
    out = {}
    for name, (data, scale) in encodings().items():
        scene = cases.loads(to_toml(data), source=name)
        out[name] = {m: (api.solve(scene, m), scale) for m in MODELS}
    return out


@pytest.mark.parametrize("model", MODELS)
def test_same_answer_in_every_encoding(solved, model):
    ref = positions(*solved["as catalogued"][model])
    for name in solved:
        got = positions(*solved[name][model])
        np.testing.assert_allclose(got, ref, rtol=0, atol=5e-7, err_msg=name)  # 0.0005 mm


def test_force_method_load_totals_in_every_encoding(solved):
    ref = np.array(solved["as catalogued"]["thesis-force-method"][0].extras["part1_load_total"])
    assert ref[5] == pytest.approx(-235.439776978666, rel=1e-11)  # Table 4-8, F4y
    for name in solved:
        got = np.array(solved[name]["thesis-force-method"][0].extras["part1_load_total"])
        np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-9, err_msg=name)
