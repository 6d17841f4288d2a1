"""The case loader's analysis and judgement: ``[analysis]`` (driver, sweep grid, synthesis,
mechanical advantage), ``[[references]]``, ``[[tolerances]]`` and ``[[models]]``."""

from __future__ import annotations

import math

from cases import limits
from cases.load_checks import Checks, check_finite
from cases.node_rotation import stop_error
from cases.schema import (
    ANALYSIS_KINDS,
    NODE_QUANTITIES,
    REFERENCE_KINDS,
    SWEEP_OF_KINDS,
    SYNTHESIS_GOALS,
    Analysis,
    Boom,
    DesignTolerance,
    Driver,
    GridAxis,
    MechanicalAdvantage,
    ModelSpec,
    Output,
    Reference,
    Scene,
    Synthesis,
)
from cases.sweep import POSITIVE, key_error

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

ANALYSIS_KEYS = (
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
)


class AnalysisPart(Checks):
    """What to solve and how to judge it (part of ``cases.load``'s builder).  ``synthesis`` and
    ``ma`` read ``self._members`` and ``self._loads``, set by the builder before ``analysis``."""

    def analysis(
        self, node_ids: set[str], member_ids: set[str], outputs: tuple[Output, ...]
    ) -> Analysis:
        p = "analysis"
        t = self.keys(self.data.get("analysis", {"kind": "load"}), p, ANALYSIS_KEYS, ("kind",))
        kind = self.str_(t, "kind", p, choices=ANALYSIS_KINDS)
        keys = {f"{o.name}.{q}" for o in outputs for q in NODE_QUANTITIES}
        stop_output = self.str_(t, "stop_output", p)
        if stop_output is not None and stop_output not in keys:
            raise self.fail(f"{p}.stop_output", f"{stop_output!r} is not an output key")
        if stop_output is not None:
            name = stop_output.rsplit(".", 1)[0]
            node = next(o.node for o in outputs if o.name == name)
            why = stop_error(self._members, stop_output, node)
            if why:
                raise self.fail(f"{p}.stop_output", why)
        stop_value = self.num(t, "stop_value", p)
        if (stop_output is None) != (stop_value is None):
            raise self.fail(f"{p}.stop_value", "stop_output and stop_value go together")
        driver = self.driver(t, p, node_ids, member_ids)
        if kind in ("distance", "energy", "kinematics") and driver is None:
            raise self.fail(f"{p}.driver", f"missing: a {kind!r} analysis needs a driver")
        sweep_values, grid = self.sweep_grid(t, p, kind)
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
            sweep_values=sweep_values,
            grid=grid,
            sweep_of=self.str_(t, "sweep_of", p, default="load", choices=SWEEP_OF_KINDS),
            mobility=self.int_(t, "mobility", p, None, lo=0),
            synthesis=self.synthesis(t, kind, driver, keys),
            ma=self.ma(t, driver, outputs),
        )

    def driver(self, t: dict, p: str, node_ids: set[str], member_ids: set[str]) -> Driver | None:
        """``[analysis.driver]``: a prescribed displacement of a node or rotation of a member."""
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
        return driver

    def sweep_grid(
        self, t: dict, p: str, kind: str
    ) -> tuple[tuple[float, ...], tuple[GridAxis, ...]]:
        """The sweep's values (``sweep_values``) and grid axes (``sweep_key``/``sweep_values``
        first, then ``[[analysis.grid]]``), checked against the analysis kind and the limit."""
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
        return tuple(float(v) for v in sweep_values), grid

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

    def synthesis(
        self, t: dict, kind: str, driver: Driver | None, keys: set[str]
    ) -> Synthesis | None:
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

    def ma(
        self, t: dict, driver: Driver | None, outputs: tuple[Output, ...]
    ) -> MechanicalAdvantage | None:
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
            check_finite(opts, f"{p}.options", self.fail)
            out.append(ModelSpec(self.str_(t, "name", p), dict(opts)))
        return tuple(out)

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
