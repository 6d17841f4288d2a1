"""meshio/pyvista export (fem_reference/export.py): round trips and guarded rendering.

* ``write_vtu`` -> ``meshio.read`` returns the points (z = 0), the line cells and the fields;
  the geometric curvature of an equally sampled circle is exactly 1/R;
* ``write_series`` -> the XDMF time series (meshio reader) rebuilds every step's deformed
  points from mesh + ``displacement``; per-step VTUs and the .pvd collection agree; pyvista
  opens all three;
* ``render_png`` writes a real PNG through the matplotlib fallback and, where the child-process
  probe says VTK can render, through pyvista; a probe that crashes selects the fallback.
"""

from __future__ import annotations

import math
import re

import meshio
import numpy as np
import pytest

from fem_reference import export
from fem_reference.export import (
    last_render_backend,
    polyline_curvature,
    pyvista_available,
    render_png,
    write_series,
    write_vtu,
)
from reduced_models.base import Solution, Step

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def arc(phi: float, n: int, L: float = 1.0) -> np.ndarray:
    """(n, 2) points of a cantilever of length L rolled up to end angle phi (phi=0: straight)."""
    s = np.linspace(0.0, L, n)
    if phi == 0.0:
        return np.column_stack([s, np.zeros(n)])
    R = L / phi
    return np.column_stack([R * np.sin(s / R), R * (1.0 - np.cos(s / R))])


def shapes_at(phi: float) -> dict[str, np.ndarray]:
    # a curved member, and a straight member whose end follows the first member's tip
    beam = arc(phi, 11)
    return {"beam": beam, "link": np.vstack([beam[-1], beam[-1] + [0.0, -0.5]])}


def solution(n_steps: int = 4) -> Solution:
    steps = tuple(
        Step(factor=lam, outputs={"tip.x": 0.0}, shapes=shapes_at(lam * math.pi))
        for lam in np.linspace(0.0, 1.0, n_steps)
    )
    return Solution(case="rollup", model="fem-10", status="converged", message="", steps=steps)


# --- VTU ---------------------------------------------------------------------------------------


def test_vtu_round_trip(tmp_path):
    shp = shapes_at(math.pi / 2)
    stress = {"beam": np.linspace(0.0, 5.0, 11)}  # given for one member only
    path = write_vtu(tmp_path / "sub" / "state.vtu", shp, {"bending_stress": stress})
    mesh = meshio.read(path)
    expected = np.vstack(list(shp.values()))
    assert mesh.points.shape == (13, 3)
    np.testing.assert_allclose(mesh.points[:, :2], expected, rtol=0, atol=1e-15)
    assert np.all(mesh.points[:, 2] == 0.0)
    (block,) = mesh.cells
    assert block.type == "line"
    conn = np.vstack([np.column_stack([np.arange(10), np.arange(1, 11)]), [[11, 12]]])
    np.testing.assert_array_equal(block.data, conn)
    np.testing.assert_array_equal(mesh.cell_data["member"][0], [0] * 10 + [1])
    got = mesh.point_data["bending_stress"]
    np.testing.assert_allclose(got[:11], stress["beam"])
    assert np.all(np.isnan(got[11:]))
    # geometric curvature: rolled-up quarter circle of radius 2/pi, straight link
    np.testing.assert_allclose(mesh.point_data["curvature"][:11], math.pi / 2, rtol=1e-12)
    np.testing.assert_allclose(mesh.point_data["curvature"][11:], 0.0)


def test_given_curvature_replaces_geometric(tmp_path):
    shp = shapes_at(1.0)
    kap = {"beam": np.full(11, 7.0), "link": np.zeros(2)}
    mesh = meshio.read(write_vtu(tmp_path / "k.vtu", shp, {"curvature": kap}))
    np.testing.assert_allclose(mesh.point_data["curvature"][:11], 7.0)


def test_polyline_curvature_sign_and_wrap():
    # clockwise circle: negative curvature; a 3/4 turn crosses the +-pi branch cut
    pts = arc(1.5 * math.pi, 41)
    np.testing.assert_allclose(polyline_curvature(pts), 1.5 * math.pi, rtol=1e-12)
    flipped = pts * [1.0, -1.0]
    np.testing.assert_allclose(polyline_curvature(flipped), -1.5 * math.pi, rtol=1e-12)
    assert np.all(polyline_curvature(pts[:2]) == 0.0)


