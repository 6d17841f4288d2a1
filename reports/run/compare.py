"""Regression check between two runs (``flexbench compare BASE CURRENT``).

For every (case, model) pair present in both results files:

* status: ``converged`` in BASE but not in CURRENT is a regression;
* accuracy, per output (path error against the case's reference, same reference in both
  runs): CURRENT may not exceed ``max(abs_tol, rel_factor * BASE)``; an error BASE had and
  CURRENT lost is a regression;
* published references: a check that passed in BASE and does not pass in CURRENT.

Pairs only in one file and changed references are reported as notes, not regressions
(a run on a subset of the catalog is a legitimate CURRENT).  Wall times are not compared:
they are noise on shared machines; the history database tracks them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

DEFAULT_ABS_TOL = 1e-8
DEFAULT_REL_FACTOR = 1.25


@dataclass
class Comparison:
    """Outcome of ``compare``: regression rows, notes, number of pairs compared."""

    regressions: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    n_pairs: int = 0
    n_checks: int = 0

    @property
    def ok(self) -> bool:
        return not self.regressions


def _index(payload: Mapping) -> dict[tuple[str, str], Mapping]:
    return {(r["case"], r["model"]): r for r in payload["results"]}


def _ref_name(payload: Mapping, case: str) -> str | None:
    return (payload.get("cases") or {}).get(case, {}).get("reference")


def _ref_key(c: Mapping) -> tuple:
    return (c.get("output"), c.get("at_factor"), c.get("value"))


def compare(
    base: Mapping,
    current: Mapping,
    abs_tol: float = DEFAULT_ABS_TOL,
    rel_factor: float = DEFAULT_REL_FACTOR,
) -> Comparison:
    """Compare two ``results.json`` payloads (see module docstring)."""
    out = Comparison()
    b_idx, c_idx = _index(base), _index(current)
    for key in sorted(set(b_idx) - set(c_idx)):
        out.notes.append(f"only in BASE: {key[0]} / {key[1]}")
    for key in sorted(set(c_idx) - set(b_idx)):
        out.notes.append(f"only in CURRENT: {key[0]} / {key[1]}")

    def flag(case: str, model: str, what: str, b: Any, c: Any, allowed: Any, why: str) -> None:
        out.regressions.append(
            {
                "case": case,
                "model": model,
                "output": what,
                "base": b,
                "current": c,
                "allowed": allowed,
                "reason": why,
            }
        )

    for case, model in sorted(set(b_idx) & set(c_idx)):
        b, c = b_idx[(case, model)], c_idx[(case, model)]
        out.n_pairs += 1
        if b["status"] == "converged" and c["status"] != "converged":
            flag(
                case,
                model,
                "status",
                b["status"],
                c["status"],
                "converged",
                f"status converged -> {c['status']}: {c.get('message', '')}",
            )
        same_ref = _ref_name(base, case) == _ref_name(current, case)
        b_err = (b.get("errors") or {}).get("per_output") or {}
        c_err = (c.get("errors") or {}).get("per_output") or {}
        if b_err and not same_ref:
            out.notes.append(
                f"{case}: reference changed ({_ref_name(base, case)} -> "
                f"{_ref_name(current, case)}); path errors not compared"
            )
        elif b_err:
            for output, be in sorted(b_err.items()):
                if be is None:
                    continue
                out.n_checks += 1
                ce = c_err.get(output)
                allowed = max(abs_tol, rel_factor * be)
                if ce is None:
                    if c["status"] == "converged" or b["status"] != "converged":
                        flag(case, model, output, be, None, allowed, "error no longer computed")
                elif ce > allowed:
                    flag(case, model, output, be, ce, allowed, "error grew")
        c_checks = {_ref_key(x): x for x in c.get("refchecks") or []}
        for bc in b.get("refchecks") or []:
            if not bc.get("passed"):
                continue
            out.n_checks += 1
            cc = c_checks.get(_ref_key(bc))
            if cc is None:
                out.notes.append(f"{case}: reference {bc.get('output')} removed")
            elif not cc.get("passed"):
                flag(
                    case,
                    model,
                    f"ref {bc['output']} = {bc['value']:g}",
                    bc.get("error"),
                    cc.get("error"),
                    bc.get("tolerance"),
                    f"published-reference check no longer passes ({cc.get('note') or 'error'}"
                    f" > tolerance)"
                    if cc.get("error") is not None
                    else f"published-reference check no longer evaluated ({cc.get('note')})",
                )
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.3e}"
    return "–" if v is None else str(v)


def format_table(rows: list[dict[str, Any]]) -> str:
    """Plain-text table of regression rows (fixed-width columns)."""
    cols = ("case", "model", "output", "base", "current", "allowed", "reason")
    cells = [[_fmt(r[c]) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    widths[-1] = len(cols[-1])  # the reason runs free at the end
    line = "  ".join(c.ljust(w) for c, w in zip(cols, widths))
    out = [line, "  ".join("-" * w for w in widths)]
    out += ["  ".join(v.ljust(w) for v, w in zip(row, widths)).rstrip() for row in cells]
    return "\n".join(out)


def report(result: Comparison) -> str:
    """Human-readable summary (the CLI prints it on stdout)."""
    lines = []
    if result.regressions:
        lines.append(
            f"REGRESSION: {len(result.regressions)} problem(s) in {result.n_pairs} common pairs"
        )
        lines.append(format_table(result.regressions))
    else:
        lines.append(
            f"no regression: {result.n_pairs} common pairs, {result.n_checks} accuracy checks"
        )
    lines += [f"note: {n}" for n in result.notes]
    return "\n".join(lines)
