"""The run's ParaView series (reports.run.exports): the FE reference's VTU files carry the
tip displacement and rotation the solver reports, and the PVD time values are the load
factors."""

import re

import meshio
import numpy as np

import cases
from reports.api import solve
from reports.run.exports import DEFAULT_EXPORT, export_outputs


def test_reference_series_carries_displacement_rotation_stress_and_time(tmp_path):
    scene = cases.load("cantilever-tip-load")
    sol = solve(scene, "fem-8")
    task = dict(export=DEFAULT_EXPORT, out_dir=str(tmp_path), model="fem-8", scene=scene)
    exports, warnings = export_outputs(task | {"role": "reference", "case": scene.name}, sol)
    assert warnings == [] and exports["paraview"]["n_vtu"] == len(sol.steps)
    pvd = (tmp_path / exports["paraview"]["pvd"]).read_text()
    files = re.findall(r'file="([^"]+)"', pvd)
    times = [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd)]
    np.testing.assert_array_equal(times, [s.factor for s in sol.steps])
    last = meshio.read(tmp_path / exports["paraview"]["dir"] / files[-1])
    assert {"displacement", "rotation", "bending_moment", "bending_stress"} <= set(last.point_data)
    tip = sol.steps[-1].outputs  # node B is the member's last point
    np.testing.assert_allclose(
        last.point_data["displacement"][-1], [tip["tip.ux"], tip["tip.uy"], 0]
    )
    # the rotation is the centre line's tangent recovered from 9 points: the tip's within
    # 0.5 % of the FE's nodal rotation, the clamp's (zero) within 5 mrad
    rot = last.point_data["rotation"]
    np.testing.assert_allclose(rot[-1], tip["tip.rot"], rtol=0.005)
    assert abs(rot[0]) < 5e-3
