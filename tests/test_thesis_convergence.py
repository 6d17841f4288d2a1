"""Increment-factor convergence of the thesis method against the exact equilibrium."""

from __future__ import annotations

import numpy as np

import cases
from reports.verdicts.thesis_study import increment_convergence


def test_orders_and_error_at_thesis_setting():
    scene = cases.load("thesis-sixbar-config4")
    st = increment_convergence(scene, (0.02, 0.01, 0.005))
    # the relaxation's own drift converges at second order, the last increment at first
    assert np.all(np.abs(np.array(st["order_drift"]) - 2.0) < 0.2), st["order_drift"]
    assert np.all(np.abs(np.array(st["order_last_increment"]) - 1.0) < 0.1)
    # the error is the boom's overshoot past 0.3 m, bounded by the last increment
    err, over, last = (np.array(st[k]) for k in ("error_m", "overshoot_m", "last_increment_m"))
    np.testing.assert_allclose(err, over, rtol=1e-3)
    assert np.all(over <= last)
    assert abs(err[-1] - 9.616e-5) < 1e-7  # 0.096 mm at gamma = 0.005
