"""Loads that only axial stretch can follow: a trap for inextensible member models.

``linear-N`` segments and the PRB family (``prb-*``, ``prb-fsm-N``) have infinite axial
stiffness: a clamped beam whose end runs on a slider along its own axis, or a von Mises truss
of such members loaded before snap-through, cannot move at all in these models, and Newton
converges at once to zero displacement.  That answer satisfies the model's equations but says
nothing about the structure (the FE shows the axial shortening, then the snap).

``axial_only(sysm, scene, spec_of)`` compares the first-order response to the load at the
undeformed state (the load tangent of the KKT system) with that of the same scene whose
inextensible members are made extensible (``cbcm-2``: the same bending law, finite EA): when
the inextensible response is nil and the extensible one is not, the loaded mode is resisted
by the inextensibility alone, and the model declines with that reason.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cases.schema import Member, Scene
from reduced_models.beam.bcm import BCM_LAW
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.newton import Solver, State
from reduced_models.mechanism.system import MechanismSystem, SceneError

RATIO = 1e-6  # |du| inextensible / |du| extensible below which the load is resisted axially


def _inextensible(spec: tuple) -> bool:
    """Member law with infinite axial stiffness: PRB links, inextensible chains."""
    return spec[0] == "prb" or (spec[0] == "chain" and not spec[3])


def _node_response(sysm: MechanismSystem) -> float:
    """Norm of the node translations and end rotations (times the reference length) per
    unit load factor at the undeformed state."""
    solver = Solver(sysm)
    dx = solver.tangent(State(sysm.q0.copy(), np.zeros(sysm.m), 0.0), "lam")
    full = np.zeros(sysm.n)
    full[sysm.free] = dx[: solver.nf]
    lay = sysm.lay
    idx = np.array([[i, i + 1] for i in lay.node_dof.values()], dtype=np.int64).ravel()
    rot = np.array(sorted(set(lay.end_rot.values())), dtype=np.int64)
    return float(np.hypot(np.linalg.norm(full[idx]), lay.Lref * np.linalg.norm(full[rot])))


def axial_only(
    sysm: MechanismSystem, scene: Scene, spec_of: Callable[[Member], tuple]
) -> str | None:
    """The reason to decline when the load only stretches inextensible members, else None.

    Parameters
    ----------
    sysm : the system assembled with ``spec_of``.
    scene : the scene (a ``load`` or ``path`` analysis; other kinds are not checked).
    spec_of : member -> member law (``model.member_spec``).
    """
    if scene.analysis.kind not in ("load", "path") or not scene.loads:
        return None
    flex = [m for m in scene.members if m.kind == "flexible"]
    stiff = [m.id for m in flex if _inextensible(spec_of(m))]
    if not stiff:
        return None

    def extensible(m: Member) -> tuple:
        return ("chain", BCM_LAW, 2, True) if m.id in stiff else spec_of(m)

    try:
        ref = _node_response(build(scene, extensible))
    except SceneError:
        return None
    own = _node_response(sysm)
    if not (np.isfinite(own) and np.isfinite(ref)) or ref == 0.0 or own > RATIO * ref:
        return None
    return (
        "the load is resisted only by the axial inextensibility of member(s) "
        f"{', '.join(repr(i) for i in stiff)} (first-order displacement {own:.1e} against "
        f"{ref:.1e} with finite EA): this model would report zero motion; use cbcm-N or fem-auto"
    )


__all__ = ["axial_only"]
