"""The recommender's reason says why a model within the tolerance does not qualify."""

from reports.verdicts.recommendation import Candidate, verdict
from reports.verdicts.tolerance import parse_tolerance


def test_within_tolerance_but_not_with_the_reference_uncertainty_is_said():
    tol = parse_tolerance("1%")
    c = Candidate(
        "elastica", "converged", "21 steps", worst_error=3.3e-5, worst_output="tip.ux",
        tolerance=0.01, cpu_s=0.5, uncertainty=0.2, qualifies=False,
    )  # fmt: skip
    model, reason, _ = verdict([c], tol, lambda m, s: s)
    assert model is None
    assert "reference's own uncertainty 20 %" in reason.replace("20.0 %", "20 %"), reason
