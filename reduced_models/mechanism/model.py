"""Model-protocol layer of the mechanism assembler: member laws by model name, ``kinetostatic``,
``mixed``, and the dispatch that lets every reduced model name solve mechanism scenes.

* ``member_spec(name, options)`` -> the member law of a reduced model name (or the reason it
  has none): ``linear-N``/``bcm``/``cbcm-N`` -> chained segments; the PRB family -> its PRB
  matrix (``prb_tables``); ``elastica`` -> the extensible elastica by shooting per member
  (``elastica_member``; ``elastica-bvp`` stays a single-beam solver).
* ``MechanismModel(name)`` puts that law into every flexible member; ``Kinetostatic`` solves
  scenes without flexible members; ``Mixed`` reads each member's ``model`` key.
* ``reduced_models.routing.routed`` gives a registered single-beam model the mechanism route
  (plain cantilever scenes keep their specialised solver, every other scene comes here).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from cases.schema import Member, Scene
from reduced_models.base import ModelCard, Solution, not_applicable
from reduced_models.beam import prb_tables as T
from reduced_models.beam.bcm import BCM_LAW
from reduced_models.beam.linear import LINEAR_LAW
from reduced_models.beam.prb_chain import check_matrix
from reduced_models.mechanism import analyses
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.inextensible import axial_only
from reduced_models.mechanism.system import MechanismSystem, SceneError

ANALYSES = ("load", "path", "distance", "energy", "kinematics", "synthesis", "deploy")
_PRB_FIXED = {
    "prb-short": lambda o: T.PRB_SHORT,
    "prb-2r": lambda o: T.PRB_2R,
    "prb-3r": lambda o: T.prb3r_matrix(o.get("stiffness", "average")),
    "prb-3r-force": lambda o: T.prb3r_matrix("force"),
    "prb-3r-moment": lambda o: T.prb3r_matrix("moment"),
    "prb-2rpr": lambda o: T.prb2rpr_matrix(),
    # load-ratio dependent in a cantilever; in a mechanism the load ratio of a member is not
    # known beforehand, so Howell's average parameters are used (documented in the card)
    "prb-1r": lambda o: T.prb1r_matrix(T.HOWELL_AVERAGE["gamma"], T.HOWELL_AVERAGE["K_Theta"]),
}


def member_spec(name: str, options: dict | None = None) -> tuple | str:
    """Member law of a reduced model name: ``("chain", law, N, extensible)``,
    ``("prb", matrix)``, or the reason the name has no member law."""
    o = dict(options or {})
    if name in _PRB_FIXED:
        try:
            return ("prb", _PRB_FIXED[name](o))
        except (KeyError, ValueError) as err:
            return f"{name}: bad options ({err})"
    if name == "prb-custom":
        if "matrix" not in o:
            return "prb-custom needs options.matrix = [[k_theta, k_ex, gamma], ...]"
        try:
            return ("prb", check_matrix(o["matrix"]))
        except ValueError as err:
            return f"prb-custom: options.matrix: {err}"
    if name == "bcm":
        return ("chain", BCM_LAW, 1, True)
    family, _, n = name.rpartition("-")
    if n.isdigit() and int(n) >= 1:
        if family == "cbcm":
            return ("chain", BCM_LAW, int(n), True)
        if family == "linear":
            return ("chain", LINEAR_LAW, int(n), False)
        if family == "prb-fsm":
            return ("prb", T.fsm_matrix(int(n), o.get("placement", "mid")))
    if name == "elastica":  # exact member law by shooting (mechanism/elastica_member.py)
        return ("elastica",)
    if name.startswith("elastica"):
        return f"{name}: single-beam solver only; `elastica` carries the member law in mechanisms"
    return f"{name}: no member energy law in the mechanism assembler"


def _check_scene(scene: Scene) -> str | None:
    kind = scene.analysis.kind
    if kind not in ANALYSES:
        return f"analysis kind {kind!r} is not run by the mechanism assembler"
    if any(ld.follower and (ld.fx or ld.fy) for ld in scene.loads):
        return "follower loads are non-conservative: the energy-based assembler takes dead loads"
    if any(getattr(m, "sweep_deg", None) for m in scene.members):
        return "curved (arc) members are not modelled by the mechanism assembler"
    return None


def _held(scene: Scene, node: str, member: str) -> bool:
    """Is the node tied to something other than this member (support or another member)?"""
    if scene.support_at(node) is not None:
        return True
    return any(m.id != member and node in (m.a, m.b) for m in scene.members)


def _locked_prb(scene: Scene, name: str, spec: tuple, flex: list[Member]) -> str | None:
    """A one-joint PRB member welded at both ends to held nodes cannot bend (its end-b
    section turns with its only link, so both end rotations fix the link): decline."""
    if spec[0] != "prb" or int(np.isfinite(spec[1][:, 0]).sum()) >= 2:
        return None
    for m in flex:
        if m.end_a == m.end_b == "weld" and _held(scene, m.a, m.id) and _held(scene, m.b, m.id):
            return (
                f"{name} has one PRB joint: member {m.id!r} is welded at both ends (fixed-guided) "
                "and needs two joints (Howell: two 1R halves); use prb-3r or prb-fsm-N"
            )
    return None


class MechanismModel:
    """A reduced model name applied to every flexible member of a mechanism scene."""

    def __init__(self, name: str, options: dict | None = None) -> None:
        self.name = name
        self.options = dict(options or {})
        self.card = ModelCard(
            name=name,
            family="mechanism",
            summary=f"mechanism assembler, every flexible member modelled by {name}",
            assumptions=(
                "node-based assembly: member energy laws in node poses + internal unknowns",
                "rigid links are loop-closure constraints (exact), constrained Newton (KKT)",
                "dead loads only; a flexible member loaded inside is split at the load point",
                "prb-1r in a mechanism: Howell's average gamma 0.85, K_Theta 2.65",
                "PRB members: the end-b section turns with the last PRB link",
                "bending stress: chained segments from the cubic Hermite curvature at segment "
                "ends; PRB members from the joint moments (M t / 2I, coarse)",
            ),
            validity="that of the member model in each flexible member",
            references=("DAS-2D seed 000_265bc60728766176.txt, 'Solver- Kinetostatic Analysis'",),
        )

    def spec_of(self, scene: Scene) -> tuple[Callable[[Member], tuple], tuple | str]:
        opts = {**scene.model_options(self.name), **self.options}
        spec = member_spec(self.name, opts)

        def of(m: Member) -> tuple:
            if isinstance(spec, str):
                raise SceneError(spec)
            return spec

        return of, spec

    def applies_to(self, scene: Scene) -> str | None:
        """None, or why the assembler cannot solve ``scene`` with this member model."""
        reason = _check_scene(scene)
        if reason:
            return reason
        flex = [m for m in scene.members if m.kind == "flexible"]
        if not flex:
            return "no flexible member: solved by `kinetostatic`"
        if scene.analysis.kind == "kinematics":
            return "kinematics (rigid-body motion) needs a scene without flexible members"
        _, spec = self.spec_of(scene)
        if isinstance(spec, str):
            return spec
        return _locked_prb(scene, self.name, spec, flex)

    def solve(self, scene: Scene) -> Solution:
        """Run the scene's analysis (never raises for a numerical failure)."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        of, _ = self.spec_of(scene)
        return solve_with(scene, self.name, of)

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """Shapes and stress of the reported steps (module function ``postprocess``)."""
        return postprocess(scene, sol)


