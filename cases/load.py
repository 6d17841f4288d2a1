"""TOML case file -> validated, frozen ``Scene``.

Every mistake a user can make raises ``CaseError("FILE: KEY: reason")`` with the key written
as a path (``members[2].E``), so the CLI can print one line and exit 2.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from cases import limits
from cases.arc import MAX_SWEEP_DEG
from cases.schema import (
    ANALYSIS_KINDS,
    END_KINDS,
    MEMBER_KINDS,
    MEMBER_MODEL,
    NODE_QUANTITIES,
    REFERENCE_KINDS,
    SUPPORT_TYPES,
    SWEEP_OF_KINDS,
    SYNTHESIS_GOALS,
    UNITS,
    Analysis,
    Boom,
    DesignTolerance,
    Driver,
    GridAxis,
    Load,
    MechanicalAdvantage,
    Member,
    ModelSpec,
    Node,
    Output,
    Reference,
    Scene,
    Support,
    Synthesis,
    TorsionSpring,
)
from cases.sweep import POSITIVE, free_from_rest, key_error

CATALOG = Path(__file__).parent / "catalog"
_NAME = re.compile(r"^[a-z0-9]+(-[a-z0-9]+)*$")
# outputs that are not node quantities but may carry references
EXTRA_OUTPUTS = (
    "factor",
    "factor.max",  # the largest load factor along the path (a limit load)
    "factor.min",  # the smallest load factor along the path (e.g. a second limit load)
    "energy",
    "driver.force",
    "driver.torque",
    "max_stress",
    "ma",  # mechanical advantage ([analysis.ma])
)


class CaseError(ValueError):
    """A case file that cannot be used; the message is ``FILE: KEY: reason``."""


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


class _Builder:
    """Walks the TOML tree once, checking every key, and builds the Scene."""

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

    def __init__(self, data: dict[str, Any], source: str) -> None:
        self.data = data
        self.src = source

    # -- primitive checks ------------------------------------------------------------------
    def fail(self, key: str, reason: str) -> CaseError:
        return CaseError(f"{self.src}: {key}: {reason}")

    def keys(self, table: Any, key: str, allowed: tuple[str, ...], required: tuple[str, ...]):
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

    # -- tables ----------------------------------------------------------------------------
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

    def nodes(self) -> tuple[Node, ...]:
        out = []
        for i, t in enumerate(self.array("nodes")):
            p = f"nodes[{i}]"
            self.keys(t, p, ("id", "x", "y"), ("id", "x", "y"))
            out.append(Node(self.str_(t, "id", p), self.num(t, "x", p), self.num(t, "y", p)))
        self.unique([n.id for n in out], "nodes")
        return tuple(out)

    def members(self, nodes: tuple[Node, ...]) -> tuple[Member, ...]:
        where = {n.id: n for n in nodes}
        out = []
        allowed = (
            "id",
            "from",
            "to",
            "kind",
            "E",
            "I",
            "A",
            "width",
            "thickness",
            "end_a",
            "end_b",
            "k",
            "free_length",
            "density",
            "sweep_deg",
            "model",
            "model_options",
        )
        for i, t in enumerate(self.array("members")):
            p = f"members[{i}]"
            self.keys(t, p, allowed, ("id", "from", "to"))
            a, b = self.str_(t, "from", p), self.str_(t, "to", p)
            for key, nid in (("from", a), ("to", b)):
                if nid not in where:
                    raise self.fail(f"{p}.{key}", f"unknown node {nid!r}")
            if a == b:
                raise self.fail(f"{p}.to", "a member must join two different nodes")
            na, nb = where[a], where[b]
            length = math.hypot(nb.x - na.x, nb.y - na.y)
            if length <= 1e-12 * max(1.0, abs(na.x), abs(na.y)):
                raise self.fail(f"{p}.to", f"zero-length member ({a} and {b} coincide)")
            kind = self.str_(t, "kind", p, default="flexible", choices=MEMBER_KINDS)
            E = self.num(t, "E", p, positive=True)
            I = self.num(t, "I", p, positive=True)
            A = self.num(t, "A", p, positive=True)
            width = self.num(t, "width", p, positive=True)
            thick = self.num(t, "thickness", p, positive=True)
            if width is not None and thick is not None:
                I = width * thick**3 / 12.0 if I is None else I
                A = width * thick if A is None else A
            k = self.num(t, "k", p, positive=True)
            if kind == "flexible":
                if E is None:
                    raise self.fail(f"{p}.E", "missing: a flexible member needs E")
                if I is None:
                    raise self.fail(f"{p}.I", "missing: give I (and A) or width and thickness")
                if A is None:
                    raise self.fail(f"{p}.A", "missing: give A or width and thickness")
            if kind == "spring" and k is None:
                raise self.fail(f"{p}.k", "missing: a spring member needs stiffness k > 0")
            if kind != "spring" and k is not None:
                raise self.fail(f"{p}.k", f"only spring members take k (kind is {kind!r})")
            sweep = self.num(t, "sweep_deg", p, default=0.0)
            if sweep and kind != "flexible":
                raise self.fail(f"{p}.sweep_deg", f"only flexible members are arcs (kind {kind!r})")
            if abs(sweep) > MAX_SWEEP_DEG:
                raise self.fail(f"{p}.sweep_deg", f"|sweep_deg| must be <= {MAX_SWEEP_DEG:g}")
            model, model_options = self.member_model(t, p, kind)
            out.append(
                Member(
                    id=self.str_(t, "id", p),
                    a=a,
                    b=b,
                    kind=kind,
                    E=E,
                    I=I,
                    A=A,
                    thickness=thick,
                    width=width,
                    end_a=self.str_(t, "end_a", p, default="weld", choices=END_KINDS),
                    end_b=self.str_(t, "end_b", p, default="weld", choices=END_KINDS),
                    k=k,
                    free_length=self.num(t, "free_length", p, nonneg=True),
                    density=self.num(t, "density", p, positive=True),
                    sweep_deg=sweep,
                    model=model,
                    model_options=model_options,
                )
            )
        self.unique([m.id for m in out], "members")
        return tuple(out)

    def member_model(self, t: dict, p: str, kind: str) -> tuple[str | None, dict]:
        """Per-member model assignment (``model``, ``model_options``) of a flexible member."""
        model = self.str_(t, "model", p)
        opts = t.get("model_options", {})
        if model is not None and kind != "flexible":
            raise self.fail(f"{p}.model", f"only flexible members take a model (kind is {kind!r})")
        if model is not None and not re.match(MEMBER_MODEL, model):
            raise self.fail(
                f"{p}.model",
                f"{model!r} is not a reduced beam model (elastica, bcm, cbcm-N, linear-N, "
                "prb-short, prb-1r, prb-2r, prb-3r, prb-2rpr, prb-fsm-N, prb-custom)",
            )
        if not isinstance(opts, dict):
            raise self.fail(f"{p}.model_options", "must be a table")
        if opts and model is None:
            raise self.fail(f"{p}.model_options", "model_options need model")
        _check_finite(opts, f"{p}.model_options", self.fail)
        return model, dict(opts)

    def supports(self, node_ids: set[str]) -> tuple[Support, ...]:
        out, supported = [], set()
        for i, t in enumerate(self.array("supports", required=False)):
            p = f"supports[{i}]"
            self.keys(t, p, ("node", "type", "angle_deg"), ("node", "type"))
            node = self.str_(t, "node", p)
            if node not in node_ids:
                raise self.fail(f"{p}.node", f"unknown node {node!r}")
            if node in supported:
                raise self.fail(f"{p}.node", f"node {node!r} already has a support")
            supported.add(node)
            typ = self.str_(t, "type", p, choices=SUPPORT_TYPES)
            if "angle_deg" in t and typ not in ("slider",):
                raise self.fail(f"{p}.angle_deg", "only a slider takes angle_deg")
            out.append(Support(node, typ, self.num(t, "angle_deg", p, default=0.0)))
        if not out:
            raise self.fail("supports", "missing: the structure needs supports (rigid-body motion)")
        return tuple(out)

    def torsion_springs(self, node_ids: set[str], members: tuple[Member, ...]):
        by_id = {m.id: m for m in members}
        out = []
        for i, t in enumerate(self.array("torsion_springs", required=False)):
            p = f"torsion_springs[{i}]"
            self.keys(
                t,
                p,
                ("id", "node", "member_a", "member_b", "stiffness", "free_angle_deg")
                + ("rest_angle_deg",),
                ("id", "node", "member_a", "stiffness"),
            )
            node = self.str_(t, "node", p)
            if node not in node_ids:
                raise self.fail(f"{p}.node", f"unknown node {node!r}")
            names = [self.str_(t, "member_a", p), self.str_(t, "member_b", p)]
            for key, mid in zip(("member_a", "member_b"), names):
                if mid is None:
                    continue
                if mid not in by_id:
                    raise self.fail(f"{p}.{key}", f"unknown member {mid!r}")
                if node not in (by_id[mid].a, by_id[mid].b):
                    raise self.fail(f"{p}.{key}", f"member {mid!r} does not end at node {node!r}")
            if names[0] == names[1]:
                raise self.fail(f"{p}.member_b", "a torsion spring joins two different members")
            if "free_angle_deg" in t and "rest_angle_deg" in t:
                raise self.fail(f"{p}.rest_angle_deg", "give free_angle_deg or rest_angle_deg")
            out.append(
                TorsionSpring(
                    id=self.str_(t, "id", p),
                    node=node,
                    member_a=names[0],
                    member_b=names[1],
                    stiffness=self.num(t, "stiffness", p, positive=True),
                    free_angle_deg=self.num(t, "free_angle_deg", p, default=0.0),
                    rest_angle_deg=self.num(t, "rest_angle_deg", p),
                )
            )
        self.unique([s.id for s in out], "torsion_springs")
        return tuple(out)

    def loads(self, node_ids: set[str], members: tuple[Member, ...]) -> tuple[Load, ...]:
        mids = {m.id for m in members}
        out = []
        allowed = ("id", "node", "member", "fraction", "fx", "fy", "moment", "follower")
        for i, t in enumerate(self.array("loads", required=False)):
            p = f"loads[{i}]"
            self.keys(t, p, allowed, ())
            node, member = self.str_(t, "node", p), self.str_(t, "member", p)
            if (node is None) == (member is None):
                raise self.fail(f"{p}.node", "give exactly one of node or member (+ fraction)")
            if node is not None and node not in node_ids:
                raise self.fail(f"{p}.node", f"unknown node {node!r}")
            frac = self.num(t, "fraction", p)
            if member is not None:
                if member not in mids:
                    raise self.fail(f"{p}.member", f"unknown member {member!r}")
                if frac is None:
                    raise self.fail(f"{p}.fraction", "missing: a member load needs fraction")
                if not 0.0 <= frac <= 1.0:
                    raise self.fail(f"{p}.fraction", f"must be in [0, 1], got {frac:g}")
            elif frac is not None:
                raise self.fail(f"{p}.fraction", "fraction only goes with member")
            out.append(
                Load(
                    id=self.str_(t, "id", p, default=f"load{i}"),
                    fx=self.num(t, "fx", p, default=0.0),
                    fy=self.num(t, "fy", p, default=0.0),
                    moment=self.num(t, "moment", p, default=0.0),
                    node=node,
                    member=member,
                    fraction=frac,
                    follower=self.bool_(t, "follower", p),
                )
            )
        self.unique([ld.id for ld in out], "loads")
        return tuple(out)

    def outputs(self, node_ids: set[str]) -> tuple[Output, ...]:
        out, names = [], set()
        for i, t in enumerate(self.array("outputs")):
            p = f"outputs[{i}]"
            self.keys(t, p, ("name", "node"), ("name", "node"))
            name, node = self.str_(t, "name", p), self.str_(t, "node", p)
            if node not in node_ids:
                raise self.fail(f"{p}.node", f"unknown node {node!r}")
            if not re.match(r"^[A-Za-z_][A-Za-z0-9_-]*$", name):
                raise self.fail(f"{p}.name", f"{name!r}: letters, digits, '_' or '-' only")
            if name in names:
                raise self.fail(f"{p}.name", f"duplicate output name {name!r}")
            names.add(name)
            out.append(Output(name, node))
        return tuple(out)

    def analysis(self, node_ids: set[str], member_ids: set[str], outputs: tuple[Output, ...]):
        p = "analysis"
        t = self.keys(
            self.data.get("analysis", {"kind": "load"}),
            p,
            (
                "kind",
                "steps",
                "factor_end",
                "stop_output",
                "stop_value",
                "max_steps",
                "driver",
                "sweep_key",
                "sweep_values",
                "sweep_of",
                "grid",
                "mobility",
                "synthesis",
                "ma",
            ),
            ("kind",),
        )
        kind = self.str_(t, "kind", p, choices=ANALYSIS_KINDS)
        keys = {f"{o.name}.{q}" for o in outputs for q in NODE_QUANTITIES}
        stop_output = self.str_(t, "stop_output", p)
        if stop_output is not None and stop_output not in keys:
            raise self.fail(f"{p}.stop_output", f"{stop_output!r} is not an output key")
        stop_value = self.num(t, "stop_value", p)
        if (stop_output is None) != (stop_value is None):
            raise self.fail(f"{p}.stop_value", "stop_output and stop_value go together")
        driver = None
        if "driver" in t:
            d = self.keys(
                t["driver"],
                f"{p}.driver",
                ("kind", "node", "direction", "member", "start", "stop"),
                ("kind", "start", "stop"),
            )
            dk = self.str_(d, "kind", f"{p}.driver", choices=("displacement", "rotation"))
            node, member = (
                self.str_(d, "node", f"{p}.driver"),
                self.str_(d, "member", f"{p}.driver"),
            )
            direction = self.str_(d, "direction", f"{p}.driver", choices=("x", "y"))
            if dk == "displacement" and (node not in node_ids or direction is None):
                raise self.fail(
                    f"{p}.driver.node", "a displacement driver needs a known node and direction x|y"
                )
            if dk == "rotation" and member not in member_ids:
                raise self.fail(f"{p}.driver.member", "a rotation driver needs a known member")
            driver = Driver(
                dk,
                self.num(d, "start", f"{p}.driver"),
                self.num(d, "stop", f"{p}.driver"),
                node,
                direction,
                member,
            )
        if kind in ("distance", "energy", "kinematics") and driver is None:
            raise self.fail(f"{p}.driver", f"missing: a {kind!r} analysis needs a driver")
        sweep_values = t.get("sweep_values", [])
        if not isinstance(sweep_values, list) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in sweep_values
        ):
            raise self.fail(f"{p}.sweep_values", "must be an array of finite numbers")
        grid = self.grid(t, p)
        if "sweep_key" in t and sweep_values:
            grid = (GridAxis((self.str_(t, "sweep_key", p),), tuple(map(float, sweep_values))),)
            grid += self.grid(t, p)
        if kind == "sweep" and not grid:
            raise self.fail(f"{p}.grid", "a sweep needs [[analysis.grid]] (or sweep_key/values)")
        if kind != "sweep" and grid:
            raise self.fail(f"{p}.grid", f"only a sweep takes a grid (kind is {kind!r})")
        points = math.prod(len(ax.values) for ax in grid)
        if points > limits.MAX_GRID_POINTS:
            raise self.fail(
                f"{p}.grid", f"{points} sweep scenes exceed the limit of {limits.MAX_GRID_POINTS}"
            )
        # a path traced to a stop output goes on until it gets there (DESIGN.md): no bound
        factor_end = self.num(t, "factor_end", p, default=math.inf if stop_output else 1.0)
        if kind in ("load", "path") and factor_end <= 0:
            raise self.fail(
                f"{p}.factor_end",
                f"must be > 0 for a {kind!r} analysis (the load factor rises from 0), got "
                f"{factor_end:g}; reverse the loads to load the other way",
            )
        return Analysis(
            kind=kind,
            steps=self.int_(t, "steps", p, 20),
            factor_end=factor_end,
            stop_output=stop_output,
            stop_value=stop_value,
            max_steps=self.int_(t, "max_steps", p, 400),
            driver=driver,
            sweep_key=self.str_(t, "sweep_key", p),
            sweep_values=tuple(float(v) for v in sweep_values),
            grid=grid,
            sweep_of=self.str_(t, "sweep_of", p, default="load", choices=SWEEP_OF_KINDS),
            mobility=self.int_(t, "mobility", p, None, lo=0),
            synthesis=self.synthesis(t, kind, driver, keys),
            ma=self.ma(t, driver, outputs),
        )

    def grid(self, t: dict, p: str) -> tuple[GridAxis, ...]:
        """``[[analysis.grid]]``: axes of ``key`` (or ``keys``, set together) and ``values``."""
        items = t.get("grid", [])
        if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
            raise self.fail(f"{p}.grid", "must be an array of tables ([[analysis.grid]])")
        out = []
        for i, ax in enumerate(items):
            q = f"{p}.grid[{i}]"
            self.keys(ax, q, ("key", "keys", "values"), ("values",))
            if ("key" in ax) == ("keys" in ax):
                raise self.fail(f"{q}.key", "give exactly one of key or keys")
            keys = [ax["key"]] if "key" in ax else ax["keys"]
            if (
                not isinstance(keys, list)
                or not keys
                or not all(isinstance(k, str) and k for k in keys)
            ):
                raise self.fail(f"{q}.keys", "must be a non-empty array of scene keys")
            vals = ax["values"]
            if (
                not isinstance(vals, list)
                or not vals
                or not all(
                    isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                    for v in vals
                )
            ):
                raise self.fail(f"{q}.values", "must be a non-empty array of finite numbers")
            out.append(GridAxis(tuple(keys), tuple(float(v) for v in vals)))
        return tuple(out)

    def synthesis(self, t: dict, kind: str, driver: Driver | None, keys: set[str]):
        """``[analysis.synthesis]`` (required by, and only allowed with, kind "synthesis")."""
        p = "analysis.synthesis"
        if "synthesis" not in t:
            if kind == "synthesis":
                raise self.fail(p, "missing: a 'synthesis' analysis needs [analysis.synthesis]")
            return None
        if kind != "synthesis":
            raise self.fail(p, f"only a 'synthesis' analysis takes it (kind is {kind!r})")
        s = self.keys(t["synthesis"], p, ("goal", "members", "target", "output"), ("goal",))
        goal = self.str_(s, "goal", p, choices=SYNTHESIS_GOALS)
        if goal == "bistable":  # a search, nothing to size; no driver: every candidate
            for k in ("members", "target", "output"):
                if k in s:
                    raise self.fail(f"{p}.{k}", "a bistable search sizes nothing (no such key)")
            return Synthesis(goal, (), math.nan)
        for k in ("members", "target"):
            if k not in s:
                raise self.fail(f"{p}.{k}", "missing required key")
        mem = s["members"]
        if not isinstance(mem, list) or not mem or not all(isinstance(m, str) for m in mem):
            raise self.fail(f"{p}.members", "must be a non-empty array of member ids")
        kinds = {m.id: m.kind for m in self._members}
        if goal == "stable-position":  # one rigid link's length
            if len(mem) != 1 or kinds.get(mem[0]) != "rigid":
                raise self.fail(f"{p}.members", "must name one rigid link (its length is sized)")
        else:
            for m in mem:
                if kinds.get(m) != "flexible":
                    raise self.fail(f"{p}.members", f"{m!r} is not a flexible member (EI to size)")
        target = self.num(s, "target", p)
        output = self.str_(s, "output", p)
        if goal == "stiffness":
            if output is None or output not in keys:
                raise self.fail(f"{p}.output", "a stiffness synthesis needs an output key to hit")
            if target == 0.0:
                raise self.fail(f"{p}.target", "must be non-zero (the unloaded state is 0)")
        else:
            if driver is None:
                raise self.fail("analysis.driver", f"missing: a {goal} synthesis needs one")
            if output is not None:
                raise self.fail(f"{p}.output", "only a stiffness synthesis takes output")
            if goal == "critical-load" and target <= 0.0:
                raise self.fail(f"{p}.target", f"critical load must be > 0, got {target:g}")
        return Synthesis(goal, tuple(mem), target, output)

    def ma(self, t: dict, driver: Driver | None, outputs: tuple[Output, ...]):
        """``[analysis.ma]``: mechanical advantage output (optional)."""
        p = "analysis.ma"
        if "ma" not in t:
            return None
        m = self.keys(t["ma"], p, ("output", "direction", "input"), ("output", "direction"))
        out = self.str_(m, "output", p)
        if out not in {o.name for o in outputs}:
            raise self.fail(f"{p}.output", f"{out!r} is not an [[outputs]] name")
        direction = self.str_(m, "direction", p, choices=("x", "y", "rot"))
        inp = self.str_(m, "input", p, default="driver")
        if inp == "driver" and driver is None:
            raise self.fail(f"{p}.input", "input 'driver' needs analysis.driver")
        if inp != "driver" and inp not in {ld.id for ld in self._loads}:
            raise self.fail(f"{p}.input", f"{inp!r} is neither 'driver' nor a load id")
        return MechanicalAdvantage(out, direction, inp)

    def references(
        self, outputs: tuple[Output, ...], booms: tuple[Boom, ...] = ()
    ) -> tuple[Reference, ...]:
        keys = {f"{o.name}.{q}" for o in outputs for q in NODE_QUANTITIES} | set(EXTRA_OUTPUTS)
        keys |= {f"{b.id}.length" for b in booms}
        out = []
        allowed = (
            "output",
            "value",
            "kind",
            "source",
            "rationale",
            "tolerance",
            "at_factor",
            "abs_tolerance",
        )
        for i, t in enumerate(self.array("references", required=False)):
            p = f"references[{i}]"
            self.keys(
                t, p, allowed, ("output", "value", "kind", "source", "rationale", "tolerance")
            )
            key = self.str_(t, "output", p)
            if key not in keys:
                raise self.fail(f"{p}.output", f"{key!r} is not an output key of this case")
            out.append(
                Reference(
                    output=key,
                    value=self.num(t, "value", p),
                    kind=self.str_(t, "kind", p, choices=REFERENCE_KINDS),
                    source=self.str_(t, "source", p),
                    rationale=self.str_(t, "rationale", p),
                    tolerance=self.num(t, "tolerance", p, positive=True),
                    at_factor=self.num(t, "at_factor", p),
                    abs_tolerance=self.bool_(t, "abs_tolerance", p),
                )
            )
        return tuple(out)

    def tolerances(
        self, outputs: tuple[Output, ...], booms: tuple[Boom, ...] = ()
    ) -> tuple[DesignTolerance, ...]:
        """``[[tolerances]]``: the outputs a designer judges, each with ``rel`` or ``abs``."""
        keys = {f"{o.name}.{q}" for o in outputs for q in NODE_QUANTITIES} | set(EXTRA_OUTPUTS)
        keys |= {f"{b.id}.length" for b in booms} | {o.name for o in outputs} | {"factor"}
        out = []
        for i, t in enumerate(self.array("tolerances", required=False)):
            p = f"tolerances[{i}]"
            self.keys(t, p, ("output", "rel", "abs", "floor", "why"), ("output", "why"))
            key = self.str_(t, "output", p)
            if key not in keys:
                raise self.fail(
                    f"{p}.output", f"{key!r} is neither an output key nor a point of this case"
                )
            if ("rel" in t) == ("abs" in t):
                raise self.fail(p, "give exactly one of 'rel' (e.g. 0.01) or 'abs' (case units)")
            rel = self.num(t, "rel", p, positive=True)
            if rel is not None and rel >= 1.0:
                raise self.fail(f"{p}.rel", f"{rel:g} is not a fraction below 1 (1 % is 0.01)")
            out.append(
                DesignTolerance(
                    output=key,
                    why=self.str_(t, "why", p),
                    rel=rel,
                    abs=self.num(t, "abs", p, positive=True),
                    floor=self.num(t, "floor", p, positive=True),
                )
            )
        self.unique([t.output for t in out], "tolerances")
        return tuple(out)

    def models(self) -> tuple[ModelSpec, ...]:
        out = []
        for i, t in enumerate(self.array("models", required=False)):
            p = f"models[{i}]"
            self.keys(t, p, ("name", "options"), ("name",))
            opts = t.get("options", {})
            if not isinstance(opts, dict):
                raise self.fail(f"{p}.options", "must be a table")
            _check_finite(opts, f"{p}.options", self.fail)
            out.append(ModelSpec(self.str_(t, "name", p), dict(opts)))
        return tuple(out)

    def booms(self, node_ids: set[str], supports: tuple[Support, ...]) -> tuple[Boom, ...]:
        held = {s.node for s in supports if s.type in ("pin", "clamp")}
        out = []
        for i, t in enumerate(self.array("booms", required=False)):
            p = f"booms[{i}]"
            self.keys(t, p, ("id", "from", "to", "force", "length"), ("id", "from", "to"))
            for k in ("force", "length"):
                if k not in t:
                    raise self.fail(f"{p}.{k}", "missing required key")
            a, b = self.str_(t, "from", p), self.str_(t, "to", p)
            for key, nid in (("from", a), ("to", b)):
                if nid not in node_ids:
                    raise self.fail(f"{p}.{key}", f"unknown node {nid!r}")
            if a not in held:
                raise self.fail(f"{p}.from", f"the base end {a!r} must be a pinned/clamped node")
            if a == b:
                raise self.fail(f"{p}.to", "a boom must join two different nodes")
            out.append(
                Boom(
                    id=self.str_(t, "id", p),
                    a=a,
                    b=b,
                    force=self.num(t, "force", p, positive=True),
                    length=self.num(t, "length", p, positive=True),
                )
            )
        self.unique([b.id for b in out], "booms")
        return tuple(out)

    def resolve_rest_angles(self, scene: Scene) -> Scene:
        """Springs given by ``rest_angle_deg`` get their ``free_angle_deg`` from the drawing."""
        springs = tuple(
            replace(s, free_angle_deg=free_from_rest(scene, s, s.rest_angle_deg))
            if s.rest_angle_deg is not None
            else s
            for s in scene.torsion_springs
        )
        return replace(scene, torsion_springs=springs)

    def check_analysis_needs(self, scene: Scene) -> None:
        """A deploy needs booms; a boom's deployed length must exceed its drawn length;
        sweep keys must name numbers of this scene."""
        a = scene.analysis
        deploy = a.kind == "deploy" or (a.kind == "sweep" and a.sweep_of == "deploy")
        if deploy and not scene.booms:
            raise self.fail("booms", "missing: a deploy analysis needs at least one [[booms]]")
        for i, b in enumerate(scene.booms):
            na, nb = scene.node(b.a), scene.node(b.b)
            drawn = math.hypot(nb.x - na.x, nb.y - na.y)
            if b.length <= drawn:
                raise self.fail(
                    f"booms[{i}].length", f"{b.length:g} must exceed the drawn length {drawn:g}"
                )
        for i, ax in enumerate(a.grid):
            for key in ax.keys:
                why = key_error(scene, key)
                if why:
                    raise self.fail(f"analysis.grid[{i}].keys", why)
                if key.split(".")[2] in POSITIVE and min(ax.values) <= 0.0:
                    raise self.fail(f"analysis.grid[{i}].values", f"{key} must stay > 0")
                table, ident, fld = key.split(".")
                if table == "booms" and fld == "length":
                    b = next(b for b in scene.booms if b.id == ident)
                    na, nb = scene.node(b.a), scene.node(b.b)
                    drawn = math.hypot(nb.x - na.x, nb.y - na.y)
                    if min(ax.values) <= drawn:
                        why = f"{key} must exceed the drawn length {drawn:g}"
                        raise self.fail(f"analysis.grid[{i}].values", why)

    # -- whole-structure checks --------------------------------------------------------------
    def check_connected(self, scene: Scene) -> None:
        """Every node must be reachable from the first through members (one structure)."""
        adj: dict[str, set[str]] = {n.id: set() for n in scene.nodes}
        for m in (*scene.members, *scene.booms):
            adj[m.a].add(m.b)
            adj[m.b].add(m.a)
        seen, todo = {scene.nodes[0].id}, [scene.nodes[0].id]
        while todo:
            for nb in adj[todo.pop()] - seen:
                seen.add(nb)
                todo.append(nb)
        lost = [n.id for n in scene.nodes if n.id not in seen]
        if lost:
            i = [n.id for n in scene.nodes].index(lost[0])
            raise self.fail(
                f"nodes[{i}]", f"node {lost[0]!r} is not connected to the rest (disconnected parts)"
            )

    def check_restrained(self, scene: Scene) -> None:
        """The supports must stop the three rigid-body motions of the whole structure.

        Rigid motion: u(x, y) = (tx - w y, ty + w x), rotation w.  Each support (and each
        torsion spring to ground) contributes linear constraints on (tx, ty, w); they must have
        rank 3.
        """
        rows = []
        for s in scene.supports:
            n = scene.node(s.node)
            ux, uy = np.array([1.0, 0.0, -n.y]), np.array([0.0, 1.0, n.x])
            if s.type in ("clamp", "pin"):
                rows += [ux, uy]
            elif s.type == "slider":
                a = math.radians(s.angle_deg)
                rows.append(-math.sin(a) * ux + math.cos(a) * uy)
            if s.type in ("clamp", "guided"):
                rows.append(np.array([0.0, 0.0, 1.0]))
        # a torsion spring to ground resists rigid rotation just like a clamp's moment
        if any(t.member_b is None for t in scene.torsion_springs):
            rows.append(np.array([0.0, 0.0, 1.0]))
        rank = np.linalg.matrix_rank(np.array(rows)) if rows else 0
        if rank < 3:
            free = 3 - rank
            raise self.fail(
                "supports", f"too few supports: the structure keeps {free} rigid-body freedom(s)"
            )


def _check_finite(obj: Any, path: str, fail: Callable[[str, str], CaseError]) -> None:
    """Numbers hidden in nested model options: finite and in range (iterative, linear)."""
    limits.check_tree({path: obj}, fail)
