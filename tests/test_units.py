"""The fourth unit system, in-lbf-psi (DAS-2D's seed uses four), and the conversion of a
scene between consistent systems (``cases/units.py``): a converted case solves to the same
answer, and meets its closed-form references converted by the NIST factors."""

from __future__ import annotations

import numpy as np
import pytest

import cases
from cases.units import convert, factors
from fem_reference.beam_mesh import DEFAULT_DENSITY
from reports.api import solve
from reports.run.tables import unit_names

INCH, LBF = 0.0254, 4.4482216152605  # NIST SP 811, exact


def test_in_lbf_psi_is_a_declared_system_with_its_unit_names() -> None:
    base = cases.load("das2d-ex2-parallelogram")
    assert convert(base, "in-lbf-psi").units == "in-lbf-psi"
    assert unit_names("in-lbf-psi") == {
        "length": "in",
        "force": "lbf",
        "energy": "lbf in",
        "moment": "",
    }
    assert factors("mm-N-MPa", "in-lbf-psi") == pytest.approx((1e-3 / INCH, 1.0 / LBF))
    # 1 MPa = 145.0377 psi (NIST SP 811 table): the modulus factor F / L^2
    L, F = factors("mm-N-MPa", "in-lbf-psi")
    assert F / L**2 == pytest.approx(145.0377, rel=1e-6)
    # steel 0.2836 lb/in^3 (7850 kg/m^3) over g = 386.0886 in/s^2, in lbf s^2/in^4
    assert DEFAULT_DENSITY["in-lbf-psi"] == pytest.approx(0.28360 / 386.0886, rel=1e-4)


def test_nondim_and_unknown_systems_are_refused() -> None:
    with pytest.raises(ValueError, match="no conversion"):
        factors("nondim", "in-lbf-psi")


def _at(sol, key: str, factor: float) -> float:
    xs = np.array([s.factor for s in sol.steps])
    ys = np.array([s.outputs[key] for s in sol.steps])
    k = int(np.argmin(np.abs(xs - factor)))
    assert abs(xs[k] - factor) <= 1e-9 * max(1.0, abs(factor))
    return float(ys[k])


def test_constant_force_mechanism_in_inches_meets_its_closed_form_in_lbf() -> None:
    """Ex. 5 (rigid links, torsion springs, slider driven 40 mm) written in in-lbf-psi:
    its closed-form driving forces (case file, N at mm) converted to lbf at inches, to the
    case's tolerance, and the same path as in mm-N-MPa to 1e-9."""
    base = cases.load("das2d-ex5-constant-force")
    inch = convert(base, "in-lbf-psi")
    sol_mm, sol_in = solve(base, "kinetostatic"), solve(inch, "kinetostatic")
    assert sol_mm.ok and sol_in.ok, (sol_mm.message, sol_in.message)
    for ref in (r for r in base.references if r.kind == "closed-form"):
        f = _at(sol_in, "driver.force", ref.at_factor * 1e-3 / INCH)
        assert f == pytest.approx(ref.value / LBF, rel=ref.tolerance)
    for a, b in zip(sol_mm.steps, sol_in.steps):
        assert b.factor == pytest.approx(a.factor * 1e-3 / INCH, rel=1e-12, abs=1e-12)
        assert b.outputs["slider.ux"] * INCH * 1e3 == pytest.approx(a.outputs["slider.ux"], 1e-9)
        assert b.outputs["driver.force"] * LBF == pytest.approx(a.outputs["driver.force"], 1e-9)
        assert b.energy * LBF * INCH * 1e3 == pytest.approx(a.energy, rel=1e-9, abs=1e-12)


def test_compliant_parallelogram_in_inches_is_the_same_answer() -> None:
    """Ex. 2 (flexible links, load analysis) converted: every node output converted back to
    mm equals the mm-N-MPa solve (cbcm-4) to 1e-8 of the motion."""
    base = cases.load("das2d-ex2-parallelogram")
    a, b = solve(base, "cbcm-4"), solve(convert(base, "in-lbf-psi"), "cbcm-4")
    assert a.ok and b.ok, (a.message, b.message)
    scale = max(abs(v) for s in a.steps for k, v in s.outputs.items() if k.endswith("ux"))
    for sa, sb in zip(a.steps, b.steps):
        for key, va in sa.outputs.items():
            q = key.rsplit(".", 1)[-1]
            vb = sb.outputs[key] * (INCH * 1e3 if q in ("x", "y", "ux", "uy") else 1.0)
            tol = 1e-8 * (scale if q != "rot" else 1.0)
            assert abs(vb - va) <= tol, (key, va, vb)
