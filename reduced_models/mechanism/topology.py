"""Scene -> unknowns of the mechanism assembler: node poses, end rotations, member internals.

Unknowns (one vector ``q``, absolute values, length units and radians):

* every scene node: its position (x, y);
* rotation DOFs from the drawn state, one per *rotation group*: the member ends welded
  together at a node share one, a pinned end has its own, and both ends of a rigid member
  share one (the link turns as a body);
* member internals, appended by the member laws (``members.py``): chain nodes and axial
  forces of linear/BCM segments, joint angles and stretches of PRB chains.

Fixed unknowns (supports) stay in ``q`` at their drawn value and are left out of the Newton
system (``free``).  A flexible member loaded at a fraction of its length is split there into
two members of the same section (the load point becomes a node), each with the member's model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from cases.node_rotation import pinned_ends
from cases.schema import Load, Member, Node, Scene


@dataclass
class Layout:
    """DOF bookkeeping of one scene (see module docstring).

    Attributes
    ----------
    scene : the scene as solved (flexible members split at interior load points).
    node_dof : node id -> index of its x unknown (y follows).
    end_rot : (member id, "a" | "b") -> index of that member end's rotation unknown.
    node_rot : node id -> rotation unknowns whose mean is ``<output>.rot`` and which share a
        moment applied there (welded group, else every pinned member end:
        ``cases.node_rotation``), ``()`` when only springs end there.
    q0 : drawn state, grows as member laws add internals.
    kind : per unknown "t" (translation), "r" (rotation), "p" (axial multiplier),
        "u" (stretch) -- for residual scaling.
    fixed : indices held by supports.
    Lref : largest member length.
    """

    scene: Scene
    node_dof: dict[str, int]
    end_rot: dict[tuple[str, str], int]
    node_rot: dict[str, tuple[int, ...]]
    q0: list[float]
    kind: list[str]
    fixed: set[int] = field(default_factory=set)
    Lref: float = 1.0
    ground: int = -1

    def piece(self, member_id: str, node_id: str) -> Member:
        """The member (or the piece of a member split at a load point) ending at a node."""
        for m in self.scene.members:
            if (m.id == member_id or m.id.startswith(member_id + "#")) and node_id in (m.a, m.b):
                return m
        raise KeyError(f"member {member_id!r} does not end at node {node_id!r}")

    def pieces(self, member_id: str) -> list[Member]:
        """The member, or all pieces of a member split at load points."""
        return [
            m for m in self.scene.members if m.id == member_id or m.id.startswith(member_id + "#")
        ]

    def add(self, values: list[float], kind: str) -> np.ndarray:
        """Append unknowns with their drawn values; returns their indices."""
        start = len(self.q0)
        self.q0.extend(float(v) for v in values)
        self.kind.extend(kind for _ in values)
        return np.arange(start, len(self.q0))

    @property
    def n(self) -> int:
        """Number of unknowns."""
        return len(self.q0)

    def free(self) -> np.ndarray:
        """Indices of the unknowns the Newton system solves for."""
        return np.array([i for i in range(self.n) if i not in self.fixed], dtype=np.int64)


def split_member_loads(scene: Scene) -> Scene:
    """Split flexible members at interior load points (0 < fraction < 1) into two members.

    The new node is ``<member>@<fraction>``; the halves are ``<member>#1`` and ``<member>#2``
    with the member's section and model, welded at the new node; the load moves to the node.
    """
    inner = [
        ld
        for ld in scene.loads
        if ld.member is not None
        and 0.0 < float(ld.fraction) < 1.0
        and scene.member(ld.member).kind == "flexible"
    ]
    if not inner:
        return scene
    nodes, members, loads = list(scene.nodes), list(scene.members), list(scene.loads)
    for ld in inner:
        orig = scene.member(ld.member)
        a, b = scene.node(orig.a), scene.node(orig.b)
        f = float(ld.fraction)
        px, py = a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)
        nid = f"{ld.member}@{f:g}"
        loads[loads.index(ld)] = Load(ld.id, ld.fx, ld.fy, ld.moment, node=nid)
        if any(n.id == nid for n in nodes):  # a second load at the same point
            continue
        nodes.append(Node(nid, px, py))
        pieces = [mm for mm in members if mm.id == ld.member or mm.id.startswith(ld.member + "#")]
        m = next(
            mm
            for mm in pieces
            if 1e-12 < _param(_node(nodes, mm.a), _node(nodes, mm.b), px, py) < 1.0 - 1e-12
        )
        i = members.index(m)
        members[i : i + 1] = [
            replace(m, id=f"{m.id}#1", b=nid, end_b="weld"),
            replace(m, id=f"{m.id}#2", a=nid, end_a="weld"),
        ]
    return replace(scene, nodes=tuple(nodes), members=tuple(members), loads=tuple(loads))


def _node(nodes: list[Node], nid: str) -> Node:
    return next(n for n in nodes if n.id == nid)


def _param(a: Node, b: Node, x: float, y: float) -> float:
    dx, dy = b.x - a.x, b.y - a.y
    return ((x - a.x) * dx + (y - a.y) * dy) / (dx * dx + dy * dy)


def layout(scene: Scene) -> Layout:
    """Node and rotation unknowns of ``scene`` and the support conditions."""
    q0: list[float] = []
    kinds: list[str] = []
    node_dof = {}
    for n in scene.nodes:
        node_dof[n.id] = len(q0)
        q0 += [n.x, n.y]
        kinds += ["t", "t"]
    beams = [m for m in scene.members if m.kind in ("flexible", "rigid")]
    # union-find over member ends: welds at a node and both ends of a rigid link share a DOF
    parent: dict[tuple[str, str], tuple[str, str]] = {}

    def find(k: tuple[str, str]) -> tuple[str, str]:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    def union(a: tuple[str, str], b: tuple[str, str]) -> None:
        parent[find(a)] = find(b)

    ends = [(m.id, e) for m in beams for e in ("a", "b")]
    for k in ends:
        parent[k] = k
    weld_first: dict[str, tuple[str, str]] = {}
    for m in beams:
        for e, nid, kind in (("a", m.a, m.end_a), ("b", m.b, m.end_b)):
            if kind == "weld":
                if nid in weld_first:
                    union((m.id, e), weld_first[nid])
                else:
                    weld_first[nid] = (m.id, e)
        if m.kind == "rigid":
            union((m.id, "a"), (m.id, "b"))
    group_dof: dict[tuple[str, str], int] = {}
    end_rot = {}
    for k in ends:
        r = find(k)
        if r not in group_dof:
            group_dof[r] = len(q0)
            q0.append(0.0)
            kinds.append("r")
        end_rot[k] = group_dof[r]
    node_rot = {
        n.id: (end_rot[weld_first[n.id]],)
        if n.id in weld_first
        else tuple(end_rot[k] for k in pinned_ends(beams, n.id))
        for n in scene.nodes
    }
    lengths = [scene.member_length(m.id) for m in scene.members]
    lay = Layout(scene, node_dof, end_rot, node_rot, q0, kinds, Lref=max(lengths or [1.0]))
    lay.ground = int(lay.add([0.0], "r")[0])  # the ground's rotation, held at 0
    lay.fixed.add(lay.ground)
    for s in scene.supports:
        i = node_dof[s.node]
        if s.type in ("clamp", "pin"):
            lay.fixed |= {i, i + 1}
        if s.type in ("clamp", "guided") and s.node in weld_first:
            lay.fixed.add(end_rot[weld_first[s.node]])
    return lay


def member_frame(scene: Scene, m: Member) -> tuple[float, float]:
    """(length, direction angle in rad) of a member as drawn."""
    a, b = scene.node(m.a), scene.node(m.b)
    return math.hypot(b.x - a.x, b.y - a.y), math.atan2(b.y - a.y, b.x - a.x)


def slider_rows(scene: Scene, lay: Layout) -> list[tuple[int, float, float, float]]:
    """Slider supports as linear constraints ``-sin(a) x + cos(a) y = const``:
    (x index, coefficient on x, coefficient on y, constant)."""
    rows = []
    for s in scene.supports:
        if s.type == "slider":
            a = math.radians(s.angle_deg)
            n = scene.node(s.node)
            cx, cy = -math.sin(a), math.cos(a)
            rows.append((lay.node_dof[s.node], cx, cy, cx * n.x + cy * n.y))
    return rows
