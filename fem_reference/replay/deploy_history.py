"""The deployment as the thesis's ADAMS chapter shows it (seed 001, Figures 5-2 to 5-25): the
replay's time history of a deploy scene -- each boom's length, each joint's position and
angle, the lock events -- as JSON-ready lists (``extras["time_history"]``), and the joint
angles of any set of node positions (so a quasi-static answer is compared on the same
definition).

Joint angle (deg): at a node joining two or more members, the direction of the second member
listed at the node (pointing away from it) minus that of the first, in (-180, 180]; at a
node with one member, that member's direction away from the node, from +x.  Angles are
unwrapped in time (a joint turning through 180 deg does not jump by 360).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from cases.schema import Scene


def _members_at(scene: Scene) -> dict[str, list[object]]:
    at: dict[str, list[object]] = {}
    for m in scene.members:
        at.setdefault(m.a, []).append(m)
        at.setdefault(m.b, []).append(m)
    return at


def joint_angles(scene: Scene, xy: Mapping[str, Sequence[float]]) -> dict[str, float]:
    """Joint angle (deg) of every node that has a member, from node positions ``xy`` (node
    id -> (x, y), length units; nodes absent from ``xy`` are taken where drawn)."""

    def at(node: str) -> np.ndarray:
        n = scene.node(node)
        return np.asarray(xy.get(node, (n.x, n.y)), dtype=float)

    def away(m: object, node: str) -> float:
        d = at(m.b if m.a == node else m.a) - at(node)
        return math.atan2(d[1], d[0])

    out = {}
    for node, ms in _members_at(scene).items():
        ang = away(ms[0], node) if len(ms) == 1 else away(ms[1], node) - away(ms[0], node)
        out[node] = math.degrees((ang + math.pi) % (2 * math.pi) - math.pi)
    return out


def node_positions(system: object, q: np.ndarray) -> dict[str, tuple[float, float]]:
    """Position (length units) of every scene node of an FE system at state ``q``."""
    d = system.full(q)
    out = {}
    for node, p in system.extra["nodes"].items():
        u = d[system.trans[p]]
        out[node] = (float(system.points[p, 0] + u[0]), float(system.points[p, 1] + u[1]))
    return out


def time_history(
    scene: Scene,
    system: object,
    frames: Mapping,
    pairs: Sequence[object],
    lock_events: Sequence[Mapping],
    t_settled: float,
    q_settled: np.ndarray | None = None,
) -> dict:
    """``extras["time_history"]`` of a replayed deploy scene.

    Parameters
    ----------
    scene, system : the deploy scene and its FE system (``assembly.build``).
    frames : the replay's ``extras["frames"]`` (``t`` (nt,), ``q`` (nt, ndof)).
    pairs : the booms as ``events.LockPair`` (scene order).
    lock_events : the replay's lock events (``kind``, ``ends``, ``t``, ``gap``, ``lost``).
    t_settled : time (s) at which the deployed state settled.
    q_settled : the settled state's DOFs (its joint angles: ``settled_angle_deg``).

    Returns
    -------
    dict of lists: ``t`` (s); ``boom_length`` {boom id: lengths}; ``joint_x``, ``joint_y``
    {node: coordinates} (every node of a member or a boom); ``joint_angle_deg`` {node of a
    member: angles}; ``locks`` [{boom, t, energy lost at the latch}]; ``settled_t``,
    ``settled_angle_deg`` {node: angle}; ``members`` [[a, b], ...] and ``booms`` [[a, b], ...]
    to draw the mechanism.
    """
    ts = [float(t) for t in frames["t"]]
    qs = np.asarray(frames["q"])
    pos = [node_positions(system, q) for q in qs]
    nodes = sorted(_members_at(scene))
    drawn = sorted(set(nodes) | {n for b in scene.booms for n in (b.a, b.b)})
    ang = np.array([[joint_angles(scene, p)[n] for n in nodes] for p in pos])
    ang = np.degrees(np.unwrap(np.radians(ang), axis=0)) if len(ang) else ang
    by_ends = {f"{b.a} - {b.b}": b.id for b in scene.booms}
    locks = [
        {"boom": by_ends.get(e["ends"], e["ends"]), "t": float(e["t"]), "lost": float(e["lost"])}
        for e in lock_events
        if e.get("kind") == "lock"
    ]
    return {
        "t": ts,
        "boom_length": {
            b.id: [pair.geometry(q)[0] for q in qs] for b, pair in zip(scene.booms, pairs)
        },
        "joint_x": {n: [p[n][0] for p in pos] for n in drawn},
        "joint_y": {n: [p[n][1] for p in pos] for n in drawn},
        "joint_angle_deg": {n: ang[:, k].tolist() for k, n in enumerate(nodes)},
        "locks": locks,
        "settled_t": float(t_settled),
        "settled_angle_deg": {}
        if q_settled is None
        else {n: v for n, v in joint_angles(scene, node_positions(system, q_settled)).items()},
        "members": [[m.a, m.b] for m in scene.members],
        "booms": [[b.a, b.b] for b in scene.booms],
    }
