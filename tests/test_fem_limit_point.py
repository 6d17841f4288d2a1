"""The FE's refined limit points against the closed form of the von Mises truss.

Two linear springs (k, free length L0 = sqrt(a^2 + h^2)) pinned at (+-a, 0) and at the apex
(0, h), the apex loaded downwards by P x factor (``path`` analysis): P(w) = 2 k (L0 - L)(h - w)
/ L with L = sqrt(a^2 + (h - w)^2) has its maximum where L*^3 = L0 a^2, at
w* = h - sqrt(L*^2 - a^2), and (the mirrored truss) its minimum at w = 2h - w*.  The FE's
spring elements are exact, so the limit state is judged to round-off: the refinement finds
the root of d lam / d v, which a maximum of lam(v) found only to the square root of lam's
round-off (3e-11 m off here, 4e-9 of w*).  At the fold itself the state is unstable.
"""

from __future__ import annotations

import math
import re

import pytest
from scipy.optimize import brentq

import cases
from reports.api import make_model

A, H, K, P = 0.1, 0.02, 2.0e4, 10.0


def _truss_path() -> cases.Scene:
    text = cases.resolve("von-mises-spring-truss").read_text()
    head = re.sub(r'(?s)description = """.*?"""\n', "", text[: text.index("[analysis]")])
    path = f'[[loads]]\nnode = "C"\nfy = {-P}\n\n[analysis]\nkind = "path"\nsteps = 40\n'
    return cases.loads(head + path + '\n[[outputs]]\nname = "apex"\nnode = "C"\n', "vm-path")


@pytest.mark.parametrize("model", ["fem-8", "fem-auto"])
def test_limit_points_of_the_von_mises_truss_to_round_off(model):
    L0 = math.hypot(A, H)
    Ls = (L0 * A * A) ** (1.0 / 3.0)
    w = H - math.sqrt(Ls * Ls - A * A)
    lam = 2.0 * K * (L0 - Ls) * (H - w) / Ls / P
    sol = make_model(model, _truss_path()).solve(_truss_path())
    assert sol.ok, sol.message
    top, bottom = sol.extras["limit_points"]
    assert (top["kind"], bottom["kind"]) == ("max", "min")
    assert top["factor"] == pytest.approx(lam, rel=1e-12)
    assert bottom["factor"] == pytest.approx(-lam, rel=1e-12)
    assert top["outputs"]["apex.uy"] == pytest.approx(-w, abs=1e-13)
    assert bottom["outputs"]["apex.uy"] == pytest.approx(-(2.0 * H - w), abs=1e-13)
    folds = [s for s in sol.steps if s.info.get("limit_point")]
    assert len(folds) == 2 and all(s.stable is False for s in folds)


def test_shallow_arch_limit_points_to_round_off():
    """``shallow-arch-snap`` (bars of half-span 1, rise 0.1, EA = 1000): P(w) = -2 EA (h - w)
    (1 - L0 / L) / L0 has its maximum where dP/dw = 0 (w* = 0.0423607465169); the FE's bars
    carry exactly that axial law.  The maximum of lam(v) put the state 1.3e-10 off."""
    b, h, ea = 1.0, 0.1, 1000.0
    L0 = math.hypot(b, h)

    def dp(w: float) -> float:
        s = h - w
        L = math.hypot(b, s)
        return -2.0 * ea / L0 * (-(1.0 - L0 / L) - s * s * L0 / L**3)

    w = brentq(dp, 0.01, 0.08, xtol=1e-17)
    scene = cases.load("shallow-arch-snap")
    sol = make_model("fem-8", scene).solve(scene)
    assert sol.ok, sol.message
    top, bottom = sol.extras["limit_points"]
    assert top["outputs"]["apex.uy"] == pytest.approx(-w, abs=1e-13)
    assert bottom["outputs"]["apex.uy"] == pytest.approx(-(2.0 * h - w), abs=1e-13)
