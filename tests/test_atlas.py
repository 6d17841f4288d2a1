"""Validity atlases: values at sampled grid points equal individual solves, and claims are
judged inside their stated region only."""

from __future__ import annotations

import numpy as np
import pytest

import reports
from reports import atlas

SMALL = {"n_mag": 8, "n_ang": 5}


def individual_error(family: str, model: str, mag: float, angle: float) -> float:
    """Summary error of one separate 20-step solve to exactly this load, against the elastica
    solved on its own (no atlas code path)."""
    scene = atlas.scene_for(family, mag, angle, steps=20)
    m, e = reports.solve(scene, model), reports.solve(scene, "elastica")
    assert m.ok and e.ok, (m.message, e.message)
    return max(
        abs(m.steps[-1].outputs[k] - e.steps[-1].outputs[k])
        for k in ("tip.ux", "tip.uy", "tip.rot")
    )


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
            direct = individual_error(family, model, at.mags[j], at.angles[i])
            assert value == pytest.approx(direct, rel=1e-6, abs=1e-10), (model, i, j)


def test_claims_are_judged_inside_their_region():
    at = atlas.compute("force", ("bcm",), **SMALL)
    for claim in (c for c in atlas.CLAIMS if c.model == "bcm"):
        res = atlas.check_claim(claim, at)
        region = claim.region(at)
        assert res["points"] == int((region & np.all(np.isfinite(at.ref), -1)).sum()) > 0
        # outside the region the single BCM is far off; inside its claimed range it is not
        assert np.nanmax(at.pos["bcm"][~region]) > claim.accuracy
        assert res["verdict"] == ("holds" if res["failing"] == 0 else "fails")
