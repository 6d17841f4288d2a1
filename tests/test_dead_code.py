"""No dead code: vulture at confidence 60 finds nothing in the four packages.

Confidence 60 is vulture's level for unused functions, classes, methods, properties and
attributes (80 and above only reach unused imports and locals, which ruff already checks), so
this is the level that keeps a forgotten helper from lingering.  The tests are scanned too, as
*users*: code a test calls (a verification helper) is not dead.  Genuine false positives
(names used through strings, ``__dict__`` or in-place arguments) are listed with their reason
in ``.ci/vulture_whitelist.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

vulture = pytest.importorskip("vulture", reason="vulture is in the `test` extra")

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("cases", "reduced_models", "fem_reference", "reports")
WHITELIST = ROOT / ".ci" / "vulture_whitelist.py"
CONFIDENCE = 60


def dead_code(extra: list[Path] = ()) -> list[str]:
    """vulture's findings in the packages (and in ``extra`` files), as ``path:line: message``."""
    v = vulture.Vulture()
    v.scavenge(
        [str(ROOT / p) for p in (*PACKAGES, "tests")] + [str(WHITELIST)] + list(map(str, extra))
    )
    roots = [ROOT / p for p in PACKAGES] + [Path(e).parent for e in extra]
    found = []
    for item in v.get_unused_code(min_confidence=CONFIDENCE):
        path = Path(item.filename)
        if any(path.is_relative_to(r) for r in roots):
            where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
            found.append(f"{where}:{item.first_lineno}: {item.message} ({item.confidence}%)")
    return found


def test_no_dead_code():
    found = dead_code()
    assert not found, (
        "dead code (or add a true false positive to .ci/vulture_whitelist.py):\n" + "\n".join(found)
    )


def test_a_planted_dead_function_is_found(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text("def never_called_helper():\n    return 1\n")
    assert any("never_called_helper" in line for line in dead_code([planted]))
