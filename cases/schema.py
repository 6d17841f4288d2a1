"""Frozen dataclasses describing a scene (one case file).

The scene is pure data: geometry, stiffness, supports, springs, loads, the analysis to run,
the outputs to report and the reference values to check against.  Nothing here solves.

Sign conventions (used by every model and by the FE reference)
-------------------------------------------------------------
* Global frame x to the right, y up, angles counter-clockwise positive, radians internally
  (case files give angles in degrees where the key ends in ``_deg``).
* Loads are given at load factor 1; a step with factor ``lam`` applies ``lam`` times them.
* A *follower* force keeps its angle relative to the tangent of the member end (or the body)
  it acts on; a dead force keeps its global direction.
* Output ``<name>.rot`` is the rotation (rad) of the material cross-section at the node
  (for a node with only pinned member ends: the mean of their rotations, and a moment
  applied there is split equally among them: ``cases.node_rotation``).
* ``Step.energy`` is the elastic strain energy stored (beams + springs) in the scene's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from cases.arc import arc_length

UNITS: dict[str, str] = {
    "m-N-Pa": "lengths in m, forces in N, moduli in Pa",
    "mm-N-MPa": "lengths in mm, forces in N, moduli in MPa (N/mm^2)",
    "in-lbf-psi": "lengths in in, forces in lbf, moduli in psi (lbf/in^2)",
    "nondim": "dimensionless (L = 1, EI = 1 typically)",
}
MEMBER_KINDS = ("flexible", "rigid", "spring")
END_KINDS = ("weld", "pin")
SUPPORT_TYPES = ("clamp", "pin", "slider", "guided")
ANALYSIS_KINDS = (
    "load",
    "path",
    "distance",
    "energy",
    "sweep",
    "kinematics",
    "synthesis",
    "deploy",
)
SYNTHESIS_GOALS = ("stiffness", "critical-load", "bistable", "stable-position")
#: per-member model names a case may assign (``[[members]] model = ...``; issue 9)
MEMBER_MODEL = (
    r"^(elastica|bcm|prb-short|prb-1r|prb-2r|prb-3r|prb-2rpr|prb-custom"
    r"|prb-fsm-[1-9][0-9]*|cbcm-[1-9][0-9]*|linear-[1-9][0-9]*)$"
)
# analyses a sweep may repeat at each grid point
SWEEP_OF_KINDS = ("load", "deploy")
REFERENCE_KINDS = ("closed-form", "published", "fe", "model")
NODE_QUANTITIES = ("x", "y", "ux", "uy", "rot")


@dataclass(frozen=True)
class Node:
    """A point of the drawing: id and undeformed coordinates (length units)."""

    id: str
    x: float
    y: float


@dataclass(frozen=True)
class Member:
    """A link between two nodes.

    ``kind`` is ``flexible`` (a beam: E, I, A), ``rigid`` (a rigid link; E/I/A optional and
    only used by models that replace it by a stiff beam) or ``spring`` (a linear axial spring
    with stiffness ``k`` [force/length] and free length ``free_length`` [length]).
    ``thickness`` is the in-plane thickness (used for bending stress sigma = M t / (2 I)).
    ``model`` (flexible members only) is the reduced model this member gets under the
    per-member model ``mixed`` (DAS-2D Ex. 3: PRB-3R short links, CBCM-2 long links), with
    ``model_options`` (e.g. a ``prb-custom`` matrix); every other model name ignores it.
    """

    id: str
    a: str
    b: str
    kind: str
    E: float | None = None
    I: float | None = None
    A: float | None = None
    thickness: float | None = None
    width: float | None = None
    end_a: str = "weld"
    end_b: str = "weld"
    k: float | None = None
    free_length: float | None = None
    density: float | None = None
    sweep_deg: float = 0.0  # circular arc from a to b through this central angle (cases.arc)
    model: str | None = None
    model_options: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)

    @property
    def EI(self) -> float:
        """Flexural rigidity E*I (force * length^2); NaN when not given."""
        return float(self.E * self.I) if self.E is not None and self.I is not None else math.nan

    @property
    def EA(self) -> float:
        """Axial rigidity E*A (force); NaN when not given."""
        return float(self.E * self.A) if self.E is not None and self.A is not None else math.nan


@dataclass(frozen=True)
class Support:
    """Ground connection of a node: ``clamp`` (x, y, rotation fixed), ``pin`` (x, y fixed),
    ``slider`` (moves along the direction ``angle_deg`` from the x axis, rotation free) or
    ``guided`` (rotation fixed, both translations free: the parallel-guided end)."""

    node: str
    type: str
    angle_deg: float = 0.0


@dataclass(frozen=True)
class TorsionSpring:
    """Rotational spring at ``node`` between member ``member_a`` and ``member_b`` (or ground
    when ``member_b`` is None).

    Torque = stiffness * (rot_a - rot_b - free_angle), where rot_* are the rotations of the
    member ends at the node from the drawn configuration (ground: 0).  A non-zero
    ``free_angle_deg`` is a preload: the spring is unloaded when the relative rotation equals it.
    """

    id: str
    node: str
    member_a: str
    member_b: str | None
    stiffness: float
    free_angle_deg: float = 0.0
    rest_angle_deg: float | None = None


@dataclass(frozen=True)
class Boom:
    """A tape-spring boom from the supported node ``a`` to node ``b`` (the thesis's Part 1 /
    Part 2 actuator).

    While its length |b - a| is below ``length`` it pushes ``b`` with the constant ``force``
    along the line a -> b (a conservative force: potential ``-force * |b - a|``); at
    ``length`` it locks and acts as a rigid bar.  A boom that cannot reach ``length``
    (insufficient force) stalls at the length where the mechanism balances it.
    """

    id: str
    a: str
    b: str
    force: float
    length: float
    # "lock" (default): a bar of exactly ``length`` from the moment it gets there; "damper":
    # the thesis's ADAMS collision damper (BISTOP, seed 001 Chapter 5): the push stays on and
    # an elastic stop of ``stop_stiffness`` (force/length) resists extension past ``length``
    # (dynamic; only ``replay`` models it)
    stop: str = "lock"
    stop_stiffness: float = 0.0


@dataclass(frozen=True)
class GridAxis:
    """One axis of a sweep grid: every scene key in ``keys`` (``table.id.field``, e.g.
    ``torsion_springs.S1.stiffness``) is set to each of ``values`` in turn."""

    keys: tuple[str, ...]
    values: tuple[float, ...]


@dataclass(frozen=True)
class Load:
    """A force/moment at load factor 1, at a node or at ``fraction`` along a member (from its
    node ``a``).  ``follower`` forces turn with the body they act on."""

    id: str
    fx: float = 0.0
    fy: float = 0.0
    moment: float = 0.0
    node: str | None = None
    member: str | None = None
    fraction: float | None = None
    follower: bool = False


@dataclass(frozen=True)
class Driver:
    """A prescribed coordinate for ``distance`` / ``energy`` analyses.

    ``kind = "displacement"``: node ``node`` moves in ``direction`` ("x" or "y") from
    ``start`` to ``stop`` (length).  ``kind = "rotation"``: member ``member`` rotates from
    ``start`` to ``stop`` (degrees).  In a ``distance`` analysis the unknown is the load
    factor; in an ``energy`` analysis the driver is a constraint and ``Step.factor`` is the
    driver coordinate (length, or degrees for a rotation).  Its reaction is reported as output
    ``driver.force`` (``driver.torque``): the force (moment) the driver exerts on the node
    (member) along the +direction (counter-clockwise), so pushing a slider towards -x gives a
    negative ``driver.force``.
    """

    kind: str
    start: float
    stop: float
    node: str | None = None
    direction: str | None = None
    member: str | None = None


@dataclass(frozen=True)
class Synthesis:
    """A synthesis goal (``[analysis.synthesis]``; DAS-2D "Flexural Stiffness Synthesis" and
    "Bistable Mechanism Synthesis").

    The flexural rigidities EI of ``members`` are scaled by one common factor s (found by
    the solver) so that:

    * ``goal = "stiffness"``: output ``output`` (an output key) equals ``target`` (length or
      rad) at load factor ``factor_end`` of the load ramp;
    * ``goal = "critical-load"``: the largest driving force (torque) between the first stable
      position and the energy barrier of the ``energy`` sweep of ``analysis.driver`` equals
      ``target`` in magnitude (the switching load of a bistable mechanism);
    * ``goal = "bistable"``: no sizing (``members`` empty, ``target`` NaN): the driver's range
      is searched for two stable equilibria with an unstable one between (both stable
      positions, the barrier and the switching loads both ways, or why it is not bistable);
      without ``analysis.driver`` every candidate driver is searched, both senses;
    * ``goal = "stable-position"``: no EI sizing: the length of the one rigid link in
      ``members`` is changed (its end-b node moves along the link, every other node stays)
      so that the second stable position of the ``energy`` sweep of ``analysis.driver`` is
      at driver coordinate ``target`` (DAS-2D "Stable Position Synthesis").
    """

    goal: str
    members: tuple[str, ...]
    target: float
    output: str | None = None


@dataclass(frozen=True)
class MechanicalAdvantage:
    """Mechanical advantage requested for ``energy``/``load``/``kinematics`` analyses
    (``[analysis.ma]``), reported per step as output ``ma``.

    Output coordinate s_out: ``direction`` (``x``, ``y`` or ``rot``) of the node of output
    ``output``.  Input: ``input = "driver"`` (the driver coordinate and its force/torque) or a
    load id (s_in = displacement of its point along the load, F_in = its magnitude times the
    factor).  From the power balance F_in ds_in = dU + F_out ds_out along the motion (U the
    elastic energy), ``ma = F_out / F_in = (1 - (dU/ds_in) / F_in) / (ds_out/ds_in)``; for a
    mechanism without stored energy this is the kinematic advantage ds_in/ds_out.
    """

    output: str
    direction: str
    input: str = "driver"


@dataclass(frozen=True)
class Analysis:
    """What to compute.

    ``load``: factor 0 -> ``factor_end`` in ``steps`` equal increments (solvers may cut steps
    internally; they report these steps).  ``path``: arc-length continuation until
    ``stop_output`` reaches ``stop_value`` or the factor reaches ``factor_end`` (inf when a stop
    output is given without it), at most ``max_steps`` steps.  ``distance``/``energy``: the
    ``driver`` goes from start to stop in ``steps``.  ``sweep``: ``load`` repeated for each
    value of ``sweep_values`` of the scene parameter ``sweep_key``; or, with ``grid``, the
    analysis ``sweep_of`` (``load`` or ``deploy``) at every point of the cartesian product of
    the grid axes (``sweep_key`` / ``sweep_values`` are read as a one-axis grid).  ``deploy``:
    the scene's booms push (Part 1) until they reach their length or stall, reported at
    ``steps`` + 1 points, ``Step.factor`` = boom extension progress (L - L0) / (L_deployed - L0)
    in [0, 1]; then (Part 2) the booms lock and the mechanism settles: one more step with
    ``factor`` = 2. Every deploy step reports ``<boom id>.length``.
    ``kinematics``: rigid-body motion of a mechanism without flexible members, driven by
    ``driver`` (``Step.factor`` = driver coordinate); ``mobility`` is the expected mobility
    (Gruebler count, checked by the solver).  ``synthesis``: see ``Synthesis``.  ``ma``:
    mechanical advantage output (``MechanicalAdvantage``).
    """

    kind: str = "load"
    steps: int = 20
    factor_end: float = 1.0
    stop_output: str | None = None
    stop_value: float | None = None
    max_steps: int = 400
    driver: Driver | None = None
    sweep_key: str | None = None
    sweep_values: tuple[float, ...] = ()
    grid: tuple[GridAxis, ...] = ()
    sweep_of: str = "load"
    mobility: int | None = None
    synthesis: Synthesis | None = None
    ma: MechanicalAdvantage | None = None


@dataclass(frozen=True)
class Output:
    """A reported point: node outputs are ``name.x``, ``name.y``, ``name.ux``, ``name.uy``,
    ``name.rot``."""

    name: str
    node: str


@dataclass(frozen=True)
class Reference:
    """A reference value with provenance.

    ``output`` is an output key (``tip.uy``) or ``factor``; ``at_factor`` the load factor the
    value belongs to (None: the last step).  ``kind`` is ``closed-form``, ``published``, ``fe``
    or ``model`` (an exact model named in ``source``).  ``tolerance`` is the relative (or, with
    ``abs_tolerance``, absolute) error a model must stay within to be called accurate here;
    ``rationale`` says why the tolerance is what it is.
    """

    output: str
    value: float
    kind: str
    source: str
    rationale: str
    tolerance: float
    at_factor: float | None = None
    abs_tolerance: bool = False


@dataclass(frozen=True)
class DesignTolerance:
    """An output a designer judges, and how closely (``[[tolerances]]`` in a case file).

    ``output`` is an output key (``stage.uy``), a point name (``stage``: the magnitude of that
    point's displacement error) or ``factor``.  Exactly one of ``rel`` (relative to the
    output's own excursion along the reference path, the yardstick of ``reports.verdicts.errors``)
    and
    ``abs`` (case units: length, rad, force, ...) is set.  ``floor`` (case units, optional)
    replaces the default floor under the excursion: an output whose excursion is below it is
    judged against the floor, never divided by ~0.  ``why`` says where the number comes from.
    """

    output: str
    why: str
    rel: float | None = None
    abs: float | None = None
    floor: float | None = None


@dataclass(frozen=True)
class ModelSpec:
    """A model the case recommends, with options (``prb-custom`` matrix, segment counts)."""

    name: str
    options: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)


@dataclass(frozen=True)
class Scene:
    """One validated case file."""

    name: str
    title: str
    units: str
    nodes: tuple[Node, ...]
    members: tuple[Member, ...]
    supports: tuple[Support, ...]
    loads: tuple[Load, ...]
    analysis: Analysis
    outputs: tuple[Output, ...]
    torsion_springs: tuple[TorsionSpring, ...] = ()
    references: tuple[Reference, ...] = ()
    models: tuple[ModelSpec, ...] = ()
    tolerances: tuple[DesignTolerance, ...] = ()
    tags: tuple[str, ...] = ()
    description: str = ""
    reference_model: str | None = None
    path: str = ""
    booms: tuple[Boom, ...] = ()
    # a point of a sweep: the parent case's name and ((scene key, value), ...) at this point
    sweep_parent: str | None = None
    sweep_point: tuple[tuple[str, float], ...] = ()

    # -- convenience lookups (cheap; scenes are small) ---------------------------------------
    def node(self, node_id: str) -> Node:
        """The node with this id (KeyError if absent)."""
        for n in self.nodes:
            if n.id == node_id:
                return n
        raise KeyError(node_id)

    def member(self, member_id: str) -> Member:
        """The member with this id (KeyError if absent)."""
        for m in self.members:
            if m.id == member_id:
                return m
        raise KeyError(member_id)

    def support_at(self, node_id: str) -> Support | None:
        """The support at a node, or None."""
        for s in self.supports:
            if s.node == node_id:
                return s
        return None

    def member_length(self, member_id: str) -> float:
        """Undeformed length of a member (length units; the arc length of a curved one)."""
        m = self.member(member_id)
        a, b = self.node(m.a), self.node(m.b)
        return arc_length(math.hypot(b.x - a.x, b.y - a.y), m.sweep_deg)

    def output_keys(self) -> list[str]:
        """All scalar output keys this scene reports, in order."""
        keys = [f"{o.name}.{q}" for o in self.outputs for q in NODE_QUANTITIES]
        return keys + [f"{b.id}.length" for b in self.booms]

    def model_options(self, name: str) -> dict[str, Any]:
        """Options the case gives for a model name (empty dict if none)."""
        for spec in self.models:
            if spec.name == name:
                return dict(spec.options)
        return {}