def test_vtu_bad_input(tmp_path):
    with pytest.raises(ValueError, match="no shapes"):
        write_vtu(tmp_path / "a.vtu", {})
    with pytest.raises(ValueError, match="must be"):
        write_vtu(tmp_path / "a.vtu", {"m": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="3 values"):
        write_vtu(tmp_path / "a.vtu", {"m": np.zeros((4, 2))}, {"f": {"m": np.zeros(3)}})


# --- time series ---------------------------------------------------------------------------------


def test_series_round_trip(tmp_path):
    sol = solution(4)
    fields = [{"axial_force": {"beam": np.full(11, float(k))}} for k in range(4)]
    xdmf = write_series(tmp_path / "out", sol, fields)
    assert xdmf.suffix == ".xdmf" and xdmf.exists()
    ref = np.vstack(list(sol.steps[0].shapes.values()))
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == 4
        np.testing.assert_allclose(points[:, :2], ref, atol=1e-15)
        assert cells[0].type == "line" and len(cells[0].data) == 11
        for k in range(reader.num_steps):
            t, pdata, cdata = reader.read_data(k)
            assert t == sol.steps[k].factor  # the load factor rises: it is the time value
            deformed = points + pdata["displacement"]
            np.testing.assert_allclose(
                deformed[:, :2], np.vstack(list(sol.steps[k].shapes.values())), atol=1e-14
            )
            np.testing.assert_allclose(pdata["load_factor"], sol.steps[k].factor)
            np.testing.assert_allclose(pdata["axial_force"][:11], k)
            assert np.all(np.isnan(pdata["axial_force"][11:]))
            np.testing.assert_array_equal(cdata["member"][0], [0] * 10 + [1])
    # per-step VTU files hold the deformed points; the .pvd lists them in order
    pvd = xdmf.with_suffix(".pvd").read_text()
    files = re.findall(r'file="([^"]+)"', pvd)
    assert len(files) == 4
    last = meshio.read(xdmf.parent / files[-1])
    np.testing.assert_allclose(last.points[:, :2], np.vstack(list(sol.steps[-1].shapes.values())))


def test_series_fields_of_a_rolled_up_cantilever(tmp_path):
    """A cantilever rolled into an arc of end angle phi: rotation s/R along it, bending
    moment E I phi / L and stress E t phi / (2 L) everywhere, tip displacement from the
    circle; the PVD time values are the load factors."""
    E, t, L, n = 2.0e5, 0.5, 1.0, 4
    sections = {"beam": (E * 1.5, E * t / 2.0)}  # E I with I = 1.5; no section for "link"
    sol = solution(n)
    write_series(tmp_path, sol, sections=sections)
    files = sorted(tmp_path.glob("*.vtu"))
    assert len(files) == n
    for k, f in enumerate(files):
        phi, m = np.linspace(0.0, 1.0, n)[k] * math.pi, meshio.read(f)
        beam = slice(0, 11)
        u = m.point_data["displacement"]
        assert u.shape == (13, 3) and np.all(u[:, 2] == 0.0)
        np.testing.assert_allclose(u[beam, :2], arc(phi, 11) - arc(0.0, 11), atol=1e-12)
        s = np.linspace(0.0, L, 11)
        np.testing.assert_allclose(m.point_data["rotation"][beam], phi * s / L, atol=1e-12)
        np.testing.assert_allclose(m.point_data["bending_moment"][beam], E * 1.5 * phi / L)
        np.testing.assert_allclose(m.point_data["bending_stress"][beam], E * t * phi / (2 * L))
        assert np.all(np.isnan(m.point_data["bending_stress"][11:]))  # the link: no section
        np.testing.assert_allclose(m.point_data["load_factor"], sol.steps[k].factor)
    pvd = (tmp_path / "rollup_fem-10.pvd").read_text()
    steps = [float(v) for v in re.findall(r'timestep="([^"]+)"', pvd)]
    np.testing.assert_allclose(steps, np.linspace(0.0, 1.0, n), atol=0)


def test_series_times():
    def steps(factors, t=None):
        info = [{} if t is None else {"t": v} for v in t or factors]
        return [Step(factor=f, outputs={}, info=i) for f, i in zip(factors, info)]

    np.testing.assert_array_equal(export.series_times(steps([0.0, 0.5, 1.0])), [0.0, 0.5, 1.0])
    # a path through a limit point: the factor falls, so the step index orders the frames
    np.testing.assert_array_equal(export.series_times(steps([0.0, 1.0, 0.8])), [0, 1, 2])
    replay = steps([0.0, 1.0, 1.0], t=[0.0, 0.2, 0.7])  # replay frames carry their time
    np.testing.assert_array_equal(export.series_times(replay), [0.0, 0.2, 0.7])


def test_series_resamples_changing_point_counts(tmp_path):
    steps = (
        Step(factor=0.0, outputs={}, shapes={"beam": arc(0.0, 5)}),
        Step(factor=1.0, outputs={}, shapes={"beam": arc(0.0, 9)}),  # same line, 9 points
    )
    sol = Solution(case="c", model="m", status="converged", message="", steps=steps)
    xdmf = write_series(tmp_path, sol)
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, _ = reader.read_points_cells()
        _, pdata, _ = reader.read_data(1)
    assert len(points) == 5
    np.testing.assert_allclose(pdata["displacement"], 0.0, atol=1e-15)


def test_series_bad_input(tmp_path):
    empty = Solution(case="c", model="m", status="failed", message="x", steps=())
    with pytest.raises(ValueError, match="no shapes"):
        write_series(tmp_path, empty)
    with pytest.raises(ValueError, match="fields has 1 entries"):
        write_series(tmp_path, solution(3), [None])


def test_pyvista_opens_the_files(tmp_path):
    pv = pytest.importorskip("pyvista")
    xdmf = write_series(tmp_path, solution(3))
    vtu = pv.read(sorted(tmp_path.glob("*.vtu"))[-1])
    assert vtu.n_points == 13 and vtu.n_cells == 11
    assert "curvature" in vtu.point_data
    pvd = pv.get_reader(str(xdmf.with_suffix(".pvd")))
    assert list(pvd.time_values) == [0.0, 0.5, 1.0]  # the load factors
    series = pv.get_reader(str(xdmf)).read()
    assert series.n_blocks >= 1


# --- rendering -----------------------------------------------------------------------------------


def _is_png(path) -> bool:
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == PNG_MAGIC


def test_render_matplotlib_fallback(tmp_path):
    path = render_png(
        tmp_path / "mpl.png", shapes_at(math.pi), shapes_at(0.0), "roll-up", backend="matplotlib"
    )
    assert _is_png(path) and last_render_backend() == "matplotlib"


def test_render_pyvista(tmp_path):
    if not pyvista_available():
        pytest.skip("pyvista cannot render off-screen here (no EGL/OSMesa): fallback only")
    path = render_png(
        tmp_path / "pv.png", shapes_at(math.pi), shapes_at(0.0), "roll-up", backend="pyvista"
    )
    assert _is_png(path) and last_render_backend() == "pyvista"


def test_render_auto_gives_a_png(tmp_path):
    path = render_png(tmp_path / "auto.png", shapes_at(1.0))
    assert _is_png(path)
    assert last_render_backend() == ("pyvista" if pyvista_available() else "matplotlib")


def test_crashing_probe_selects_fallback(tmp_path, monkeypatch):
    # a probe that dies like a VTK segfault (abort) must not take the caller down
    monkeypatch.setattr(export, "_PROBE", "import os; os.abort()")
    monkeypatch.setattr(export, "_verdict", None)
    monkeypatch.setenv(export._ENV_KEY, "")  # recorded, so restored after the test
    assert pyvista_available() is False
    path = render_png(tmp_path / "fb.png", shapes_at(1.0))
    assert _is_png(path) and last_render_backend() == "matplotlib"
    with pytest.raises(RuntimeError, match="cannot render"):
        render_png(tmp_path / "x.png", shapes_at(1.0), backend="pyvista")


def test_env_forces_matplotlib(tmp_path, monkeypatch):
    monkeypatch.setenv("FLEXBENCH_RENDER", "matplotlib")
    assert pyvista_available() is False
    render_png(tmp_path / "e.png", shapes_at(1.0))
    assert last_render_backend() == "matplotlib"


def test_render_bad_input(tmp_path):
    with pytest.raises(ValueError):
        render_png(tmp_path / "a.png", {})
    with pytest.raises(ValueError):
        render_png(tmp_path / "a.png", shapes_at(1.0), backend="opengl")
