"""fem-auto's error estimate when the meshes of a load-stepped path are on different branches.

A snap (or a switch at a bifurcation) that happens at another load factor on a coarse mesh
leaves that mesh on another branch for the steps in between: the difference of the meshes
there is the distance between the branches, not a discretisation error.  Such a mesh must not
enter those steps' estimate (DAS-2D Ex. 3: the estimate was 16.5 mm, the shuttle's travel on
the snap, at load factors 0.45-0.65).

The synthetic runs below have a closed form on every mesh: a value ``g(factor) + C h^2`` on the
near branch and ``g(factor) + JUMP + C h^2`` on the far one, with the jump at a mesh-dependent
factor.  Richardson on the meshes of one branch is exact (the error is exactly C h^2).
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from fem_reference.error.richardson import branch_changes, combine
from reduced_models.base import Step

SEQ = (8, 16, 32, 64)
FACTORS = np.round(np.arange(0.0, 1.0001, 0.05), 12)
JUMP = 16.5  # the far branch's offset (length units)
C = 0.7  # discretisation error coefficient: value = exact + C / n^2
L = 1.0


def exact(lam: float, far: bool) -> float:
    return 2.0 * lam + lam**2 + (JUMP if far else 0.0)


def fake_run(n: int, jump_at: float, kind: str):
    """A converged Runner-like run on ``n`` elements that jumped to the far branch at
    ``jump_at`` (a ``kind`` critical point with ``switched``)."""
    steps = [
        Step(lam, {"p.ux": exact(lam, lam > jump_at) + C / n**2}, energy=lam**2 + 1.0 / n**2)
        for lam in FACTORS
    ]
    cps = [{"factor": jump_at, "kind": kind, "switched": True}]
    if kind == "snap":  # the bifurcation the coarse meshes did not switch at
        cps.insert(0, {"factor": 0.432, "kind": "bifurcation", "switched": False})
    run = types.SimpleNamespace(
        steps=steps,
        extras={"critical_points": cps},
        system=types.SimpleNamespace(length_scale=lambda: L),
    )
    return run, "converged", ""


SCENE = types.SimpleNamespace(name="synthetic", analysis=types.SimpleNamespace(kind="load"))


def solve(jumps: tuple[float, ...], kinds: tuple[str, ...]):
    runs = [fake_run(n, j, k) for n, j, k in zip(SEQ, jumps, kinds)]
    return combine(SCENE, "fem-auto", SEQ, runs)


def test_coarse_meshes_on_another_branch_give_no_estimate_there():
    """Ex. 3's pattern: 8/16/32 stay near up to their snap at 0.67, 64 switches at 0.432."""
    sol = solve((0.67, 0.67, 0.67, 0.432), ("snap", "snap", "snap", "bifurcation"))
    err = np.array(sol.extras["error_estimate_steps"]["p.ux"])
    vals = np.array([s.outputs["p.ux"] for s in sol.steps])
    between = (FACTORS > 0.432) & (FACTORS < 0.67)
    # one branch on every mesh: Richardson of exact C h^2 errors recovers the exact value
    want = [exact(lam, lam > 0.432) for lam in FACTORS]
    assert np.allclose(vals[~between], np.array(want)[~between], rtol=0, atol=1e-12)
    assert np.all(err[~between] < 1e-9)
    # between the jumps only the finest mesh is on its branch: its own value, no estimate
    assert np.all(np.isnan(err[between]))
    assert np.allclose(vals[between], np.array(want)[between] + C / 64**2, rtol=0, atol=1e-12)
    off = sol.extras["off_branch"]
    assert [r["factor"] for r in off] == pytest.approx(FACTORS[between].tolist())
    assert all(r["excluded"] == [8, 16, 32] and not r["estimate"] for r in off)
    assert f"no error estimate at {between.sum()} steps (factors 0.45-0.65)" in sol.message


def test_meshes_on_the_finest_branch_still_estimate_it():
    """8 jumps late, 16/32/64 at 0.432: the steps between are extrapolated from 16/32/64
    (exact) without the 8-element mesh, their estimate the three-mesh one, the finest
    mesh's own error |f* - f3| = C / 64^2."""
    sol = solve((0.67, 0.432, 0.432, 0.432), ("snap", "bifurcation", "bifurcation", "bifurcation"))
    err = np.array(sol.extras["error_estimate_steps"]["p.ux"])
    vals = np.array([s.outputs["p.ux"] for s in sol.steps])
    want = np.array([exact(lam, lam > 0.432) for lam in FACTORS])
    between = (FACTORS > 0.432) & (FACTORS < 0.67)
    assert np.allclose(vals, want, rtol=0, atol=1e-12)
    assert np.all(err[~between] < 1e-9)
    assert np.allclose(err[between], C / 64**2, rtol=1e-9, atol=0)
    assert {r["factor"] for r in sol.extras["off_branch"]} == set(FACTORS[between].tolist())
    assert "an error estimate from fewer meshes at 5 steps" in sol.message


def test_branch_changes_count_in_the_direction_of_loading():
    cps = [{"factor": -0.3, "switched": True}, {"factor": -0.1, "switched": False}]
    assert branch_changes(cps, np.array([0.0, -0.2, -0.4])).tolist() == [0, 0, 1]
