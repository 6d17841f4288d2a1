"""The report's synthesis notes (``reports/render/synthnote.py``): the target beside the FE
re-solve, and a failed FE check says why (issue 21)."""

from __future__ import annotations

from reports.render import synthnote


def test_a_failed_fe_check_of_a_driver_candidate_gives_its_reason() -> None:
    why = "finest mesh (n=64): displacement control stalled at 0"
    extras = {
        "drivers": [
            {
                "driver": "N2 -y",
                "bistable": True,
                "stable": [0.0, -15.0],
                "unstable": -5.9,
                "fem-auto": {"model": "fem-auto", "status": "failed", "message": why + "; more"},
            }
        ]
    }
    line = next(ln for ln in synthnote.notes(extras) if ln.startswith("driver N2 -y"))
    assert line.endswith(f"fem-auto failed ({why})")


def test_a_stiffness_synthesis_shows_the_target_and_the_fe_value() -> None:
    extras = {
        "synthesis": {
            "goal": "stiffness",
            "EI": {"upper": 3033.75},
            "achieved": 20.0,
            "target": 20.0,
            "fem-auto": {"status": "converged", "achieved": 19.9788, "relative_error": 1.06e-3},
        }
    }
    lines = synthnote.notes(extras)
    assert lines[0] == "synthesised EI: upper 3033.75 (stiffness 20, target 20)"
    assert lines[1] == "fem-auto on the synthesised scene: 19.9788 (error 0.00106 of the target)"
