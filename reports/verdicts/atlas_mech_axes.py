"""The second axis of a mechanism atlas and the driver grid along its first.

``axis_for(scene)`` chooses what the second axis varies, by what decides the scene's answer:
the legs' slenderness for a bistable snap (``thin``), the length of a compliant member the
driver bends (``lengthen``), else the direction of the applied forces (``turn_loads``); a case
without one raises ``NoAtlas`` naming why.  ``driver_grid`` is the first axis (load factors or
driver coordinates) and ``driven_key`` the driven quantity judged besides the node outputs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cases.schema import Scene
from reduced_models.base import load_factors


class NoAtlas(ValueError):
    """The case has no mechanism atlas (message: why, one line)."""


@dataclass(frozen=True)
class Axis:
    """Second axis of a case's atlas: ``apply(scene, value) -> scene`` and why it matters."""

    name: str
    label: str
    values: np.ndarray
    apply: Callable[[Scene, float], Scene]
    why: str


def turn_loads(scene: Scene, phi_deg: float) -> Scene:
    """Every applied force turned counter-clockwise by ``phi_deg`` (moments unchanged)."""
    c, s = math.cos(math.radians(phi_deg)), math.sin(math.radians(phi_deg))
    loads = tuple(
        dataclasses.replace(ld, fx=c * ld.fx - s * ld.fy + 0.0, fy=s * ld.fx + c * ld.fy + 0.0)
        for ld in scene.loads
    )
    return dataclasses.replace(scene, loads=loads)


def thin(scene: Scene, s: float) -> Scene:
    """Flexible members' in-plane thickness times ``s`` (I s^3, A s), loads and springs s^3:
    only the slenderness (EA L^2 / EI) changes."""
    k = s**3
    mem = []
    for m in scene.members:
        if m.kind == "flexible":
            t = None if m.thickness is None else m.thickness * s
            m = dataclasses.replace(m, I=m.I * k, A=m.A * s, thickness=t)
        elif m.kind == "spring" and m.k is not None:
            m = dataclasses.replace(m, k=m.k * k)
        mem.append(m)
    loads = tuple(
        dataclasses.replace(ld, fx=ld.fx * k, fy=ld.fy * k, moment=ld.moment * k)
        for ld in scene.loads
    )
    springs = tuple(
        dataclasses.replace(sp, stiffness=sp.stiffness * k) for sp in scene.torsion_springs
    )
    return dataclasses.replace(scene, members=tuple(mem), loads=loads, torsion_springs=springs)


def _grounded(scene: Scene) -> list[tuple[str, str, str]]:
    """(member id, ground node, free node) of flexible members with exactly one end on a
    support that no other member uses."""
    out = []
    for m in (m for m in scene.members if m.kind == "flexible"):
        for g, f in ((m.a, m.b), (m.b, m.a)):
            alone = not any(o.id != m.id and g in (o.a, o.b) for o in scene.members)
            if scene.support_at(g) is not None and alone and scene.support_at(f) is None:
                out.append((m.id, g, f))
    return out


def lengthen(scene: Scene, s: float) -> Scene:
    """Grounded compliant members (``_grounded``) ``s`` times as long: the ground end moves
    along the member's line, the other end stays."""
    moved = {}
    for _, g, f in _grounded(scene):
        ng, nf = scene.node(g), scene.node(f)
        moved[g] = (nf.x + s * (ng.x - nf.x), nf.y + s * (ng.y - nf.y))
    nodes = tuple(
        dataclasses.replace(n, x=moved[n.id][0], y=moved[n.id][1]) if n.id in moved else n
        for n in scene.nodes
    )
    return dataclasses.replace(scene, nodes=nodes)


def axis_for(scene: Scene, n: int = 9) -> Axis:
    """The second axis of ``scene``'s atlas (module docstring); raises NoAtlas."""
    kind = scene.analysis.kind
    if not any(m.kind == "flexible" for m in scene.members):
        raise NoAtlas("no flexible member: kinetostatic (rigid links, springs) is exact here")
    if kind not in ("load", "distance", "energy"):
        raise NoAtlas(f"a {kind} analysis has no driver path to map")
    if "bistable" in scene.tags and kind in ("load", "distance"):
        return Axis(
            "slenderness",
            "thickness scale s (EA L^2/EI x 1/s^2)",
            np.geomspace(0.5, 2.0, n),
            thin,
            "the snap comes from the legs' axial strain: slenderness decides it",
        )
    if kind == "energy":
        if not _grounded(scene):
            raise NoAtlas("no compliant member grounded at one end to lengthen")
        return Axis(
            "length",
            "compliant member length L/L0",
            np.linspace(0.7, 1.4, n),
            lengthen,
            "the driver imposes the member's tip motion: deflection / L scales as 1 / s",
        )
    if kind != "load" or not any(ld.fx or ld.fy for ld in scene.loads):
        raise NoAtlas(f"a {kind} analysis without applied forces: no second axis chosen")
    return Axis(
        "direction",
        "load direction phi (deg, counter-clockwise)",
        np.linspace(-30.0, 30.0, n),
        turn_loads,
        "the force component along the flexures stiffens or softens them (BCM's p)",
    )


def driver_grid(scene: Scene) -> tuple[np.ndarray, str]:
    """(first-axis values (d,), label): load factors or driver coordinates."""
    a = scene.analysis
    if a.kind == "load":
        return load_factors(scene), "load factor"
    unit = "deg" if a.driver.kind == "rotation" else "length"
    label = f"driver {a.driver.kind} ({unit})"
    return np.linspace(a.driver.start, a.driver.stop, a.steps + 1), label


def driven_key(scene: Scene) -> str | None:
    """The driven quantity judged besides the node outputs (None for load analyses)."""
    a = scene.analysis
    if a.kind == "distance":
        return "factor"
    if a.kind == "energy":
        return "driver.torque" if a.driver.kind == "rotation" else "driver.force"
    return None
