"""The notebook API: Solution.to_frame / plot_path / plot_shapes / _repr_html_ and
reports.load_run, checked against the closed-form cantilever (linear Euler-Bernoulli beam
under a tip load P: tip deflection P L^3 / (3 EI), tip rotation P L^2 / (2 EI))."""

import dataclasses

import matplotlib
import numpy as np
import pytest

import cases
import reports

matplotlib.use("Agg")

P, L, EI = 10.0, 1.0, 1.0  # cases/catalog/cantilever-tip-load.toml: fy = -10, L = 1, E I = 1


@pytest.fixture(scope="module")
def sol():
    scene = cases.load("cantilever-tip-load")
    assert (scene.loads[0].fy, scene.member("beam").EI) == (-P, EI)
    return reports.solve(dataclasses.replace(scene, units="m-N-Pa"), "linear-1")


def test_frame_one_row_per_step_with_closed_form_values(sol):
    df = sol.to_frame()
    assert len(df) == len(sol.steps) == 21
    assert list(df.columns[:2]) == ["step", "factor"]
    f = df["factor"].to_numpy()
    np.testing.assert_allclose(f, np.linspace(0.0, 1.0, 21), atol=1e-12)
    np.testing.assert_allclose(df["tip.uy"], -f * P * L**3 / (3 * EI), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(df["tip.rot"], -f * P * L**2 / (2 * EI), rtol=1e-9, atol=1e-12)
    # strain energy of the linear cantilever: P^2 L^3 / (6 EI) at factor f squared
    np.testing.assert_allclose(df["energy"], (f * P) ** 2 * L**3 / (6 * EI), rtol=1e-9)
    units = df.attrs["units"]
    assert (units["tip.uy"], units["tip.rot"], units["energy"], units["factor"]) == (
        "m",
        "rad",
        "N m",
        "-",
    )
    assert df.attrs["model"] == "linear-1" and df.attrs["status"] == "converged"


def test_unit_names_of_every_output_kind():
    from reduced_models.notebook import unit_table

    keys = ["tip.x", "tip.rot", "boom.length", "driver.torque", "input.force", "gain.ma"]
    got = unit_table(keys, "mm-N-MPa")
    assert [got[k] for k in keys] == ["mm", "rad", "mm", "N mm", "N", "-"]
    assert unit_table(["tip.uy"], None)["tip.uy"] == "length"  # unit system unknown


def test_frame_units_follow_the_case_and_an_override(sol):
    assert sol.to_frame(units="mm-N-MPa").attrs["units"]["tip.ux"] == "mm"
    assert sol.to_frame(units="mm-N-MPa").attrs["units"]["max_stress"] == "MPa"
    nondim = reports.solve("cantilever-tip-load", "linear-1").to_frame()
    assert nondim.attrs["unit_system"] == "nondim"


def test_plot_path_draws_load_against_deflection(sol):
    ax = sol.plot_path()
    x, y = ax.lines[0].get_xydata().T
    np.testing.assert_allclose(y, np.linspace(0.0, 1.0, 21), atol=1e-12)
    np.testing.assert_allclose(x, -y * P * L**3 / (3 * EI), rtol=1e-9, atol=1e-12)
    assert ax.get_xlabel() == "tip.uy (m)" and ax.get_ylabel() == "factor"
    assert sol.plot_path("tip.rot", "factor", ax=ax) is ax  # drawn on the caller's axes
    with pytest.raises(KeyError, match="no output 'tip.nope'"):
        sol.plot_path("tip.nope")


def test_plot_shapes_ends_at_the_tip(sol):
    ax = sol.plot_shapes()
    tip = ax.lines[-1].get_xydata()[-1]
    np.testing.assert_allclose(tip, [L, -P * L**3 / (3 * EI)], rtol=1e-9, atol=1e-12)
    assert ax.get_xlabel() == "x (m)" and len(ax.lines) == 5
    assert len(sol.plot_shapes(steps=[0, 20]).lines) == 2
    with pytest.raises(ValueError, match="no shapes"):
        dataclasses.replace(sol, steps=()).plot_shapes()


def test_repr_html_summarises(sol):
    text = sol._repr_html_()
    for part in ("linear-1", "cantilever-tip-load", "converged", "21", "tip.uy (m)"):
        assert part in text
    assert f"{-P * L**3 / (3 * EI):.6g}" in text
    assert "warning" in text  # the validity atlas's warning at PL^2/EI = 10 is shown
    failed = dataclasses.replace(sol, status="failed", message="a <b> reason", steps=())
    assert "a &lt;b&gt; reason" in failed._repr_html_()
