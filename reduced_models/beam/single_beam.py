"""Recognise single-beam scenes and move between the global frame and the beam frame.

Most reduced models (elastica, linear, PRB, BCM) describe one initially straight beam of
length L clamped at its root and loaded at its tip.  ``cantilever_of(scene)`` extracts that
problem in the beam's own frame (x along the undeformed beam, y to its left) or returns the
reason it cannot; ``tip_outputs`` maps a beam-frame solution back to the scene's outputs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from cases.schema import Scene
from reduced_models.base import Step


@dataclass(frozen=True)
class Cantilever:
    """A clamped-free (or clamped-guided) straight beam in its own frame.

    Attributes
    ----------
    L, EI, EA : length, flexural and axial rigidity (scene units); EA may be inf.
    thickness : in-plane thickness for stress (None if unknown).
    fx, fy, m : tip loads at factor 1 in the beam frame (fx along the beam, tension +).
    follower : True if the tip force is a follower force (turns with the tip tangent).
    guided : True if the tip rotation is held at zero (fixed-guided beam, translations free).
    root, tip : node ids; c, s : direction cosines of the undeformed beam, root to tip
    (global; the drawn dx / L, dy / L: exactly 0 and 1 along an axis, where cos(atan2) left
    6e-17 of the tip load across a vertical column).
    origin : root coordinates (global).
    member : member id.
    """

    L: float
    EI: float
    EA: float
    thickness: float | None
    fx: float
    fy: float
    m: float
    follower: bool
    guided: bool
    root: str
    tip: str
    c: float
    s: float
    origin: tuple[float, float]
    member: str

    def rotate_to_global(self, xy: np.ndarray) -> np.ndarray:
        """Beam-frame points (..., 2) -> global points (..., 2)."""
        c, s = self.c, self.s
        R = np.array([[c, -s], [s, c]])
        xy = np.asarray(xy)
        # one (n, 2) x (2, 2) product: a stack of steps (m, n, 2) would loop over m
        return (xy.reshape(-1, 2) @ R.T).reshape(xy.shape) + np.asarray(self.origin)


# the last scene asked about and its answer: a model's router, ``applies_to`` and ``solve``
# all ask for the same (immutable) scene, and a 1-DOF solve costs little more than the asking
_LAST: list = [None, None]


def cantilever_of(scene: Scene) -> Cantilever | str:
    """The single-beam problem of ``scene``, or a one-line reason it is not one."""
    if _LAST[0] is scene:
        return _LAST[1]
    beam = _cantilever_of(scene)
    _LAST[0], _LAST[1] = scene, beam
    return beam


def _cantilever_of(scene: Scene) -> Cantilever | str:
    flex = [m for m in scene.members if m.kind == "flexible"]
    if len(scene.members) != 1 or len(flex) != 1:
        return "not a single flexible member (mechanism scenes need the mechanism assembler)"
    mem = flex[0]
    if scene.torsion_springs:
        return "torsion springs are not part of a single-beam model"
    clamps = [s for s in scene.supports if s.type == "clamp"]
    if len(clamps) != 1:
        return "single-beam models need exactly one clamped end"
    root = clamps[0].node
    tip = mem.b if root == mem.a else mem.a
    others = [s for s in scene.supports if s.node != root]
    guided = False
    if others:
        if len(others) == 1 and others[0].type == "guided" and others[0].node == tip:
            guided = True
        else:
            return "the free end is supported (only a 'guided' tip is modelled)"
    ends = {mem.a: mem.end_a, mem.b: mem.end_b}
    if ends[root] != "weld":
        return "the beam is pinned (end 'pin') to its clamped node: a pinned root, not a cantilever"
    if ends[tip] != "weld" and (guided or any(ld.moment for ld in scene.loads)):
        return "the beam's tip end is a free hinge: the guide or tip moment does not act on it"
    if any(ld.node != tip or ld.member is not None for ld in scene.loads):
        return "loads must act at the free end of the beam"
    follower = {ld.follower for ld in scene.loads if ld.fx or ld.fy}
    if len(follower) > 1:
        return "mixed dead and follower tip forces"
    if scene.analysis.kind not in ("load", "path"):
        return f"analysis kind {scene.analysis.kind!r} is not a load ramp"
    if not math.isfinite(scene.analysis.factor_end):
        return "a path traced to its stop output (no factor_end) needs arc-length continuation"
    if mem.sweep_deg:
        return "the member is a circular arc (sweep_deg): single-beam models are straight"
    r, t = scene.node(root), scene.node(tip)
    L = math.hypot(t.x - r.x, t.y - r.y)
    c, s = (t.x - r.x) / L, (t.y - r.y) / L
    fxg = sum(ld.fx for ld in scene.loads)
    fyg = sum(ld.fy for ld in scene.loads)
    fx, fy = c * fxg + s * fyg, -s * fxg + c * fyg
    return Cantilever(
        L=L,
        EI=mem.EI,
        EA=mem.EA if math.isfinite(mem.EA) else math.inf,
        thickness=mem.thickness,
        fx=fx,
        fy=fy,
        m=sum(ld.moment for ld in scene.loads),
        follower=bool(follower and follower.pop()),
        guided=guided,
        root=root,
        tip=tip,
        c=c,
        s=s,
        origin=(r.x, r.y),
        member=mem.id,
    )


def tip_outputs(scene: Scene, beam: Cantilever, x: float, y: float, rot: float) -> dict:
    """Scene outputs for a beam-frame tip state (x, y position; rot = tip rotation, rad)."""
    return output_map(scene, beam)(x, y, rot)


def output_map(scene: Scene, beam: Cantilever) -> Callable[[float, float, float], dict]:
    """``tip_outputs`` for one scene as a function of (x, y, rot): the output keys, node
    positions and the rotation are looked up once per solve, not once per step."""
    c, s = beam.c, beam.s
    ox, oy = beam.origin
    rows = []
    for o in scene.outputs:
        if o.node not in (beam.root, beam.tip):
            raise KeyError(f"output {o.name!r}: node {o.node!r} is not an end of the beam")
        n = scene.node(o.node)
        keys = tuple(f"{o.name}.{q}" for q in ("x", "y", "ux", "uy", "rot"))
        rows.append((keys, o.node == beam.tip, float(n.x), float(n.y)))

    def outputs(x: float, y: float, rot: float) -> dict:
        gx, gy = ox + c * x - s * y, oy + s * x + c * y
        out: dict[str, float] = {}
        for (kx, ky, kux, kuy, krot), at_tip, nx, ny in rows:
            px, py, pr = (gx, gy, rot) if at_tip else (ox, oy, 0.0)
            out[kx], out[ky], out[kux], out[kuy], out[krot] = px, py, px - nx, py - ny, pr
        return out

    return outputs


def stress_from_curvature(scene: Scene, beam: Cantilever, kappa: np.ndarray) -> float | None:
    """Largest |sigma| = E t |kappa| / 2 over the sampled curvatures kappa (1/length)."""
    mem = scene.member(beam.member)
    if mem.thickness is None or mem.E is None:
        return None
    return float(mem.E * mem.thickness * np.max(np.abs(kappa)) / 2.0)


def steps_with_shapes(
    scene: Scene, beam: Cantilever, steps: Sequence[Step], pts: np.ndarray, kmax: np.ndarray
) -> tuple[Step, ...]:
    """``steps`` with the member's deformed shape and largest bending stress of each step.

    Parameters
    ----------
    pts : (m, P, 2) centre-line points of each step in global coordinates (length units).
    kmax : (m,) largest |curvature| of each step (1/length); the stress is
        ``stress_from_curvature``'s E t kmax / 2, all steps at once (None without E, t).
    """
    mem = scene.member(beam.member)
    if mem.thickness is None or mem.E is None:
        stress = [None] * len(steps)
    else:
        stress = (mem.E * mem.thickness * np.asarray(kmax) / 2.0).tolist()
    return tuple(
        Step(
            st.factor, st.outputs, st.energy, st.iterations, st.stable,
            {beam.member: xy}, sig, st.info,
        )
        for st, xy, sig in zip(steps, pts, stress)
    )  # fmt: skip


def unstable_note(steps: Sequence[Step]) -> str:
    """``"; ..."`` saying that a path ends on an unstable equilibrium (its stability test
    says so), else ``""``: a converged answer on an unstable branch is never silent."""
    if steps and steps[-1].stable is False:
        first = next(s.factor for s in steps if s.stable is False)
        return (
            f"; unstable equilibria from factor {first:.4g} to the end (the path stayed on "
            "a branch that lost stability: a bifurcation needs an imperfection)"
        )
    return ""
