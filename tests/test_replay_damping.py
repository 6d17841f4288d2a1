"""The replay's damping is what its card states (issue 23, item 6): mass-proportional,
``a0 = 2 zeta omega_1``, so the lowest mode decays at the damping ratio ``zeta``.

A cantilever under a suddenly applied small tip load (linear range, ramp of 0.01 T1) rings
in its lowest mode about the settled state: ``exp(-zeta omega_1 t) cos(omega_d t + phi)``,
a logarithmic decrement per period of ``2 pi zeta / sqrt(1 - zeta^2)``.  The decay is fitted
to every sample of the free ringing (peaks alone fall between the adaptive time steps); the
integrator runs at ``rho_inf = 0.8``, whose numerical dissipation at the lowest mode is
negligible at the replay's step (T1 / 40) and which still damps the mesh's highest modes.
"""

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import curve_fit

import cases
import reports


def ringing(zeta: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(times, tip.uy about its settled value, omega_1) of the free ringing."""
    scene = cases.load("cantilever-tip-load")
    a = dataclasses.replace(scene.analysis, steps=1, factor_end=0.01)  # PL^2/EI = 0.1
    opts = {"zeta": zeta, "ramp_periods": 0.01, "probe": "none", "rho_inf": 0.8, "n_elements": 8}
    sol = reports.solve(dataclasses.replace(scene, analysis=a), "replay", options=opts)
    assert sol.status == "converged", sol.message
    h, w1 = sol.extras["history"], sol.extras["settle"]["omega1"]
    t, u = np.asarray(h["t"]), np.asarray(h["tip.uy"])
    d = u - u[-1]
    free = (t > math.pi / w1) & (np.abs(d) > 1e-4 * np.abs(d).max())  # past the step
    return t[free], d[free], w1


@pytest.mark.parametrize("zeta", [0.05, 0.1])
def test_lowest_mode_decays_at_the_stated_damping_ratio(zeta):
    t, d, w1 = ringing(zeta)
    assert t.size >= 100, "too little ringing to measure a decrement"

    def mode(t, amp, z, wd, phase):
        return amp * np.exp(-z * w1 * t) * np.cos(wd * t + phase)

    (_, measured, wd, _), _ = curve_fit(mode, t, d, p0=[d[0], zeta, w1, 0.0])
    assert wd == pytest.approx(w1 * math.sqrt(1 - zeta**2), rel=0.02)  # the lowest mode
    decrement = 2 * math.pi * measured / math.sqrt(1 - measured**2)
    assert decrement == pytest.approx(2 * math.pi * zeta / math.sqrt(1 - zeta**2), rel=0.03)
