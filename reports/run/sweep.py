"""Sweep cases in the benchmark matrix: one scene (and one stored row per model) per grid point.

``cases.sweep.expand`` does the expansion (pure scene data); this module decides what the
runner does with it: point scenes run the models their parent case names (plus the
reference), not the whole default list, so a 125-point grid costs 125 x (a few) solves; each
point's meta carries its parent and coordinates so the report can draw stability maps.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from cases.schema import Scene
from cases.sweep import expand


def expand_all(scenes: Sequence[Scene], thin: bool = False) -> list[Scene]:
    """Every sweep scene replaced by its point scenes (others unchanged, order kept).

    ``thin`` (the ``--quick`` matrix) keeps each grid axis' first, middle and last values, so
    a 5 x 5 x 5 grid runs as 3 x 3 x 3: the map's corners and centre, at a fifth of the cost.
    """
    return [p for s in scenes for p in expand(_thinned(s) if thin else s)]


def _thinned(scene: Scene) -> Scene:
    a = scene.analysis
    if a.kind != "sweep" or not a.grid:
        return scene
    grid = tuple(
        dataclasses.replace(
            ax,
            values=tuple(
                ax.values[i] for i in sorted({0, len(ax.values) // 2, len(ax.values) - 1})
            ),
        )
        for ax in a.grid
    )
    return dataclasses.replace(scene, analysis=dataclasses.replace(a, grid=grid))


def point_meta(scene: Scene) -> dict[str, Any]:
    """``{"sweep": {"parent", "point": {key: value}}}`` for a point scene, else ``{}``."""
    if scene.sweep_parent is None:
        return {}
    return {"sweep": {"parent": scene.sweep_parent, "point": dict(scene.sweep_point)}}


def uses_defaults(scene: Scene) -> bool:
    """Whether the default model list is added for this scene (not for sweep points)."""
    return scene.sweep_parent is None


def single_shot(scene: Scene, policy: Any) -> Any:
    """Sweep points are timed once (the sweep's total is the figure of merit, not the
    median of repeats of one point): ``policy`` with no repeats for points."""
    if scene.sweep_parent is None or policy is None:
        return policy
    return dataclasses.replace(policy, cold_cap_s=0.0, max_runs=1, min_runs=1)


def export_for(scene: Scene, policy: Any) -> Any:
    """No ParaView series or GIFs per sweep point (hundreds of them): None for points."""
    return policy if scene.sweep_parent is None else None
