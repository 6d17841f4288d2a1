"""Per-model notes of the synthesis analyses (issue 9): the synthesised EI, the bistable summary
and the fem-auto re-solve of the synthesised scene (``reports/verdicts/fecheck.py``)."""

from __future__ import annotations

from collections.abc import Mapping


def _g(v: object) -> str:
    return f"{v:.6g}" if isinstance(v, int | float) else "?"


def _why(fe: Mapping) -> str:
    """The FE check's own reason when it did not converge (first clause, so a failed check
    says why rather than only that it failed)."""
    msg = str(fe.get("message") or "").split(";")[0].strip()
    return f" ({msg[:160]})" if msg else ""


def _bistable(b: Mapping) -> str:
    if not b.get("bistable"):
        return f"not bistable ({b.get('reason', 'no stable-unstable-stable triple')})"
    c, bar = b.get("critical") or {}, b.get("barrier") or {}
    st = b.get("stable") or [None, None]
    return (
        f"stable at {_g(st[0])} and {_g(st[1])}, unstable at {_g(b.get('unstable'))}, "
        f"barrier {_g(bar.get('forward'))} (back {_g(bar.get('backward'))}), switching "
        f"{_g(c.get('forward'))} / back {_g(c.get('backward'))}"
    )


def notes(extras: Mapping) -> list[str]:
    """Lines for the per-case model table (empty when the run is not a synthesis)."""
    out = []
    syn = extras.get("synthesis")
    if isinstance(syn, Mapping):
        what, sized = ("lengths", "lengths") if "lengths" in syn else ("EI", "EI")
        ei = ", ".join(f"{k} {_g(v)}" for k, v in (syn.get(sized) or {}).items())
        out.append(
            f"synthesised {what}: {ei} ({syn.get('goal')} {_g(syn.get('achieved'))}, "
            f"target {_g(syn.get('target'))})"
        )
        fe = syn.get("fem-auto")
        fb = fe.get("bistable") if isinstance(fe, Mapping) else None
        if syn.get("goal") == "stable-position" and isinstance(fb, Mapping):
            second = (fb.get("stable") or [None, None])[-1] if fb.get("bistable") else None
            out.append(
                f"fem-auto on the synthesised scene: second stable position {_g(second)} "
                f"(target {_g(syn.get('target'))})"
            )
        elif isinstance(fe, Mapping):
            out.append(
                f"fem-auto on the synthesised scene: {_g(fe.get('achieved'))} "
                f"(error {_g(fe.get('relative_error'))} of the target)"
                if fe.get("status") == "converged"
                else f"fem-auto on the synthesised scene: {fe.get('status')}{_why(fe)}"
            )
    drivers = extras.get("drivers")
    if isinstance(drivers, list):  # a driver search: every candidate, and its FE re-solve
        ok = [d for d in drivers if isinstance(d, Mapping) and d.get("bistable")]
        out.append(f"driver search: bistable along {len(ok)} of {len(drivers)} candidates")
        for d in ok:
            fe = d.get("fem-auto") or {}
            check = (
                "fem-auto: " + _bistable(fe["bistable"])
                if isinstance(fe.get("bistable"), Mapping)
                else f"fem-auto {fe.get('status', 'not run')}{_why(fe)}"
            )
            out.append(f"driver {d.get('driver')}: {_bistable(d)}; {check}")
    b = extras.get("bistable")
    if isinstance(b, Mapping):
        if b.get("label"):
            out.append(f"shown: driver {b['label']}")
        out.append("bistable: " + _bistable(b))
        fe = b.get("fem-auto") or ((syn or {}).get("fem-auto") or {})
        if isinstance(fe.get("bistable"), Mapping):
            out.append("fem-auto: " + _bistable(fe["bistable"]))
    return out
