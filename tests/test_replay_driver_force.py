"""The replay's driving force is a property of the scene, not of its encoding (issue 23, item 5).

DAS-2D Ex. 5 (catalog ``das2d-ex5-constant-force``): a slider-crank whose rigid links the
replay models as stiff elements (``EA_r`` ~ 1e8 N).  Rotating the scene by 90 deg or writing
it in metres is exact in the mechanics, so the driving force along the slider must come out
the same; it may differ only by the round-off of the force itself (~1e-15 of 13 N).  Read as
the driver-DOF residual alone it carried the stiff links' round-off, eps EA_r ~ 1e-8 N, 2e-8
of the force's excursion over the stroke; condensed onto the driver DOF
(``DrivenSystem.reaction``) it agrees to ~1e-14.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import cases
import reports
from tests.hostile_review_lib import back_rigid, back_units, rigid_motion, scale_units, to_toml

CASE = Path(__file__).resolve().parents[1] / "cases" / "catalog" / "das2d-ex5-constant-force.toml"
TOL = 1e-10  # of the driving force's excursion over the stroke (0.43 N)


def _drawn() -> dict:
    d = tomllib.loads(CASE.read_text())
    for k in ("references", "tolerances"):
        d.pop(k, None)
    d["case"].pop("reference_model", None)
    return d


def _forces(scene: dict, back) -> np.ndarray:
    """driver.force along the stroke of ``scene``'s replay, brought back to the drawn frame."""
    sol = reports.solve(cases.loads(to_toml(scene)), "replay")
    assert sol.status == "converged", sol.message
    return np.array([back(dict(s.outputs), s.factor)[0]["driver.force"] for s in sol.steps])


@pytest.fixture(scope="module")
def drawn() -> tuple[dict, np.ndarray]:
    d = _drawn()
    return d, _forces(d, lambda o, f: (o, f))


@pytest.mark.parametrize("encoding", ["rot90", "units m-N-Pa"])
def test_ex5_driver_force_same_in_every_encoding(drawn, encoding):
    d, f0 = drawn
    if encoding == "rot90":
        enc = rigid_motion(d, 90.0, False)
        back = lambda o, f: back_rigid(o, f, d, 90.0, False, (0.0, 0.0))  # noqa: E731
    else:
        enc = scale_units(d, 1e-3, 1.0, "m-N-Pa")
        back = lambda o, f: back_units(o, f, d, 1e-3, 1.0)  # noqa: E731
    f1 = _forces(enc, back)
    excursion = np.ptp(f0)
    assert excursion > 0.4  # 12.78 N to 13.20 N over the stroke (closed form, case file)
    assert np.max(np.abs(f1 - f0)) / excursion < TOL
