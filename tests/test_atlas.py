"""Validity atlases: values at sampled grid points equal individual solves, and claims are
judged inside their stated region only."""

from __future__ import annotations

import math

import numpy as np
import pytest

import reports
from reports.verdicts import atlas

SMALL = {"n_mag": 8, "n_ang": 5}


def individual_error(family: str, model: str, mags, j: int, angle: float) -> float:
    """``error_rel`` of one separate 20-step solve to exactly the load ``mags[j]``, against
    the elastica solved on its own (no atlas code path): translations over the tip's largest
    exact displacement on the ramp through the atlas's magnitudes ``mags[:j + 1]``, the
    rotation over its largest rotation there (floored at 1e-3 of the ramp's displacement /
    L, L = 1, and at 1e-6 round-off, as the yardstick states)."""
    scene = atlas.scene_for(family, mags[j], angle, steps=20)
    m, e = reports.solve(scene, model), reports.solve(scene, "elastica")
    assert m.ok and e.ok, (m.message, e.message)
    ramp = reports.solve(atlas.scene_for(family, mags[j], angle, steps=j + 1), "elastica")
    move = max(math.hypot(s.outputs["tip.ux"], s.outputs["tip.uy"]) for s in ramp.steps)
    turn = max(abs(s.outputs["tip.rot"]) for s in ramp.steps)
    d = {k: abs(m.steps[-1].outputs[k] - e.steps[-1].outputs[k]) for k in m.steps[-1].outputs}
    move_f = max(move, 1e-6)  # round-off floor: 1e-6 L (an inextensible bar in tension)
    turn_f = max(turn, 1e-3 * move, 1e-6)
    return max(d["tip.ux"] / move_f, d["tip.uy"] / move_f, d["tip.rot"] / turn_f)


@pytest.mark.parametrize(
    "family, models",
    [
        ("force", ("prb-3r", "cbcm-2", "linear-8")),
        ("follower", ("cbcm-2",)),
        ("moment", ("prb-1r",)),
    ],
)
def test_atlas_values_equal_individual_solves(family: str, models: tuple[str, ...]):
    at = atlas.compute(family, models, **SMALL)
    rng = np.random.default_rng(3)
    for model in models:
        for _ in range(2):
            i, j = rng.integers(len(at.angles)), rng.integers(1, len(at.mags))
            value = at.error[model][i, j]
            if not np.isfinite(value):
                continue
            direct = individual_error(family, model, at.mags, j, at.angles[i])
            # abs: a state at round-off level (pure tension, the tip moves ~1e-12 L) is judged
            # against the 1e-6 L floor, where step-count round-off (~1e-11 L) shows as ~1e-5
            assert value == pytest.approx(direct, rel=1e-6, abs=1e-5), (model, i, j)


def test_claims_are_judged_inside_their_region():
    at = atlas.compute("force", ("bcm",), **SMALL)
    for claim in (c for c in atlas.CLAIMS if c.model == "bcm"):
        res = atlas.check_claim(claim, at)
        region = claim.region(at)
        assert res["points"] == int((region & np.all(np.isfinite(at.ref), -1)).sum()) > 0
        # outside the region the single BCM is far off; inside its claimed range it is not
        assert np.nanmax(at.pos["bcm"][~region]) > claim.accuracy
        assert res["verdict"] == ("holds" if res["failing"] == 0 else "fails")
