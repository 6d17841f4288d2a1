"""Full export (ParaView series, replay frames, animations) on every catalog mechanism, and
the driver figure's axis units (issue 21: Ex. 4's replay animation and ParaView export
crashed with an IndexError; the driver plot labelled degrees as rad and torque as [-]).

Each case is shortened to two steps: the export, not the answer, is under test.  The pairs
that export: a reference FE (fem-4 standing in for fem-auto, same shapes), the replay (four
elements, eight frames, no probes), and the solver of a kinematics analysis.
"""

from __future__ import annotations

import dataclasses

import pytest

import cases
from fem_reference.replay.model import Replay
from reports.api import solve
from reports.render.mechfig import _driver_panels
from reports.render.paths import driver_xlabel
from reports.run.exports import DEFAULT_EXPORT, export_outputs

MECHANISMS = [n for n in cases.catalog_names() if "mechanism" in cases.load(n).tags]


def _short(scene: cases.Scene) -> cases.Scene:
    a = scene.analysis
    a = dataclasses.replace(a, steps=min(a.steps, 2), max_steps=min(a.max_steps, 8))
    return dataclasses.replace(scene, analysis=a)


@pytest.mark.parametrize("name", MECHANISMS)
def test_full_export_never_fails(tmp_path, name: str) -> None:
    scene = _short(cases.load(name))
    pairs = [("fem-4", "reference"), ("replay", "reference")]
    if scene.analysis.kind == "kinematics":
        pairs.append(("kinetostatic", "model"))
    for model, role in pairs:
        m = Replay(n_elements=4, frames=8, probe="none") if model == "replay" else model
        sol = solve(scene, m)
        if sol.status != "converged":
            assert sol.status == "not-applicable", (model, sol.message)
            continue
        task = {"export": DEFAULT_EXPORT, "out_dir": str(tmp_path), "model": model}
        task.update(role=role, scene=scene, case=name)
        exports, warnings = export_outputs(task, sol)
        assert not warnings, (model, warnings)
        assert (tmp_path / exports["paraview"]["pvd"]).is_file()
        if model == "replay":
            assert exports["paraview_frames"]["n_vtu"] > 0
        if model == "replay" or scene.analysis.kind == "kinematics":
            assert (tmp_path / exports["animation"]).stat().st_size > 0


def test_driver_figure_labels_carry_the_driver_units() -> None:
    meta = {
        "units": "mm-N-MPa",
        "analysis": {"kind": "energy", "driver": {"kind": "rotation", "member": "crank"}},
    }
    assert driver_xlabel(meta).endswith("[deg]")  # Step.factor of a rotation: degrees
    recs = [{"model": "m", "steps": [{"outputs": {"driver.torque": 1.0}, "energy": 0.0}]}]
    assert ("driver.torque", "driver.torque [N·mm]") in _driver_panels(meta, recs)
    meta["analysis"]["driver"] = {"kind": "displacement", "node": "S", "direction": "x"}
    assert driver_xlabel(meta).endswith("[mm]")
    recs[0]["steps"][0]["outputs"] = {"driver.force": 1.0}
    assert ("driver.force", "driver.force [N]") in _driver_panels(meta, recs)
