"""Which member ends define a node's reported rotation (``<output>.rot``), for every model.

At a node where at least one flexible or rigid member end is welded, the node has a rotation
of its own: that of its welded group.  At a node where every member end is pinned, it has
none, and ``rot`` is the MEAN of the rotations of the member ends meeting there; a moment
applied at the node is split equally among those ends (M/k each, the work-conjugate of the
mean: M d(mean) = sum (M/k) d(theta_i)).  Both are invariant under renaming nodes,
reordering or reversing members, rigid motions, mirroring and units, which a "first member
listed" rule is not.  A path cannot be driven by or stopped on such a mean (the loader
refuses it, ``stop_error``): the controls take a single unknown.
"""

from __future__ import annotations

from collections.abc import Iterable

from cases.schema import Member


def pinned_ends(members: Iterable[Member], node_id: str) -> tuple[tuple[str, str], ...]:
    """The ``(member id, "a" | "b")`` of every flexible or rigid member end at a node where
    none is welded, in scene order; ``()`` where one is welded or no such end is there."""
    ends = []
    for m in members:
        if m.kind not in ("flexible", "rigid"):
            continue
        for end, nid, kind in (("a", m.a, m.end_a), ("b", m.b, m.end_b)):
            if nid == node_id:
                if kind == "weld":
                    return ()
                ends.append((m.id, end))
    return tuple(ends)


def no_own_rotation(output: str) -> str:
    """The reason a ``rot`` output at an all-pinned node cannot stop or drive a path."""
    return (
        f"output {output!r}: the node has no rotation of its own (every member end is "
        "pinned, its rot is their mean); a path cannot be stopped on or driven by it"
    )


def stop_error(members: Iterable[Member], output: str, node_id: str) -> str | None:
    """Why output ``output`` (a ``name.q`` key at node ``node_id``) cannot drive or stop a
    path, or None: a ``rot`` that is the mean of several pinned member ends."""
    if not output.endswith(".rot") or len(pinned_ends(members, node_id)) < 2:
        return None
    return no_own_rotation(output)


__all__ = ["no_own_rotation", "pinned_ends", "stop_error"]
