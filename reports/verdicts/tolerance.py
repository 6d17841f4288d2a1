"""Tolerances a user or a case gives: ``1%``, ``1e-3``, ``stage.uy=0.5%,stage.rot=abs:1e-4``.

A relative value is on the default yardstick (``error_rel`` of ``reports.verdicts.yardstick``: the
output's error over its own excursion along the reference path); ``abs:`` marks an absolute
value in the case's units (length, rad, force, ...).  ``%`` divides by 100.  A value without
an output name applies to every judged output; with names only, only those outputs are
judged.  A relative value must be a fraction below 1: ``--tol 1`` is refused (write ``1%`` or
``0.01``) because it would silently mean 100 %.  An output name may be a point (``stage``):
its displacement-vector error is judged.

A case's ``[[tolerances]]`` name the outputs its designer judges; ``for_case`` merges them
with what the user typed (a bare user value replaces the case's relative values, a named one
replaces or adds that output).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from reports.verdicts.yardstick import TRANSLATIONS

__all__ = ["Tolerance", "ToleranceError", "for_case", "judged_errors", "parse_tolerance", "pct"]
# the node quantities judged by default (.x/.y repeat .ux/.uy)
JUDGED = ("ux", "uy", "rot")


class ToleranceError(ValueError):
    """A ``--tol`` text that cannot be read (one-line message)."""


@dataclass(frozen=True)
class Tolerance:
    """Allowed path error: one relative value for every judged output and/or values per
    output key or point (relative in ``per_output``, absolute in ``absolute``).

    ``default`` None with named values judges only the named outputs; ``why`` holds where a
    named value comes from (a case's ``why`` or "user").
    """

    default: float | None = 0.01
    per_output: Mapping[str, float] = field(default_factory=dict)
    absolute: Mapping[str, float] = field(default_factory=dict)
    why: Mapping[str, str] = field(default_factory=dict)

    def of(self, key: str) -> float | None:
        """Relative tolerance of output ``key`` (None: not judged relatively)."""
        if key in self.absolute:
            return None
        return self.per_output.get(key, self.default)

    def named(self) -> list[str]:
        """Output keys and points with a value of their own, in the order given."""
        return list(dict.fromkeys([*self.per_output, *self.absolute]))

    def values(self) -> list[float]:
        """Every relative value (for ``*-auto`` targets)."""
        return [t for t in (self.default, *self.per_output.values()) if t is not None]

    def as_json(self) -> float | dict[str, Any]:
        """A float when one value applies everywhere, else ``{"*": default, key: value,
        key: {"abs": value}}``."""
        if not self.per_output and not self.absolute and self.default is not None:
            return self.default
        out: dict[str, Any] = {} if self.default is None else {"*": self.default}
        out.update(self.per_output)
        out.update({k: {"abs": v} for k, v in self.absolute.items()})
        return out

    def text(self) -> str:
        """Human form: ``1 %`` or ``stage.uy 0.5 %, stage.rot 0.0001 abs``."""
        parts = [] if self.default is None else [pct(self.default)]
        parts += [f"{k} {pct(v)}" for k, v in self.per_output.items()]
        parts += [f"{k} {v:.3g} abs" for k, v in self.absolute.items()]
        return ", ".join(parts)


def pct(x: float) -> str:
    """``0.01`` -> ``"1 %"``."""
    return f"{x * 100:.3g} %"


def _number(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ToleranceError(f"--tol: {what!r} is not a number (e.g. 1%, 1e-3)") from None
    if not (math.isfinite(v) and v > 0):
        raise ToleranceError(f"--tol: {what!r} must be a positive finite number")
    return v


def _value(text: str) -> tuple[float, bool]:
    """(value, absolute?) of one tolerance token."""
    t = text.strip()
    if t.startswith("abs:"):
        return _number(t[4:].strip(), t), True
    if t.endswith("%"):
        return _number(t[:-1].strip(), t) / 100.0, False
    v = _number(t, t)
    if v >= 1.0:
        raise ToleranceError(
            f"--tol: {t!r} would mean {v:.3g} x 100 %; write {t}% or {v / 100:g} "
            "(a fraction), or abs:VALUE for an absolute tolerance in case units"
        )
    return v, False


def parse_tolerance(text: str | float | Tolerance) -> Tolerance:
    """``"1%"``, ``"1e-3"``, ``"tip.uy=0.5%,tip.rot=abs:1e-3"`` or ``"1%,tip.rot=1e-3"``."""
    if isinstance(text, Tolerance):
        return text
    default, per, absolute = None, {}, {}
    for tok in (t for t in str(text).split(",") if t.strip()):
        if "=" in tok:
            key, _, val = tok.partition("=")
            key = key.strip()
            if not re.fullmatch(r"[A-Za-z0-9_.\-]+", key):
                raise ToleranceError(f"--tol: bad output name {key!r}")
            v, is_abs = _value(val)
            (absolute if is_abs else per)[key] = v
        elif default is not None:
            raise ToleranceError("--tol: more than one tolerance without an output name")
        else:
            default, is_abs = _value(tok)
            if is_abs:
                raise ToleranceError("--tol: an absolute tolerance needs an output name")
    if default is None and not per and not absolute:
        raise ToleranceError("--tol: empty tolerance")
    why = dict.fromkeys([*per, *absolute], "user")
    return Tolerance(default, per, absolute, why)


def for_case(case_tolerances: Sequence[Any], user: str | float | Tolerance | None) -> Tolerance:
    """The tolerance to judge a case by: the case's ``[[tolerances]]`` (objects or dicts with
    ``output``, ``rel`` / ``abs``, ``why``) merged with the user's (None: the case's own, or
    1 % when the case names none)."""
    user_tol = None if user is None else parse_tolerance(user)
    if not case_tolerances:
        return user_tol or Tolerance()
    per, absolute, why = {}, {}, {}
    for t in case_tolerances:
        get = t.get if isinstance(t, Mapping) else lambda k, t=t: getattr(t, k)
        if get("abs") is not None:
            absolute[get("output")] = float(get("abs"))
        else:
            per[get("output")] = float(get("rel"))
        why[get("output")] = get("why")
    if user_tol is not None:
        if user_tol.default is not None:
            per = dict.fromkeys(per, user_tol.default)
        for k, v in user_tol.per_output.items():
            absolute.pop(k, None)
            per[k], why[k] = v, "user"
        for k, v in user_tol.absolute.items():
            per.pop(k, None)
            absolute[k], why[k] = v, "user"
    return Tolerance(None, per, absolute, why)


def judged_errors(pe: Mapping[str, Any], tol: Tolerance) -> list[tuple[float, str, float, float]]:
    """(error / tolerance, key, error, tolerance) of every judged output of path errors
    ``pe``: the outputs ``tol`` names (a point: its displacement-vector error; ``abs:``
    values against ``per_output_abs``) and, with a default, every point's ``.ux .uy .rot``,
    the load factor of a path analysis and any non-node output.  A named output the model
    cannot be compared on counts as an infinite error."""
    judged = []
    for key in tol.named():
        if key in tol.absolute:
            err, t = pe["per_output_abs"].get(key), tol.absolute[key]
        else:
            err, t = pe["per_point"].get(key, pe["per_output"].get(key)), tol.per_output[key]
        e = math.inf if err is None else err
        judged.append((e / t, key, e, t))
    if tol.default is None:
        return judged
    for key, err in pe["per_output"].items():
        q = key.rsplit(".", 1)[-1]
        node_key = q in TRANSLATIONS or q == "rot"
        if key in tol.named() or (node_key and q not in JUDGED):
            continue  # named above; .x/.y repeat .ux/.uy
        if key == "factor" and pe["abscissa"] == "factor":
            continue
        e = math.inf if err is None else err
        judged.append((e / tol.default, key, e, tol.default))
    return judged
