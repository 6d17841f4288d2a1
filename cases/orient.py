"""Which end a chained member (linear-N, bcm, cbcm-N) is laid out from (and which end of a
driven rigid link the replay's stiff element is held at: fem_reference.assembly).

A chain's segments are each described in the frame of the previous segment's tip
(``reduced_models.beam.chain``): the approximation is not symmetric under end reversal (the
BCM x-relation and the linear segment's inextensibility are measured along the root tangent).
Laid out in the drawn direction (from -> to), reversing a member in the scene file would give
another answer.  ``root_at_b`` picks the root from the scene alone, by a key that every
encoding of the scene agrees on (rotation, mirror, translation, units, node names and order,
member direction, a pin written as clamp + pinned end), compared end a against end b:

1. held by ground: a support at the end's node;
2. how firmly the end is held (``fixity``: welded to a clamp, a guided support or another
   welded member > pinned > free; a pin support holding a welded end and a clamp holding a
   pinned end both count as pinned);
3. nearer the ground: fewer members from the end's node to a supported node, not counting
   this member;
4. farther from the centroid of the scene's nodes (an outer end; compared to 1e-9 of the
   scene's size, so round-off of a rotated drawing cannot decide it).

The chain is rooted at the end with the larger key, a cantilever from its base: a leg pinned
to ground and welded to a knee is laid out from the ground pin (rooted at the knee, keys 1
and 2 swapped, linear-8's driven path on DAS-2D Ex. 3 failed or converged by the drawing's
round-off).  A mirror-symmetric scene gets a mirror-symmetric layout, so a symmetric path
stays symmetric (a symmetric bistable switch: no shuttle rotation before the snap).

When every key ties, the two ends are alike in support, connection, distance to ground and
distance to the centre: in practice a symmetry of the scene maps one end onto the other (a
beam clamped at both ends, a coupler between two mirror-image links).  Then the drawn
direction is kept: the two layouts give mirror-image approximations of a symmetric member,
and no rule that depends only on the scene can prefer one (reversing such a member still
changes the answer; none in the catalog).
"""

from __future__ import annotations

import math
from collections import deque

from cases.schema import Member, Scene

#: relative tolerance of the geometric tie-break (round-off of a rotated or scaled drawing)
GEOM_RTOL = 1e-9


def fixity(scene: Scene, m: Member, end: str) -> int:
    """How firmly a member end is held: 0 free node, 1 pinned, 2 welded to a clamp, a
    guided support or another member."""
    nid, kind = (m.a, m.end_a) if end == "a" else (m.b, m.end_b)
    sup = scene.support_at(nid)
    others = [o for o in scene.members if o.id != m.id and nid in (o.a, o.b)]
    if kind == "weld" and (
        (sup is not None and sup.type in ("clamp", "guided"))
        or any((o.end_a if o.a == nid else o.end_b) == "weld" for o in others)
    ):
        return 2
    return 1 if sup is not None or others else 0


def hops_to_ground(scene: Scene, node: str, skip: str) -> float:
    """Fewest members from ``node`` to a supported node, not through member ``skip``
    (inf when none)."""
    grounded = {s.node for s in scene.supports}
    seen, todo = {node}, deque([(node, 0)])
    while todo:
        n, d = todo.popleft()
        if n in grounded:
            return float(d)
        for o in scene.members:
            if o.id != skip and n in (o.a, o.b):
                nxt = o.b if o.a == n else o.a
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append((nxt, d + 1))
    return math.inf


def end_keys(scene: Scene, m: Member) -> tuple[tuple, tuple]:
    """The comparison keys (module doc) of end a and end b: (grounded, fixity, -hops,
    distance to the node centroid / scene size)."""
    xs = [n.x for n in scene.nodes]
    ys = [n.y for n in scene.nodes]
    cx, cy = sum(xs) / len(xs), sum(ys) / len(ys)
    size = math.hypot(max(xs) - min(xs), max(ys) - min(ys)) or 1.0

    def key(nid: str, end: str) -> tuple:
        node = scene.node(nid)
        r = math.hypot(node.x - cx, node.y - cy) / size
        grounded = scene.support_at(nid) is not None
        return (grounded, fixity(scene, m, end), -hops_to_ground(scene, nid, m.id), r)

    return key(m.a, "a"), key(m.b, "b")


def _compare(ka: tuple, kb: tuple) -> int:
    """+1 if end b's key is larger, -1 if end a's, 0 on a tie (the distance to the centroid
    compared to ``GEOM_RTOL``)."""
    if ka[:3] != kb[:3]:
        return 1 if kb[:3] > ka[:3] else -1
    if abs(kb[3] - ka[3]) <= GEOM_RTOL:
        return 0
    return 1 if kb[3] > ka[3] else -1


def root_at_b(scene: Scene, m: Member) -> bool:
    """Lay the member's chain out from end b (its key is larger; module doc)."""
    return _compare(*end_keys(scene, m)) > 0
