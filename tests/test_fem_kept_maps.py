"""The index maps ``fem-N`` keeps between solves (``scatter.kept``: RCM numbering, csr and
band scatters) belong to one DOF map: two scenes with the same mesh and DOF count but
different supports each get their own, checked against the linear cantilever's closed form."""

from __future__ import annotations

import pytest

from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support
from reports import api

P, L, EI = 1e-6, 1.0, 1.0  # PL^2/EI = 1e-6: the linear regime (relative error ~1e-12)


def _cantilever(clamped: str, loaded: str) -> Scene:
    """A straight member A-B clamped at one end, a small tip force down at the other."""
    return Scene(
        name=f"cantilever-{clamped}",
        title="small-load cantilever",
        units="nondim",
        nodes=(Node("A", 0.0, 0.0), Node("B", L, 0.0)),
        members=(Member("beam", "A", "B", "flexible", E=1.0, I=EI, A=1e4),),
        supports=(Support(clamped, "clamp"),),
        loads=(Load("P", fy=-P, node=loaded),),
        analysis=Analysis(kind="load", steps=2),
        outputs=(Output("tip", loaded),),
    )


@pytest.mark.parametrize("n", [4, 16])
def test_same_mesh_other_supports_gets_its_own_maps(n):
    """Clamped at A then at B (same mesh, same DOF count, another free-DOF map), solved in
    turn: both tips deflect PL^3 / (3 EI) and rotate PL^2 / (2 EI), with opposite signs of
    rotation (the mirror image)."""
    tips = []
    for clamped, loaded in (("A", "B"), ("B", "A"), ("A", "B")):
        sol = api.solve(_cantilever(clamped, loaded), f"fem-{n}")
        assert sol.status == "converged", sol.message
        tips.append(sol.steps[-1].outputs)
    for o in tips:
        assert o["tip.uy"] == pytest.approx(-P * L**3 / (3 * EI), rel=1e-9)
        assert abs(o["tip.rot"]) == pytest.approx(P * L**2 / (2 * EI), rel=1e-9)
    assert tips[0]["tip.rot"] == pytest.approx(-tips[1]["tip.rot"], rel=1e-9)
    assert tips[2] == tips[0]  # the kept maps reproduce the first solve exactly
