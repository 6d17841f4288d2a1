"""The thesis's six-bar family read as a chain (seed 001, Appendix C): the serial chain of
rigid bars from one pinned ground node to another (any member order, direction or node names,
from the end the thesis numbers first), its ternary links, torsion springs and
booms; and the chain's geometry (bar angles, joints rebuilt from the stored bar lengths, boom
lengths, MATLAB's ``vpa`` rounding).  ``reduced_models.thesis.force_method`` runs the force
method on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cases.schema import Scene


@dataclass(frozen=True)
class Chain:
    """The scene read as the thesis's six-bar family.

    ``nodes``: chain node ids from the first ground joint to the last (n + 1 for n bars);
    ``free``: indices (into ``nodes``) of the moving joints; ``welds``: bar index pairs
    (i, i + 1) welded at their common joint; ``springs``: (bar_a, bar_b or -1, stiffness,
    free angle rad) with bar indices into the chain; ``boom``: (base xy, chain index of the
    pushed node, force, deployed length); ``others``: further booms, the same four fields:
    as in the thesis's two-boom Configuration 6 they push while the first boom does (Part 1
    stops on the first boom alone, so they may be pushed past their length) and lock with it.
    """

    nodes: tuple[str, ...]
    free: tuple[int, ...]
    welds: tuple[tuple[int, int], ...]
    springs: tuple[tuple[int, int, float, float], ...]
    base: tuple[float, float]
    tip: int
    force: float
    length: float
    bars: tuple[int, ...] = ()  # scene member index of each chain bar
    others: tuple[tuple[tuple[float, float], int, float, float], ...] = ()  # (base, tip, F, L)


def walk_chain(scene: Scene) -> tuple[tuple[str, ...], tuple[int, ...]] | str:
    """The members as one open chain, whatever their order, direction and node names: chain
    nodes and the member index of each bar, from the end ``first_end`` picks, or the reason
    the members are not one chain."""
    at: dict[str, list[int]] = {}
    for i, m in enumerate(scene.members):
        at.setdefault(m.a, []).append(i)
        at.setdefault(m.b, []).append(i)
    ends = sorted(n for n, ms in at.items() if len(ms) == 1)
    if len(ends) != 2 or any(len(ms) > 2 for ms in at.values()):
        return "members must form one open chain (no branches)"
    nodes, bars = [ends[0]], []
    while len(bars) < len(scene.members):
        nxt = [i for i in at[nodes[-1]] if i not in bars]
        if not nxt:
            return "members must form one open chain (no closed loops)"
        m = scene.members[nxt[0]]
        bars.append(nxt[0])
        nodes.append(m.b if m.a == nodes[-1] else m.a)
    if first_end(scene, nodes) != nodes[0]:
        nodes, bars = nodes[::-1], bars[::-1]
    return tuple(nodes), tuple(bars)


def first_end(scene: Scene, nodes: list[str]) -> str:
    """The chain end the walk starts from: the one farther from the first boom's base (the
    thesis's Configurations 2, 3 and 6 push from their last ground joint), else -- the two
    ends as far, as in the symmetric Configuration 4 -- the end from which the chain runs
    counter-clockwise round its loop with the ground (the thesis's numbering).

    The listing re-places the joints from the first one (``rebuild``), so the walk's start
    decides where the bars' length drift collects; the distance rule makes it the same end
    however the scene is drawn (a mirror turns a counter-clockwise walk clockwise)."""
    xy = {n: np.array([scene.node(n).x, scene.node(n).y]) for n in nodes}
    ends = (nodes[0], nodes[-1])
    if scene.booms:
        base = np.array([scene.node(scene.booms[0].a).x, scene.node(scene.booms[0].a).y])
        d = [float(np.hypot(*(xy[e] - base))) for e in ends]
        span = max(float(np.hypot(*(xy[a] - xy[b]))) for a, b in zip(nodes, nodes[1:]))
        if abs(d[0] - d[1]) > 1e-9 * span:
            return ends[int(d[1] > d[0])]
    p = np.array([xy[n] for n in nodes])
    area = np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
    return ends[int(area < 0)]


def read_chain(scene: Scene) -> Chain | str:
    """The chain description of ``scene``, or the reason it is not of the thesis's family."""
    if any(m.kind != "rigid" for m in scene.members):
        return "the force method models rigid bars only"
    if scene.loads:
        return "the thesis's force method has no external loads besides the boom"
    pinned = {s.node for s in scene.supports if s.type == "pin"}
    if len(pinned) != len(scene.supports):
        return "only pinned ground joints are modelled"
    walked = walk_chain(scene)
    if isinstance(walked, str):
        return walked
    nodes, bars = walked
    members = [scene.members[i] for i in bars]
    boom = scene.booms[0]
    if nodes[0] not in pinned or nodes[-1] not in pinned:
        return "the chain's two ends must be pinned to ground"
    for b in scene.booms:
        if b.stop != "lock":
            return "a collision-damper boom stop is dynamic: only replay models it"
        if b.a not in pinned or b.b not in nodes[1:-1]:
            return f"boom {b.id!r} must run from a ground pin to a moving joint of the chain"

    def end_at(m: object, node: str) -> str:
        return m.end_a if m.a == node else m.end_b

    welds = []
    for i in range(len(members) - 1):  # rigid only where both ends are welded (else a pin)
        j = nodes[i + 1]
        if (end_at(members[i], j), end_at(members[i + 1], j)) == ("weld", "weld"):
            welds.append((i, i + 1))
    index = {m.id: i for i, m in enumerate(members)}
    springs = []
    for t in scene.torsion_springs:
        ia, ib = index[t.member_a], -1 if t.member_b is None else index[t.member_b]
        springs.append((ia, ib, t.stiffness, math.radians(t.free_angle_deg)))
    b = scene.node(boom.a)
    others = tuple(
        ((scene.node(o.a).x, scene.node(o.a).y), nodes.index(o.b), o.force, o.length)
        for o in scene.booms[1:]
    )
    return Chain(
        others=others,
        nodes=tuple(nodes),
        bars=bars,
        free=tuple(range(1, len(nodes) - 1)),
        welds=tuple(welds),
        springs=tuple(springs),
        base=(b.x, b.y),
        tip=nodes.index(boom.b),
        force=boom.force,
        length=boom.length,
    )


def boom_lengths(chain: Chain, pos: np.ndarray) -> list[float]:
    """Length of every boom (the first, then ``others``) at joint positions ``pos``."""
    ends = [(chain.base, chain.tip)] + [(b, j) for b, j, _, _ in chain.others]
    return [float(np.hypot(*(pos[j] - np.asarray(b)))) for b, j in ends]


def round_sig(x: np.ndarray, digits: int | None) -> np.ndarray:
    """Round to ``digits`` significant decimal digits (MATLAB ``vpa(x, digits)``)."""
    if digits is None:
        return x
    return np.array([float(f"{v:.{digits - 1}e}") for v in x])


def angles(pos: np.ndarray) -> np.ndarray:
    """Bar angles (rad) along the chain from joint positions, shape (n_bars,)."""
    d = np.diff(pos, axis=0)
    return np.arctan2(d[:, 1], d[:, 0])


def rebuild(pos: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Free joints re-placed along the chain from the bar angles and stored lengths (the
    listing's ``x(i) = x_prev + L(i) cosd(alf(i))``); the last ground joint stays put."""
    th = angles(pos)
    new = pos.copy()
    steps = lengths[:-1, None] * np.column_stack([np.cos(th[:-1]), np.sin(th[:-1])])
    new[1:-1] = pos[0] + np.cumsum(steps, axis=0)
    return new
