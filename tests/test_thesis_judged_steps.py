"""thesis-force-method is judged on its deployed state only (issue 25, config2's error_rel).

Its Part 1 steps are a relaxation in pseudo-time, not equilibria: the first is the drawn pose
(kinetostatic's first step is the equilibrium at the start length, 13 mm away at J4 on
Configuration 2) and at the end of Part 1 the boom has overshot 0.3 m while the joints are
still moving (J4 12 mm from the equilibrium at 0.3 m).  Compared step by step the runner
reported error_rel 0.74-1.0; the deployed state itself is within the boom's overshoot,
~0.1 mm (``reports.verdicts.thesis_study``: bounded by one Part 1 increment).
"""

from __future__ import annotations

import cases
from reports import api
from reports.verdicts.errors import attach_errors


def _record(sol: object) -> dict:
    steps = [{"factor": s.factor, "outputs": dict(s.outputs), "stable": s.stable}
             for s in sol.steps]  # fmt: skip
    return {"model": sol.model, "status": sol.status, "message": sol.message,
            "steps": steps, "extras": dict(sol.extras)}  # fmt: skip


def test_deployed_state_judged_not_the_relaxation():
    scene = cases.load("thesis-sixbar-config2")
    ref, tfm = (_record(api.solve(scene, m)) for m in ("kinetostatic", "thesis-force-method"))
    meta = {"reference_model": "kinetostatic", "length_scale": 0.4}
    attach_errors(meta, [ref, tfm])
    assert tfm["errors"]["n_points"] == 1
    worst_mm = max(
        abs(tfm["steps"][-1]["outputs"][k] - ref["steps"][-1]["outputs"][k]) * 1e3
        for k in ref["steps"][-1]["outputs"] if k.endswith((".x", ".y"))
    )  # fmt: skip
    assert worst_mm < 0.3  # one Part 1 increment at gamma = 0.005
    assert tfm["error_rel"] < 0.01  # was 1.0 judged on the Part 1 relaxation
