"""Declared model options: names, types and ranges, checked before a model is built.

Each model class declares ``OPTIONS: dict[str, Option]`` (or plain tuples
``(kind, lo, hi, choices, doc)``) next to its code;
``registry.build`` calls ``validate`` with the options a case (``[[models]] options``) or a
caller passes, so an unknown name, a wrong type or a value out of range is a one-line
``OptionError`` (a ``ValueError``; the CLI prints it with the case file and exits 2) instead
of a silently different judge (``fem-auto`` with ``rtol = 1e10`` converged 37 % off).
A class without ``OPTIONS`` is not checked here (its constructor still rejects unknown
keyword arguments).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass


class OptionError(ValueError):
    """An option a model does not declare, or a value outside its declared type/range."""


@dataclass(frozen=True)
class Option:
    """One declared option.

    kind : ``"float"``, ``"int"``, ``"bool"``, ``"str"``, ``"ints"`` (list of positive
        integers, strictly increasing), ``"floats"`` (list of finite numbers) or ``"matrix"``
        (list of lists of numbers; the model checks the shape).
    lo, hi : inclusive bounds for numbers (None: unbounded; numbers must be finite).
    choices : allowed strings.
    doc : what it sets (shown in error messages).
    """

    kind: str
    lo: float | None = None
    hi: float | None = None
    choices: tuple[str, ...] = ()
    doc: str = ""

    def check(self, key: str, v: object) -> str | None:
        """None if ``v`` is acceptable, else why not."""
        if self.kind == "bool":
            return None if isinstance(v, bool) else f"must be true or false, got {v!r}"
        if self.kind == "str":
            if not isinstance(v, str):
                return f"must be a string, got {v!r}"
            if self.choices and v not in self.choices:
                return f"must be one of {list(self.choices)}, got {v!r}"
            return None
        if self.kind in ("int", "float"):
            return self._number(v, self.kind == "int")
        if not isinstance(v, (list, tuple)) or not v:
            return f"must be a non-empty list, got {v!r}"
        if self.kind == "ints":
            bad = [x for x in v if self._number(x, True)]
            if bad:
                return f"entries: {self._number(bad[0], True)}"
            if any(b <= a for a, b in zip(v[:-1], v[1:])):
                return f"must be strictly increasing, got {list(v)}"
            return None
        rows = v if self.kind == "matrix" else [v]
        for row in rows:
            if not isinstance(row, (list, tuple)):
                return f"must be a list of lists of numbers, got {row!r}"
            for x in row:
                if isinstance(x, bool) or not isinstance(x, (int, float)):
                    return f"entries must be numbers, got {x!r}"
                if self.kind == "floats" and not math.isfinite(x):
                    return f"entries must be finite, got {x!r}"
        return None

    def _number(self, v: object, integer: bool) -> str | None:
        what = "an integer" if integer else "a number"
        if isinstance(v, bool) or not isinstance(v, int if integer else (int, float)):
            return f"must be {what}, got {v!r}"
        if not math.isfinite(v):
            return f"must be finite, got {v!r}"
        if (self.lo is not None and v < self.lo) or (self.hi is not None and v > self.hi):
            lo = "-inf" if self.lo is None else f"{self.lo:g}"
            hi = "inf" if self.hi is None else f"{self.hi:g}"
            return f"must be in [{lo}, {hi}], got {v!r}"
        return None


def validate(model: str, declared: Mapping[str, Option], options: Mapping[str, object]) -> None:
    """Raise ``OptionError`` (one line naming model, option and reason) on the first bad
    option."""
    for key, v in options.items():
        spec = declared.get(key)
        if isinstance(spec, tuple):  # (kind, lo, hi, choices, doc): packages that do not
            spec = Option(*spec)  # import this module (the FE reference) declare plain tuples
        if spec is None:
            known = ", ".join(sorted(declared)) or "none"
            raise OptionError(f"model {model!r}: unknown option {key!r} (declared: {known})")
        why = spec.check(key, v)
        if why:
            doc = f" ({spec.doc})" if spec.doc else ""
            raise OptionError(f"model {model!r}: option {key!r}{doc} {why}")


SHAPES = {"shapes": Option("bool", doc="compute deformed shapes and stress")}
