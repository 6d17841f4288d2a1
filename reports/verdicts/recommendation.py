"""The recommender's records and its verdict in words: ``Candidate`` (one model tried),
``Recommendation`` (what ``reports.verdicts.recommend.recommend`` found; ``as_json`` is the CLI
contract object), ``verdict`` (which qualifying candidate is named, and the paragraph saying
why or why none is) and ``format_text`` (the table ``flexbench recommend`` prints).
``reports.verdicts.advice`` applies the same verdict to the records of a run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from reports.verdicts import pick
from reports.verdicts.pick import EXACT
from reports.verdicts.tolerance import Tolerance, pct

YARDSTICK = "error_rel"  # the errors' yardstick (reports.verdicts.errors), named in the JSON


@dataclass
class Candidate:
    """One model tried: status, worst judged error (relative to its tolerance) and cost."""

    model: str
    status: str
    message: str = ""
    worst_error: float | None = None
    worst_output: str | None = None
    at_factor: float | None = None
    tolerance: float | None = None
    cpu_s: float | None = None
    noise_s: float = 0.0
    uncertainty: float = 0.0  # the reference's own error estimate (error_rel) it must also fit
    ratio_to_reference: float | None = None
    qualifies: bool = False
    warning: str = ""
    yardstick: str = YARDSTICK  # or "abs": an absolute tolerance in case units
    unknowns: int | None = None
    errors: dict[str, float] = field(default_factory=dict)
    profile: list[tuple[float, float]] = field(default_factory=list)  # (factor, error / tol)

    def error_text(self, value: float | None = None) -> str:
        """The worst error (or ``value``) on this candidate's yardstick: ``0.5 %`` relative
        to the output's own excursion, or ``0.0003 abs`` in case units."""
        v = self.worst_error if value is None else value
        return pct(v) if self.yardstick == "error_rel" else f"{v:.3g} abs"

    def where(self) -> str:
        """``"stage.uy at factor 0.6"`` (the factor when known)."""
        at = "" if self.at_factor is None else f" at factor {self.at_factor:.3g}"
        return f"{self.worst_output}{at}"

    def as_json(self) -> dict[str, Any]:
        """The contract's candidate object (plus ``worst_output``, ``qualifies``, ...)."""
        out = {
            "model": self.model,
            "status": self.status,
            "worst_error": _finite(self.worst_error),
            "at_factor": _finite(self.at_factor),
            "cpu_s": _finite(self.cpu_s),
            "ratio_to_reference": _finite(self.ratio_to_reference),
        }
        out.update(
            worst_output=self.worst_output,
            tolerance=_finite(self.tolerance),
            yardstick=self.yardstick,
            qualifies=self.qualifies,
            noise_s=_finite(self.noise_s),
            unknowns=self.unknowns,
            message=self.message,
            validity_warning=self.warning or None,
        )
        return out


def _finite(x: float | None) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


@dataclass
class Recommendation:
    """What ``recommend`` found (``as_json`` is the CLI contract object)."""

    case: str
    tolerance: Tolerance
    recommended: str | None
    reason: str
    reference: str | None
    reference_cpu_s: float | None
    candidates: list[Candidate]
    skipped: list[str] = field(default_factory=list)
    elapsed_s: float = 0.0
    decided_by: str | None = None

    def as_json(self) -> dict[str, Any]:
        """``{"case", "tolerance", "recommended", "reason", "yardstick", "decided_by",
        "candidates": [...]}`` + extras."""
        return {
            "case": self.case,
            "tolerance": self.tolerance.as_json(),
            "recommended": self.recommended,
            "reason": self.reason,
            "yardstick": YARDSTICK,
            "decided_by": self.decided_by,
            "candidates": [c.as_json() for c in self.candidates],
            "reference": self.reference,
            "reference_cpu_s": _finite(self.reference_cpu_s),
            "not_run": self.skipped,
        }


def as_option(c: Candidate, cost: Callable[[str, float], float]) -> pick.Option:
    """A candidate as ``pick.choose`` sees it (cost in the caller's units)."""
    value = None if c.cpu_s is None else cost(c.model, c.cpu_s)
    return pick.Option(c.model, c.qualifies, value, c.noise_s, c.unknowns, c.worst_error)


