"""Size and range limits every case file must respect, checked before the scene is built.

A hostile or mistaken file must end in one line naming the file, the key and the reason --
never in a crash, a hang or an exhausted memory.  The rules are general, not per key:

* the file is at most ``MAX_FILE_BYTES`` long and its tables/arrays nest at most
  ``MAX_DEPTH`` deep (``tomllib`` recurses per level: the loader turns its
  ``RecursionError`` on thousands of levels into the same error);
* every number anywhere in the tree is finite (model options may say ``inf``: a rigid PRB
  link) and of magnitude 0 or within [``MIN_MAGNITUDE``, ``MAX_MAGNITUDE``]: products of a
  few inputs (E*A, E*I/L^3) then stay normal floats, and an integer too large for a float
  is an error, not an ``OverflowError``;
* the counts of nodes, members, outputs, ... are bounded (``MAX_COUNT``), and so are the
  analysis step counts (``MAX_STEPS``): the solvers' work grows with them.

Every bound is named in the message, so a user who really needs more knows what to change.

The same holds for answers: ``state_violation`` is the check every model's returned states
pass (``reports.api.run_model``): finite outputs, rigid links at their lengths and flexible
members within ``STRAIN_MAX`` -- the bounds ``fem_reference.statics.integrity`` applies to the FE.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from cases.arc import arc_length

MAX_FILE_BYTES = 1_000_000  # the largest catalog case is ~5 kB
MAX_DEPTH = 16  # nesting of tables and arrays (a case needs 4)
MAX_MAGNITUDE = 1e30  # |x| of any number; MIN..MAX spans every unit system in use
MIN_MAGNITUDE = 1e-30  # smallest non-zero |x| (E*A, E*I*... stay far from underflow)
MAX_STRING = 10_000  # characters in any string (descriptions are a few hundred)
MAX_STEPS = 10_000  # analysis steps / max_steps (the catalog uses <= 600)
# entries per array of tables: enough for a 1000-element flexure drawn node by node
MAX_COUNT = {
    "nodes": 5_000,
    "members": 5_000,
    "outputs": 500,
    "loads": 5_000,
    "supports": 5_000,
    "references": 2_000,
    "models": 100,
}
MAX_ARRAY = 10_000  # entries of any other array (tags, sweep values, option lists)
MAX_GRID_POINTS = 2_000  # scenes of one sweep grid (the product of its axes; catalog: 125)

Fail = Callable[[str, str], Exception]

# -- what a returned state must satisfy, whichever model made it --------------------------------
STRAIN_MAX = 0.2  # axial strain of a flexible member: the elastic models' range (integrity.py)
RIGID_STRETCH_MAX = 1e-4  # relative length error of a rigid link (100 x a stiff link's)


def beyond(value: float, bound: float) -> bool:
    """``value`` past ``bound`` by more than round-off (1e-9 of it): a state exactly at a
    bound is within it in every drawing (a column shortened to exactly 20 % strain was
    declined in one unit system and accepted in another)."""
    return value > bound * (1.0 + 1e-9)


def check_size(text: str, fail: Fail) -> None:
    """Reject a file larger than ``MAX_FILE_BYTES`` before parsing it."""
    if len(text) > MAX_FILE_BYTES:
        raise fail("(file)", f"{len(text)} characters exceeds the limit of {MAX_FILE_BYTES}")


def check_tree(data: dict[str, Any], fail: Fail) -> None:
    """Depth, array lengths, string lengths and number ranges of the parsed TOML tree.

    Iterative (no recursion), linear in the size of the tree; keys are reported as paths
    (``members[2].E``).
    """
    todo: list[tuple[str, Any, int]] = [(k, v, 1) for k, v in data.items()]
    while todo:
        path, v, depth = todo.pop()
        if depth > MAX_DEPTH:
            raise fail(path, f"nested deeper than the limit of {MAX_DEPTH} levels")
        if isinstance(v, dict):
            todo += [(f"{path}.{k}", x, depth + 1) for k, x in v.items()]
        elif isinstance(v, list):
            bound = MAX_COUNT.get(path, MAX_ARRAY)
            if len(v) > bound:
                raise fail(path, f"{len(v)} entries exceed the limit of {bound}")
            todo += [(f"{path}[{i}]", x, depth + 1) for i, x in enumerate(v)]
        elif isinstance(v, str):
            if len(v) > MAX_STRING:
                raise fail(path, f"string of {len(v)} characters exceeds {MAX_STRING}")
        elif isinstance(v, int | float) and not isinstance(v, bool):
            if not (v == math.inf and "options" in path):  # +inf in options: rigid, e.g. PRB
                check_number(v, path, fail)


def check_number(v: float, path: str, fail: Fail) -> None:
    """One number: finite, and 0 or MIN_MAGNITUDE <= |v| <= MAX_MAGNITUDE."""
    if isinstance(v, int) and abs(v) > MAX_MAGNITUDE:  # float(v) may overflow
        raise fail(path, f"magnitude exceeds the limit of {MAX_MAGNITUDE:g}")
    if not math.isfinite(v):
        raise fail(path, "must be finite (NaN/inf not allowed)")
    if abs(v) > MAX_MAGNITUDE:
        raise fail(path, f"magnitude {abs(v):.3g} exceeds the limit of {MAX_MAGNITUDE:g}")
    if 0 < abs(v) < MIN_MAGNITUDE:
        raise fail(path, f"magnitude {abs(v):.3g} is below {MIN_MAGNITUDE:g} (write 0)")


def check_steps(v: int, path: str, fail: Fail) -> None:
    """A step count: 1 <= v <= MAX_STEPS."""
    if v > MAX_STEPS:
        raise fail(path, f"{v} exceeds the limit of {MAX_STEPS} steps")


# ratios of two changes: undefined (NaN, null in JSON) where both vanish -- the mechanical
# advantage at the unloaded first state -- which is no failure of the model
RATIO_OUTPUTS = ("ma",)


def state_violation(
    scene: Any,
    outputs: dict[str, float],
    rigid_max: float = RIGID_STRETCH_MAX,
    strain_max: float = STRAIN_MAX,
) -> str | None:
    """None, or why a model's state (its ``Step.outputs``) of ``scene`` is not an answer.

    A non-finite output; a rigid link or a flexible member between two nodes whose positions
    are known (output nodes, clamped or pinned nodes) with a rigid link off its length by more
    than ``rigid_max`` (default ``RIGID_STRETCH_MAX``; a model whose method drifts states
    its own) or a member stretched beyond ``strain_max`` (default ``STRAIN_MAX``) -- the chord
    over the undeformed length bounds the member's mean strain from below, whatever its shape.
    """
    for key, v in outputs.items():
        if not math.isfinite(v) and key not in RATIO_OUTPUTS:
            return f"output {key!r} is {v}: not an answer"
    nodes = {n.id: (n.x, n.y) for n in scene.nodes}
    pos = {s.node: nodes[s.node] for s in scene.supports if s.type in ("clamp", "pin")}
    for o in scene.outputs:
        if f"{o.name}.ux" in outputs and f"{o.name}.uy" in outputs and o.node in nodes:
            x, y = nodes[o.node]
            pos[o.node] = (x + outputs[f"{o.name}.ux"], y + outputs[f"{o.name}.uy"])
    for m in scene.members:
        if m.kind not in ("rigid", "flexible") or m.a not in pos or m.b not in pos:
            continue
        chord0 = math.dist(nodes[m.a], nodes[m.b])
        if chord0 == 0.0:
            continue
        chord = math.dist(pos[m.a], pos[m.b])
        if m.kind == "rigid" and beyond(abs(chord / chord0 - 1.0), rigid_max):
            return (
                f"rigid link {m.id!r} is {chord:.6g} long instead of {chord0:.6g} (bound "
                f"{rigid_max:g} relative): not a state of the scene"
            )
        e = chord / arc_length(chord0, m.sweep_deg) - 1.0
        if m.kind == "flexible" and beyond(e, strain_max):
            return (
                f"member {m.id!r} strained by at least {e:.2g} (bound {strain_max:g}): beyond "
                "the moderate-strain elastic models"
            )
    return None