class Kinetostatic(MechanismModel):
    """``kinetostatic``: mechanisms of rigid links, springs (no flexible member)."""

    OPTIONS: dict = {}  # declared options (reduced_models.options): none

    def __init__(self, **options) -> None:
        super().__init__("kinetostatic", options)
        self.card = ModelCard(
            name="kinetostatic",
            family="mechanism",
            summary="rigid links (closure constraints) + torsion/linear springs, energy "
            "minimisation under constraints (DAS-2D kinetostatic analysis)",
            assumptions=("rigid links exact", "dead loads", "springs linear"),
            validity="exact for the idealised scene (rigid links, linear springs)",
            references=self.card.references,
        )

    def applies_to(self, scene: Scene) -> str | None:
        reason = _check_scene(scene)
        if reason:
            return reason
        if any(m.kind == "flexible" for m in scene.members):
            return "scene has flexible members: use a reduced model (cbcm-N, prb-3r, ...)"
        return None

    def solve(self, scene: Scene) -> Solution:
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        return solve_with(scene, self.name, lambda m: ("none",))


class Mixed(MechanismModel):
    """``mixed``: each flexible member gets its own ``model`` (DAS-2D Ex. 3)."""

    OPTIONS: dict = {}  # declared options (reduced_models.options): none (per-member options)

    def __init__(self, **options) -> None:
        super().__init__("mixed", options)
        self.card = ModelCard(
            name="mixed",
            family="mechanism",
            summary="mechanism assembler with the per-member models of the case "
            "([[members]] model = ...)",
            assumptions=self.card.assumptions,
            validity="that of each member's model",
            references=self.card.references,
        )

    def applies_to(self, scene: Scene) -> str | None:
        reason = _check_scene(scene)
        if reason:
            return reason
        flex = [m for m in scene.members if m.kind == "flexible"]
        if not flex:
            return "no flexible member: solved by `kinetostatic`"
        missing = [m.id for m in flex if m.model is None]
        if missing:
            return f"member {missing[0]!r} has no per-member model ([[members]] model = ...)"
        for m in flex:
            spec = member_spec(m.model, m.model_options)
            if isinstance(spec, str):
                return f"member {m.id!r}: {spec}"
            locked = _locked_prb(scene, m.model, spec, [m])
            if locked:
                return locked
        return None

    def solve(self, scene: Scene) -> Solution:
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        return solve_with(scene, self.name, lambda m: member_spec(m.model, m.model_options))


