"""Tolerances a user gives: ``1%``, ``1e-3``, ``tip.uy=0.5%,tip.rot=1e-3``.

Values are path errors as the report measures them (translations divided by the case's
length L, rotations in rad); ``%`` divides by 100.  A value without an output name applies to
every judged output; with names only, only those outputs are judged.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["Tolerance", "ToleranceError", "parse_tolerance", "pct"]


class ToleranceError(ValueError):
    """A ``--tol`` text that cannot be read (one-line message)."""


@dataclass(frozen=True)
class Tolerance:
    """Allowed path error: one value for every judged output and/or values per output key.

    ``default`` None with ``per_output`` given judges only the named outputs.
    """

    default: float | None = 0.01
    per_output: Mapping[str, float] = field(default_factory=dict)

    def of(self, key: str) -> float | None:
        """Tolerance of output ``key`` (None: not judged)."""
        return self.per_output.get(key, self.default)

    def as_json(self) -> float | dict[str, float]:
        """A float when one value applies everywhere, else ``{"*": default, key: value}``."""
        if not self.per_output and self.default is not None:
            return self.default
        out = {} if self.default is None else {"*": self.default}
        return {**out, **self.per_output}

    def text(self) -> str:
        """Human form: ``1 %`` or ``tip.uy 0.5 %, tip.rot 0.1 %``."""
        parts = [] if self.default is None else [pct(self.default)]
        parts += [f"{k} {pct(v)}" for k, v in self.per_output.items()]
        return ", ".join(parts)


def pct(x: float) -> str:
    """``0.01`` -> ``"1 %"``."""
    return f"{x * 100:.3g} %"


def _value(text: str) -> float:
    t = text.strip()
    scale = 1.0
    if t.endswith("%"):
        t, scale = t[:-1].strip(), 0.01
    try:
        v = float(t) * scale
    except ValueError:
        raise ToleranceError(f"--tol: {text.strip()!r} is not a number (e.g. 1%, 1e-3)") from None
    if not (math.isfinite(v) and v > 0):
        raise ToleranceError(f"--tol: {text.strip()!r} must be a positive finite number")
    return v


def parse_tolerance(text: str | float | Tolerance) -> Tolerance:
    """``"1%"``, ``"1e-3"``, ``"tip.uy=0.5%,tip.rot=1e-3"`` or ``"1%,tip.rot=1e-3"``."""
    if isinstance(text, Tolerance):
        return text
    if isinstance(text, (int, float)):
        return Tolerance(_value(str(text)))
    default, per = None, {}
    for tok in (t for t in str(text).split(",") if t.strip()):
        if "=" in tok:
            key, _, val = tok.partition("=")
            key = key.strip()
            if not re.fullmatch(r"[A-Za-z0-9_.\-]+", key):
                raise ToleranceError(f"--tol: bad output name {key!r}")
            per[key] = _value(val)
        elif default is not None:
            raise ToleranceError("--tol: more than one tolerance without an output name")
        else:
            default = _value(tok)
    if default is None and not per:
        raise ToleranceError("--tol: empty tolerance")
    return Tolerance(default, per)
