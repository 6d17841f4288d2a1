"""A mechanism's arc-length path is sampled the same way however the scene is drawn.

The shallow arch (catalog ``shallow-arch-snap``) on 64 chained segments per member: the
scaled residual's round-off floor is ~1e-10, the corrector's tolerance.  Drawn in thousandths
of its units (lengths x 0.01, forces x 1000, as the outside review writes it), one corrector
wandered at that floor for 30 iterations and failed, the step was halved, and the path was
sampled at one more point (32 states against 31; the outside review's flag on cbcm-auto).
At the floor the corrector now stops (``newton.FLOOR_RES``) and the next step's length is
decided above it (``EASY_RES``): the same states, transformed back, to 1e-8.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import cases
import reports

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.mark.parametrize("model", ["cbcm-64"])
def test_shallow_arch_path_is_sampled_the_same_in_other_units(model):
    drawn = reports.solve("shallow-arch-snap", model)
    scaled = reports.solve(
        cases.load(str(FIXTURES / "shallow-arch-snap--units-nondim_L0.01_F1000.toml")), model
    )
    assert drawn.status == scaled.status == "converged", scaled.message
    assert len(scaled.steps) == len(drawn.steps)
    for a, b in zip(drawn.steps, scaled.steps):
        assert b.factor == pytest.approx(a.factor, rel=1e-8, abs=1e-10)
        uy = a.outputs["apex.uy"]
        assert b.outputs["apex.uy"] / 0.01 == pytest.approx(uy, rel=1e-8, abs=1e-10)


@pytest.mark.parametrize("model", ["cbcm-64"])
def test_a_turned_drawing_starts_from_its_unloaded_state(model):
    """The same arch traced to a rotation of its pinned end, drawn upright and turned 37 deg:
    turned, the Newton solve of the unloaded drawn state stalled at its round-off floor
    (4e-10, the tolerance 1e-10) for 30 iterations and the model failed before its first
    step.  Stalled at the floor it is converged (``newton.FLOOR_RES``): both drawings give
    the same path."""
    upright = reports.solve(cases.load(str(FIXTURES / "shallow-arch-rotstop.toml")), model)
    turned = reports.solve(cases.load(str(FIXTURES / "shallow-arch-rotstop--rot37.toml")), model)
    assert upright.status == turned.status == "converged", turned.message
    assert len(upright.steps) == len(turned.steps)
    for a, b in zip(upright.steps, turned.steps):
        assert b.factor == pytest.approx(a.factor, rel=1e-8, abs=1e-10)
        assert b.outputs["pl.rot"] == pytest.approx(a.outputs["pl.rot"], abs=1e-9)
