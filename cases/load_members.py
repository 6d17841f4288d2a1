"""The case loader's members and what acts on them: ``[[nodes]]``, ``[[members]]`` (with a
member's own model), ``[[supports]]``, ``[[loads]]`` and ``[[outputs]]``."""

from __future__ import annotations

import math
import re

from cases.arc import MAX_SWEEP_DEG
from cases.load_checks import Checks, check_finite
from cases.schema import (
    END_KINDS,
    MEMBER_KINDS,
    MEMBER_MODEL,
    SUPPORT_TYPES,
    Load,
    Member,
    Node,
    Output,
    Support,
)


class MembersPart(Checks):
    """Nodes, members, supports, loads and outputs of a scene (part of ``cases.load``'s builder)."""

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
            a, b = self.member_ends(t, p, where)
            kind = self.str_(t, "kind", p, default="flexible", choices=MEMBER_KINDS)
            section = self.section(t, p, kind)
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
                    **section,
                    end_a=self.str_(t, "end_a", p, default="weld", choices=END_KINDS),
                    end_b=self.str_(t, "end_b", p, default="weld", choices=END_KINDS),
                    free_length=self.num(t, "free_length", p, nonneg=True),
                    density=self.num(t, "density", p, positive=True),
                    sweep_deg=sweep,
                    model=model,
                    model_options=model_options,
                )
            )
        self.unique([m.id for m in out], "members")
        return tuple(out)

    def member_ends(self, t: dict, p: str, where: dict[str, Node]) -> tuple[str, str]:
        """A member's two node ids (``from``, ``to``): known, different and apart."""
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
        return a, b

    def section(self, t: dict, p: str, kind: str) -> dict[str, float | None]:
        """A member's ``E``, ``I``, ``A``, ``width``, ``thickness`` (I = w t^3 / 12 and A = w t
        where not given directly) and spring ``k``, as ``Member`` keyword arguments."""
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
        return {"E": E, "I": I, "A": A, "thickness": thick, "width": width, "k": k}

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
        check_finite(opts, f"{p}.model_options", self.fail)
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
