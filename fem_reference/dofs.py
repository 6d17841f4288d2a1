"""Full DOF numbering of the scene nodes for ``assembly.build``: translations and rotations.

Per node, in scene order: ``ux, uy``, then its rotation DOFs -- one shared by every welded
member end at the node, one per pinned member end.  With exact rigid links (``rigid.py``) a
rigid link is one body: its two end rotations are one DOF (numbered where it first appears),
so a rigid link welded at both ends ties the welded rotations of its two nodes together, and
a link pinned at an end keeps that end's rotation free of the node's other members.
"""

from __future__ import annotations

from cases.schema import Member, Scene


def number_dofs(
    scene: Scene, beams_m: list[Member], exact_rigid: bool
) -> tuple[list[list[int]], dict[str, int], dict[tuple[str, str], int], int]:
    """``(trans, weld_rot, end_rot, nfull)``.

    Returns
    -------
    trans : per scene node ``[ux, uy]`` full DOF ids.
    weld_rot : {node id: rotation DOF of its welded ends}.
    end_rot : {(member id, "a" | "b"): rotation DOF of that member end}.
    nfull : number of full DOFs so far (meshes and multipliers are numbered after them).
    """
    weld_nodes = {m.a for m in beams_m if m.end_a == "weld"}
    weld_nodes |= {m.b for m in beams_m if m.end_b == "weld"}
    parent: dict[tuple, tuple] = {}

    def root(k: tuple) -> tuple:
        while parent.get(k, k) != k:
            k = parent[k]
        return k

    def key(m: Member, end: str) -> tuple:
        nid, kind = (m.a, m.end_a) if end == "a" else (m.b, m.end_b)
        return ("w", nid) if kind == "weld" else ("e", m.id, end)

    if exact_rigid:  # union of each rigid link's two end rotations
        for m in beams_m:
            if m.kind == "rigid" and root(key(m, "a")) != root(key(m, "b")):
                parent[root(key(m, "a"))] = root(key(m, "b"))
    nfull = 0
    trans: list[list[int]] = []
    weld_rot: dict[str, int] = {}
    end_rot: dict[tuple[str, str], int] = {}
    rot_num: dict[tuple, int] = {}

    def number(k: tuple) -> int:
        nonlocal nfull
        k = root(k)
        if k not in rot_num:
            rot_num[k] = nfull
            nfull += 1
        return rot_num[k]

    for n in scene.nodes:
        trans.append([nfull, nfull + 1])
        nfull += 2
        if n.id in weld_nodes:
            weld_rot[n.id] = number(("w", n.id))
        for m in beams_m:
            for end, nid in (("a", m.a), ("b", m.b)):
                if nid == n.id:
                    end_rot[(m.id, end)] = number(key(m, end))
    return trans, weld_rot, end_rot, nfull


__all__ = ["number_dofs"]
