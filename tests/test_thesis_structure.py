"""The deployed six-bar as a structure (seed 001, Eqs. 2-11, 2-12, 2-46 to 2-48).

Counts against Gruebler's count on the same graph (the thesis's Eq. 2-11 is meant to give it
without the formula): Configuration 4 before the lock has five moving joints (10 rows) and
six bars, the ternary link's moment and no boom column (7): 3 mechanisms; locked, 8
columns: 2.  Configuration 6 (five-link chain, two locked booms): 8 rows, 7 columns: 1.  No
state of self-stress in either.  Stiffness: Configuration 4 deploys with the boom vertical
under J4, so to first order J4 can only move across the boom: its compliance along the boom
is that of the rigid boom (zero) and its softest direction is horizontal.
"""

from __future__ import annotations

import pytest

import cases
from reports import api


@pytest.mark.parametrize(
    ("case", "start", "deployed"),
    [("thesis-sixbar-config4", 3, 2), ("thesis-sixbar-config3", 3, 2),
     ("thesis-sixbar-config6", 3, 1)],
)  # fmt: skip
def test_mechanism_and_self_stress_counts(case, start, deployed):
    s = api.solve(cases.load(case), "thesis-force-method").extras["structure"]
    assert s["start"] == {"mechanisms": start, "self_stress": 0}
    assert s["deployed"] == {"mechanisms": deployed, "self_stress": 0}


def test_joint_stiffness_config4_across_the_boom():
    s = api.solve(cases.load("thesis-sixbar-config4"), "thesis-force-method").extras["structure"]
    assert s["joint"] == "J4"
    C = s["joint_compliance"]
    assert abs(C[1][1]) < 1e-12 * C[0][0]  # along the locked boom: rigid
    assert abs(s["joint_soft_direction"][0]) == pytest.approx(1.0, abs=1e-9)
    assert s["joint_soft_stiffness"] == pytest.approx(1.0 / C[0][0])
    assert s["lowest_eigenvalue"] > 0
