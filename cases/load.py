"""TOML case file -> validated, frozen ``Scene``.

Every mistake a user can make raises ``CaseError("FILE: KEY: reason")`` with the key written
as a path (``members[2].E``), so the CLI can print one line and exit 2.

This module holds the entry points and the builder's core (the ``[case]`` table and the order
the parts are read in); each part of the scene is read by its own module: the primitive checks
(``load_checks``), members and what acts on them (``load_members``), mechanism parts and
whole-structure checks (``load_mechanism``), analysis and judgement (``load_analysis``).
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from cases import limits
from cases.load_analysis import EXTRA_OUTPUTS, AnalysisPart
from cases.load_checks import CaseError
from cases.load_mechanism import MechanismPart
from cases.load_members import MembersPart
from cases.schema import UNITS, Scene

__all__ = ["CATALOG", "EXTRA_OUTPUTS", "CaseError", "catalog_names", "load", "loads", "resolve"]

CATALOG = Path(__file__).parent / "catalog"
_NAME = re.compile(r"^[a-z0-9]+(-[a-z0-9]+)*$")


def catalog_names() -> list[str]:
    """Names of the catalog cases, sorted."""
    return sorted(p.stem for p in CATALOG.glob("*.toml"))


def resolve(name_or_path: str | Path) -> Path:
    """Catalog name or path -> path of the TOML file (CaseError if neither exists)."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            raise CaseError(f"{p}: (file): no such case file")
        return p
    cand = CATALOG / f"{name_or_path}.toml"
    if cand.is_file():
        return cand
    raise CaseError(f"{name_or_path}: (case): not a catalog case or a file (see `flexbench cases`)")


def load(name_or_path: str | Path) -> Scene:
    """Load and validate a case from the catalog (by name) or from a path."""
    path = resolve(name_or_path)
    try:
        if path.stat().st_size > limits.MAX_FILE_BYTES:  # before reading it all into memory
            size = path.stat().st_size
            raise CaseError(
                f"{path}: (file): {size} bytes exceeds the limit of {limits.MAX_FILE_BYTES}"
            )
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CaseError(f"{path}: (file): cannot read: {exc}") from None
    return loads(text, source=str(path))


def loads(text: str, source: str = "<string>") -> Scene:
    """Parse and validate case TOML text; ``source`` names the file in errors."""

    def fail(key: str, reason: str) -> CaseError:
        return CaseError(f"{source}: {key}: {reason}")

    limits.check_size(text, fail)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CaseError(f"{source}: (toml): {exc}") from None
    except RecursionError:  # tomllib recurses once per nesting level
        raise fail("(toml)", f"nested deeper than the limit of {limits.MAX_DEPTH} levels") from None
    limits.check_tree(data, fail)
    return _Builder(data, source).scene()


class _Builder(MembersPart, MechanismPart, AnalysisPart):
    """Walks the TOML tree once, checking every key, and builds the Scene: the parts of the
    scene are read by ``MembersPart``, ``MechanismPart`` and ``AnalysisPart``."""

    TOP = (
        "case",
        "nodes",
        "members",
        "supports",
        "torsion_springs",
        "loads",
        "analysis",
        "outputs",
        "references",
        "tolerances",
        "models",
        "booms",
    )

    def scene(self) -> Scene:
        for k in self.data:
            if k not in self.TOP:
                raise self.fail(k, f"unknown table (allowed: {', '.join(self.TOP)})")
        case = (
            self.keys(
                self.data.get("case"),
                "case",
                ("name", "title", "units", "tags", "description", "reference_model"),
                ("name", "title", "units"),
            )
            if "case" in self.data
            else None
        )
        if case is None:
            raise self.fail("case", "missing required table [case]")
        name = self.str_(case, "name", "case")
        if not _NAME.match(name):
            raise self.fail("case.name", f"{name!r} is not kebab-case (a-z, 0-9, '-')")
        units = self.str_(case, "units", "case", choices=tuple(UNITS))
        tags = case.get("tags", [])
        if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
            raise self.fail("case.tags", "must be an array of strings")
        nodes = self.nodes()
        node_ids = {n.id for n in nodes}
        members = self.members(nodes)
        supports = self.supports(node_ids)
        springs = self.torsion_springs(node_ids, members)
        loads = self.loads(node_ids, members)
        self._members, self._loads = members, loads
        outputs = self.outputs(node_ids)
        booms = self.booms(node_ids, supports)
        analysis = self.analysis(node_ids, {m.id for m in members}, outputs)
        if analysis.kind == "path" and analysis.driver is None:
            if not any(ld.fx or ld.fy or ld.moment for ld in loads):
                raise self.fail("loads", "a 'path' analysis needs a nonzero load to trace")
        references = self.references(outputs, booms)
        tolerances = self.tolerances(outputs, booms)
        models = self.models()
        scene = Scene(
            name=name,
            title=self.str_(case, "title", "case"),
            units=units,
            nodes=nodes,
            members=members,
            supports=supports,
            loads=loads,
            analysis=analysis,
            outputs=outputs,
            torsion_springs=springs,
            references=references,
            tolerances=tolerances,
            models=models,
            tags=tuple(tags),
            description=self.str_(case, "description", "case", default="") or "",
            reference_model=self.str_(case, "reference_model", "case"),
            path=self.src,
            booms=booms,
        )
        scene = self.resolve_rest_angles(scene)
        self.check_analysis_needs(scene)
        self.check_connected(scene)
        self.check_restrained(scene)
        return scene
