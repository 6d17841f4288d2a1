"""Sweep grids: scene keys, their validation and the expansion of a sweep into point scenes.

A scene key names one number of a scene as ``table.id.field``:

* ``torsion_springs.<id>.stiffness`` | ``.free_angle_deg`` | ``.rest_angle_deg``
* ``booms.<id>.force`` | ``.length``
* ``loads.<id>.fx`` | ``.fy`` | ``.moment``
* ``members.<id>.E`` | ``.I`` | ``.A`` | ``.k`` | ``.free_length``
* ``nodes.<id>.x`` | ``.y``

``expand(scene)`` turns a ``sweep`` scene into one scene per point of the cartesian product of
its grid axes, each with ``analysis.kind = sweep_of`` and ``sweep_point`` recording the
coordinates.  Pure data: nothing here solves.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

from cases.schema import Scene, TorsionSpring

FIELDS: dict[str, tuple[str, ...]] = {
    "torsion_springs": ("stiffness", "free_angle_deg", "rest_angle_deg"),
    "booms": ("force", "length"),
    "loads": ("fx", "fy", "moment"),
    "members": ("E", "I", "A", "k", "free_length"),
    "nodes": ("x", "y"),
}
# values that must stay > 0 after substitution
POSITIVE = {"stiffness", "force", "length", "E", "I", "A", "k"}


def key_error(scene: Scene, key: str) -> str | None:
    """None if ``key`` names a number of ``scene``, else the reason it does not."""
    parts = key.split(".")
    if len(parts) != 3:
        return f"{key!r} is not of the form table.id.field"
    table, ident, fld = parts
    if table not in FIELDS:
        return f"{key!r}: table {table!r} cannot be swept (one of: {', '.join(FIELDS)})"
    if fld not in FIELDS[table]:
        return f"{key!r}: field {fld!r} cannot be swept (one of: {', '.join(FIELDS[table])})"
    if not any(_ident(item) == ident for item in getattr(scene, table)):
        return f"{key!r}: no {table} entry with id {ident!r}"
    return None


def _ident(item: object) -> str:
    return item.id


def wrap_deg(angle: float) -> float:
    """Angle wrapped to (-180, 180] degrees."""
    a = math.fmod(angle + 180.0, 360.0)
    a = a + 360.0 if a <= 0.0 else a
    return a - 180.0


def member_angle_deg(scene: Scene, member_id: str | None) -> float:
    """Drawn direction of a member's from -> to vector (deg, ccw from +x); ground: 0."""
    if member_id is None:
        return 0.0
    m = scene.member(member_id)
    a, b = scene.node(m.a), scene.node(m.b)
    return math.degrees(math.atan2(b.y - a.y, b.x - a.x))


def free_from_rest(scene: Scene, spring: TorsionSpring, rest_deg: float) -> float:
    """``free_angle_deg`` of a spring whose unloaded absolute angle is ``rest_deg``."""
    drawn = member_angle_deg(scene, spring.member_a) - member_angle_deg(scene, spring.member_b)
    return wrap_deg(rest_deg - drawn)


def substitute(scene: Scene, key: str, value: float) -> Scene:
    """``scene`` with the number named by ``key`` set to ``value`` (key assumed valid)."""
    table, ident, fld = key.split(".")
    items = []
    for item in getattr(scene, table):
        if _ident(item) == ident:
            if table == "torsion_springs" and fld == "rest_angle_deg":
                item = dataclasses.replace(
                    item, rest_angle_deg=value, free_angle_deg=free_from_rest(scene, item, value)
                )
            elif table == "torsion_springs" and fld == "free_angle_deg":
                item = dataclasses.replace(item, free_angle_deg=value, rest_angle_deg=None)
            else:
                item = dataclasses.replace(item, **{fld: value})
        items.append(item)
    return dataclasses.replace(scene, **{table: tuple(items)})


def points(scene: Scene) -> list[tuple[tuple[str, float], ...]]:
    """The grid points of a sweep scene, in row-major order of its axes: each point is a
    tuple of (key, value) pairs (an axis with several keys gives them all the same value)."""
    axes = scene.analysis.grid
    out = []
    for combo in itertools.product(*(ax.values for ax in axes)):
        out.append(tuple((k, v) for ax, v in zip(axes, combo) for k in ax.keys))
    return out


def expand(scene: Scene) -> list[Scene]:
    """One scene per grid point (a non-sweep scene is returned alone)."""
    a = scene.analysis
    if a.kind != "sweep":
        return [scene]
    inner = dataclasses.replace(a, kind=a.sweep_of, grid=(), sweep_key=None, sweep_values=())
    out = []
    for i, point in enumerate(points(scene)):
        s = scene
        for key, value in point:
            s = substitute(s, key, value)
        out.append(
            dataclasses.replace(
                s,
                name=f"{scene.name}/p{i:03d}",
                analysis=inner,
                sweep_parent=scene.name,
                sweep_point=point,
            )
        )
    return out