def solve_with(scene: Scene, name: str, spec_of: Callable[[Member], tuple]) -> Solution:
    """Assemble and run; SceneError -> not-applicable, numerical trouble -> failed."""
    kind = scene.analysis.kind
    try:
        if kind == "synthesis":
            from reduced_models.mechanism.synthesis import synthesise

            return synthesise(scene, name, spec_of)
        sysm = build(scene, spec_of)
        axial = axial_only(sysm, scene, spec_of)
    except SceneError as err:
        return not_applicable(scene, name, str(err))
    if axial:
        return not_applicable(scene, name, axial)
    if kind in ("distance", "energy", "kinematics") and (why := analyses.stalled_driver(sysm)):
        return not_applicable(scene, name, why)
    if kind == "deploy":
        from reduced_models.mechanism.deploy_staged import deploy_any as deploy

        return deploy(sysm, name)
    r = analyses.run(sysm, kind, lazy=True)
    return finish(scene, name, r)


def finish(scene: Scene, name: str, r: analyses.Run) -> Solution:
    """Solution from a finished (or failed) run, with MA outputs when requested."""
    if scene.analysis.ma is not None and r.steps:
        from reduced_models.mechanism.advantage import add_ma

        r.steps = add_ma(r)
    extras = r.extras
    if getattr(r, "lazy", False):  # shapes and stress of the steps by ``postprocess``
        extras = {**extras, "_post": _Post(r.s, [st.q for st in r.states])}
    if r.exc is not None:
        return Solution(scene.name, name, "failed", r.exc, tuple(r.steps), extras)
    its = sum(s.iterations for s in r.steps)
    msg = f"{len(r.steps)} steps, {its} Newton iterations, {r.extras['ndof']} unknowns"
    msg += "".join(
        f"; snap at factor {p['factor']:.8g}: the path jumps to another branch "
        "(critical_points: from, to)"
        for p in r.extras.get("critical_points", ())
        if p["kind"] == "snap"
    )
    lost = [s for s in r.steps if s.stable is False]
    if scene.analysis.kind == "load" and lost:
        # load control stays on the branch it started on: say so rather than let a path of
        # unstable equilibria (a straight column past buckling) pass as the answer
        msg += (
            f"; equilibria unstable from load factor {lost[0].factor:g} on (reduced Hessian): "
            "the load path crossed a bifurcation or limit point, run a `path` analysis"
        )
    return Solution(scene.name, name, "converged", msg, tuple(r.steps), extras)


class _Post:
    """The assembled system and the state of every step, kept in ``extras["_post"]`` for
    ``postprocess`` (not JSON: ``reports.run.store.extras_json`` drops it)."""

    def __init__(self, sysm: MechanismSystem, qs: list[np.ndarray]) -> None:
        self.sysm, self.qs = sysm, qs


def postprocess(scene: Scene, sol: Solution) -> Solution:
    """Shapes and bending stress of every step from the states the solve kept (outside the
    timed solve); ``sol`` unchanged when it kept none."""
    post = sol.extras.get("_post")
    if not isinstance(post, _Post):
        return sol
    s = post.sysm
    steps = tuple(
        dataclasses.replace(st, shapes=s.shapes(q), max_stress=s.max_stress(q))
        for st, q in zip(sol.steps, post.qs)
    )
    extras = {k: v for k, v in sol.extras.items() if k != "_post"}
    return dataclasses.replace(sol, steps=steps, extras=extras)


__all__ = ["Kinetostatic", "MechanismModel", "Mixed", "member_spec"]
