"""The case loader's mechanism parts: ``[[torsion_springs]]`` (rest angles resolved from the
drawing), ``[[booms]]``, and the whole-structure checks (one connected structure, no rigid-body
freedom left)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cases.load_checks import Checks
from cases.schema import (
    Boom,
    Member,
    Scene,
    Support,
    TorsionSpring,
)
from cases.sweep import free_from_rest


class MechanismPart(Checks):
    """Springs, booms and whole-structure checks of a scene (part of ``cases.load``'s builder)."""

    def torsion_springs(
        self, node_ids: set[str], members: tuple[Member, ...]
    ) -> tuple[TorsionSpring, ...]:
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

    def booms(self, node_ids: set[str], supports: tuple[Support, ...]) -> tuple[Boom, ...]:
        held = {s.node for s in supports if s.type in ("pin", "clamp")}
        out = []
        for i, t in enumerate(self.array("booms", required=False)):
            p = f"booms[{i}]"
            allowed = ("id", "from", "to", "force", "length", "stop", "stop_stiffness")
            self.keys(t, p, allowed, ("id", "from", "to"))
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
                    **self.boom_stop(t, p),
                )
            )
        self.unique([b.id for b in out], "booms")
        return tuple(out)

    def boom_stop(self, t: dict, p: str) -> dict:
        """``stop`` ("lock" | "damper") and, for a damper, its ``stop_stiffness`` (> 0)."""
        stop = t.get("stop", "lock")
        if stop not in ("lock", "damper"):
            raise self.fail(f"{p}.stop", f"must be 'lock' or 'damper', got {stop!r}")
        if stop == "lock":
            if "stop_stiffness" in t:
                raise self.fail(f"{p}.stop_stiffness", "only a 'damper' stop has a stiffness")
            return {}
        if "stop_stiffness" not in t:
            raise self.fail(f"{p}.stop_stiffness", "missing (required with stop = 'damper')")
        return {"stop": stop, "stop_stiffness": self.num(t, "stop_stiffness", p, positive=True)}

    def resolve_rest_angles(self, scene: Scene) -> Scene:
        """Springs given by ``rest_angle_deg`` get their ``free_angle_deg`` from the drawing."""
        springs = tuple(
            replace(s, free_angle_deg=free_from_rest(scene, s, s.rest_angle_deg))
            if s.rest_angle_deg is not None
            else s
            for s in scene.torsion_springs
        )
        return replace(scene, torsion_springs=springs)

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
