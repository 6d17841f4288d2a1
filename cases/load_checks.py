"""The case loader's primitive checks: one key of one table, each failure a ``CaseError``
naming the file, the key (as a path, ``members[2].E``) and the reason.

``Checks`` is the base of the loader's builder (``cases.load``); the parts of the scene
(``cases.load_members``, ``cases.load_mechanism``, ``cases.load_analysis``) build on it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cases import limits


class CaseError(ValueError):
    """A case file that cannot be used; the message is ``FILE: KEY: reason``."""


class Checks:
    """The TOML tree of one case file and the checks every part of the builder uses."""

    def __init__(self, data: dict[str, Any], source: str) -> None:
        self.data = data
        self.src = source

    def fail(self, key: str, reason: str) -> CaseError:
        return CaseError(f"{self.src}: {key}: {reason}")

    def keys(
        self, table: Any, key: str, allowed: tuple[str, ...], required: tuple[str, ...]
    ) -> dict[str, Any]:
        if not isinstance(table, dict):
            raise self.fail(key, "must be a table")
        for k in table:
            if k not in allowed:
                raise self.fail(f"{key}.{k}", f"unknown key (allowed: {', '.join(allowed)})")
        for k in required:
            if k not in table:
                raise self.fail(f"{key}.{k}", "missing required key")
        return table

    def array(self, name: str, required: bool = True) -> list[dict[str, Any]]:
        items = self.data.get(name, [])
        if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
            raise self.fail(name, "must be an array of tables ([[" + name + "]])")
        if required and not items:
            raise self.fail(name, "missing: at least one entry is required")
        return items

    def num(
        self,
        table: dict,
        key: str,
        path: str,
        default: float | None = None,
        *,
        positive: bool = False,
        nonneg: bool = False,
    ) -> float | None:
        if key not in table:
            return default
        v = table[key]
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise self.fail(f"{path}.{key}", f"must be a number, got {type(v).__name__}")
        limits.check_number(v, f"{path}.{key}", self.fail)
        v = float(v)
        if positive and v <= 0:
            raise self.fail(f"{path}.{key}", f"must be > 0, got {v:g}")
        if nonneg and v < 0:
            raise self.fail(f"{path}.{key}", f"must be >= 0, got {v:g}")
        return v

    def int_(self, table: dict, key: str, path: str, default: int, lo: int = 1) -> int:
        if key not in table:
            return default
        v = table[key]
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(f"{path}.{key}", "must be an integer")
        if v < lo:
            raise self.fail(f"{path}.{key}", f"must be >= {lo}, got {v}")
        if key.endswith("steps"):
            limits.check_steps(v, f"{path}.{key}", self.fail)
        return v

    def str_(
        self,
        table: dict,
        key: str,
        path: str,
        default: str | None = None,
        choices: tuple[str, ...] | None = None,
    ) -> str | None:
        if key not in table:
            return default
        v = table[key]
        if not isinstance(v, str) or not v.strip():
            raise self.fail(f"{path}.{key}", "must be a non-empty string")
        if choices is not None and v not in choices:
            raise self.fail(f"{path}.{key}", f"unknown value {v!r} (one of: {', '.join(choices)})")
        return v

    def bool_(self, table: dict, key: str, path: str, default: bool = False) -> bool:
        v = table.get(key, default)
        if not isinstance(v, bool):
            raise self.fail(f"{path}.{key}", "must be true or false")
        return v

    def unique(self, ids: list[str], path: str) -> None:
        seen: set[str] = set()
        for i, x in enumerate(ids):
            if x in seen:
                raise self.fail(f"{path}[{i}].id", f"duplicate id {x!r}")
            seen.add(x)


def check_finite(obj: Any, path: str, fail: Callable[[str, str], CaseError]) -> None:
    """Numbers hidden in nested model options: finite and in range (iterative, linear)."""
    limits.check_tree({path: obj}, fail)
