"""Grading that fits the model: each pair's error judged against a tolerance meant for it.

A reduced model is not graded against the reference's own 1e-3 tolerance (that would give
PRB-1R at 0.7 % the same FAIL as linear-1 at 100 %): its error on the default yardstick
(``error_rel``: each judged output's error over its own excursion along the reference path)
is judged against the case's ``[[tolerances]]`` when it names the outputs a designer judges,
else against the user's tolerance (``flexbench run --tol``) or its family's default below.
The model's own validity warnings travel with the grade so that every table shows them
next to the numbers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from reports.verdicts.tolerance import for_case, judged_errors

# family (ModelCard.family) -> default tolerance on the summary error, and why
FAMILY_TOLERANCE: dict[str, tuple[float, str]] = {
    "elastica": (1e-3, "an exact model: only the reference's own uncertainty"),
    "fem": (1e-3, "a reference-grade discretisation"),
    "replay": (1e-3, "settles to the static reference"),
    "auto": (1e-3, "refined to a 1e-3 estimate by default"),
}
DEFAULT_TOLERANCE = (
    1e-2,
    "engineering accuracy of a reduced model: 1 % of each output's excursion",
)


def family_of(rec: Mapping[str, Any]) -> str:
    """The model family of a pair record (from its card, else its name)."""
    card = rec.get("card") or {}
    if card.get("family"):
        return str(card["family"])
    name = str(rec.get("model", ""))
    return name.rsplit("-", 1)[0] if name.rsplit("-", 1)[-1].isdigit() else name


def tolerance_of(rec: Mapping[str, Any], user: float | None = None) -> tuple[float, str]:
    """(tolerance, where it comes from) for one pair."""
    if user is not None:
        return float(user), "user tolerance"
    fam = family_of(rec)
    tol, why = FAMILY_TOLERANCE.get(fam, DEFAULT_TOLERANCE)
    return tol, f"{fam} default: {why}"


def validity_warning(rec: Mapping[str, Any]) -> str | None:
    """The model's own out-of-range warning, if it raised one."""
    extras = rec.get("extras") or {}
    if not extras.get("validity_warning"):
        return None
    return str(extras.get("validity_message") or "outside the model's validity range")


def grade(
    rec: Mapping[str, Any], user: float | None = None, case_tolerances: Sequence[Mapping] = ()
) -> dict[str, Any]:
    """``{"tolerance", "source", "verdict", "validity_warning"}`` of one pair record.

    ``verdict``: ``within`` | ``exceeds`` | ``reference`` | ``-`` (no error to judge: declined,
    failed before a comparable step, or no reference).  With ``case_tolerances`` (the case's
    ``[[tolerances]]`` dicts) every named output is judged against its own value (the user's
    ``user`` replaces the relative ones) and ``tolerance`` is that of the worst output.
    """
    tol, source = tolerance_of(rec, user)
    err = rec.get("error_rel")
    path = rec.get("errors") if rec.get("summary_basis") == "path" else None
    if case_tolerances and path and not rec.get("is_reference"):
        judged = judged_errors(path, for_case(case_tolerances, user))
        if judged:
            _, key, err, tol = max(judged)  # the worst output by error / its tolerance
            source = f"case tolerance on {key}" + ("" if user is None else " (user value)")
    if rec.get("is_reference"):
        verdict = "reference"
    elif err is None:
        verdict = "-"
    else:
        verdict = "within" if err <= tol else "exceeds"
    if verdict == "within" and rec.get("status") != "converged":
        verdict = "exceeds"  # a partial path is not within tolerance over the whole path
    return {
        "tolerance": tol,
        "source": source,
        "verdict": verdict,
        "validity_warning": validity_warning(rec),
    }


def label(g: Mapping[str, Any] | None) -> str:
    """Short table text: ``within 1 %``, ``EXCEEDS 1 %`` (+ ``, validity warning``)."""
    if not g:
        return "–"
    tol = f"{g['tolerance'] * 100:.3g} %"
    text = {"within": f"within {tol}", "exceeds": f"EXCEEDS {tol}"}.get(g["verdict"], "–")
    if g["verdict"] == "reference":
        text = "reference"
    return text + (" ⚠ validity" if g.get("validity_warning") else "")


def summary_text(user: float | None) -> str:
    """The report's statement of how results are graded."""
    if user is not None:
        return (
            f"Grades: every model's summary error is judged against the user's tolerance "
            f"{user * 100:.3g} % of each judged output's own excursion (error_rel)."
        )
    fams = ", ".join(f"{f} {t * 100:.3g} %" for f, (t, _) in FAMILY_TOLERANCE.items())
    return (
        "Grades: every model's summary error is judged against its family's default tolerance "
        f"(of L, or rad): {fams}, every reduced model {DEFAULT_TOLERANCE[0] * 100:.3g} % "
        f"({DEFAULT_TOLERANCE[1]}); `flexbench run --tol X` sets one for all. "
        "⚠ marks a model that left its own validity range (its warning is in the note)."
    )