def verdict(
    cands: list[Candidate], tol: Tolerance, cost: Callable[[str, float], float]
) -> tuple[str | None, str, str | None]:
    """(recommended model or None, one-paragraph reason, the rule that decided)."""
    ok = [c for c in cands if c.qualifies]
    ran = [c for c in cands if c.status != "not-applicable"]
    reduced = [c for c in ran if not c.model.startswith("fem-")]
    if not ran:
        return (
            None,
            (
                f"every candidate model declines this scene ({_declines(cands)}); "
                "no reduced model can represent it"
            ),
            None,
        )
    if not ok:
        worst = min(ran, key=_closeness)
        return None, f"no model qualifies at {tol.text()}; closest: {_miss(worst)}", None
    options = [as_option(c, cost) for c in ok]
    chosen = pick.choose(options)
    c = next(c for c in ok if c.model == chosen.model)
    what = "an exact model" if c.model in EXACT and c.worst_error == 0.0 else "within"
    reason = (
        f"{c.model} is the cheapest model within {tol.text()}"
        + (f" ({what}: {c.message})" if what != "within" else "")
        + f": worst error {c.error_text()}"
        + (f" ({c.where()})" if c.worst_output else "")
        + f", {c.cpu_s * 1e3:.3g} ms CPU; {chosen.explain(options)}"
    )
    if c.model.startswith("fem-"):
        miss = [r for r in reduced if not r.qualifies]
        dearer = [r for r in reduced if r.qualifies]
        if dearer:  # a reduced model is within tolerance but measured dearer than the FE
            r = min(dearer, key=lambda r: cost(r.model, r.cpu_s))
            reason += (
                f"; the cheapest reduced model within {tol.text()}, {r.model} "
                f"({r.error_text()}), costs more here ({r.cpu_s * 1e3:.3g} ms CPU)"
            )
        elif miss:
            reason += f"; no reduced model qualifies: closest {_miss(min(miss, key=_closeness))}"
        elif not reduced:
            reason += f"; every reduced model declines this scene ({_declines(cands)})"
    return c.model, reason, chosen.decided_by


def _closeness(c: Candidate) -> float:
    if c.worst_error is None or c.tolerance is None:
        return math.inf
    return c.worst_error / c.tolerance + (0.0 if c.status == "converged" else 1e6)


def _miss(c: Candidate) -> str:
    if c.worst_error is None:
        return f"{c.model} ({c.status}: {c.message})"
    why = f"{c.worst_output} error {c.error_text()}{c.where()[len(c.worst_output or '') :]}"
    if c.status != "converged":
        why += f", {c.status}: {c.message}"
    elif c.worst_error <= (c.tolerance or 0.0):
        # within the tolerance alone: it is the reference's own uncertainty that does not fit
        why += f" + the reference's own uncertainty {c.error_text(c.uncertainty)}, {c.message}"
    return f"{c.model} ({why} > {c.error_text(c.tolerance)})"


def _declines(cands: list[Candidate]) -> str:
    reasons: dict[str, list[str]] = {}
    for c in (c for c in cands if c.status == "not-applicable"):
        reasons.setdefault(c.message, []).append(c.model.rsplit("-", 1)[0] + "*")
    return "; ".join(f"{', '.join(dict.fromkeys(m))}: {r}" for r, m in reasons.items())


def ordered(rec: Recommendation) -> list[Candidate]:
    """The candidates as the verdict tables list them: qualifying first, cheapest first."""
    return sorted(rec.candidates, key=lambda c: (not c.qualifies, c.cpu_s or math.inf))


def verdict_word(c: Candidate, recommended: str | None) -> str:
    """A candidate's one-word verdict in the tables: recommended, within, declines, exceeds
    or its status, with a validity warning noted."""
    if c.model == recommended:
        verdict = "recommended"
    elif c.qualifies:
        verdict = "within"
    elif c.status == "not-applicable":
        verdict = "declines"
    else:
        verdict = "exceeds" if c.status == "converged" else c.status
    return verdict + (" (validity warning)" if c.warning else "")


def format_text(rec: Recommendation) -> str:
    """The evidence table and verdict printed by ``flexbench recommend``."""
    lines = [
        f"{rec.case}: tolerance {rec.tolerance.text()} (error_rel: each output's error "
        f"over its own excursion along the reference path); reference {rec.reference} "
        f"({(rec.reference_cpu_s or math.nan) * 1e3:.3g} ms CPU)",
        *(
            f"  judged: {key} (why: {why})"
            for key, why in rec.tolerance.why.items()
            if why != "user"  # a case's [[tolerances]] entry says why the designer judges it
        ),
        f"recommended: {rec.recommended or 'none'}"
        + (f" (decided by: {rec.decided_by})" if rec.decided_by else ""),
        f"  {rec.reason}",
        "",
        f"{'model':<14} {'status':<15} {'worst error':>11} {'output':<12} {'at factor':>9} "
        f"{'CPU ms':>8} {'+/- ms':>7} {'unknowns':>8} {'x ref':>7}  verdict",
    ]
    for c in ordered(rec):
        err = "-" if c.worst_error is None else c.error_text()
        at = "-" if c.at_factor is None else f"{c.at_factor:.3g}"
        ms = "-" if c.cpu_s is None else f"{c.cpu_s * 1e3:.3g}"
        noise = "-" if c.cpu_s is None else f"{c.noise_s * 1e3:.2g}"
        unk = "-" if c.unknowns is None else str(c.unknowns)
        ratio = "-" if c.ratio_to_reference is None else f"{c.ratio_to_reference:.3g}"
        verdict = verdict_word(c, rec.recommended).replace("recommended", "RECOMMENDED")
        lines.append(
            f"{c.model:<14} {c.status:<15} {err:>11} {c.worst_output or '-':<12} {at:>9} "
            f"{ms:>8} {noise:>7} {unk:>8} {ratio:>7}  {verdict}"
        )
    if rec.skipped:
        lines.append(f"not run (cannot be cheaper): {', '.join(rec.skipped)}")
    lines.append(f"({rec.elapsed_s:.2f} s)")
    return "\n".join(lines)
