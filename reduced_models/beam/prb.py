"""Pseudo-rigid-body (PRB) models of a cantilever through the PRB matrix: the registered models.

Every PRB model here is a chain of rigid segments described by a PRB matrix
``[[k_theta, k_ex, gamma], ...]`` (see ``prb_tables``): segment i has length gamma_i L (plus an
axial stretch u_i when k_ex_i is finite), a torsion spring k_theta_i EI/L at its proximal end
(absent when infinite) and an axial spring k_ex_i EA/L (rigid when infinite).  The chain
numerics -- kinematics, energy with analytic gradient and Hessian, the equilibrium path
through the shared continuation, end-load recovery by pinv(J^T), shape and stress from the
elastica -- are in ``reduced_models.beam.prb_chain`` (re-exported here).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import replace

import numpy as np

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable
from reduced_models.beam import prb_tables as T
from reduced_models.beam.prb_chain import (
    RESIDUAL_TOL,
    PRBChain,
    check_matrix,
    equilibrium_path,
)
from reduced_models.beam.prb_post import (
    recover_tip_loads,
    recover_tip_loads_batch,
    shape_and_stress,
)
from reduced_models.beam.single_beam import Cantilever, cantilever_of, output_map, unstable_note
from reduced_models.options import SHAPES, Option

__all__ = [
    "RESIDUAL_TOL",
    "PRB1R",
    "PRB2R",
    "PRB2RPR",
    "PRB3R",
    "PRB3RForce",
    "PRB3RMoment",
    "PRBChain",
    "PRBCustom",
    "PRBFSM",
    "PRBModel",
    "PRBShort",
    "check_matrix",
    "equilibrium_path",
    "recover_tip_loads",
    "shape_and_stress",
]

_REF = "Venkiteswaran & Su, Precis. Eng. 40:46-54, 2015, doi 10.1016/j.precisioneng.2014.10.002"
_SEED = "seed 000_265bc60728766176.txt: PRB matrix, Jacobian, shape and stress slides"

_COMMON = (
    "rigid segments joined by linear torsion springs (PRB matrix)",
    "dead tip loads only (energy formulation; follower loads are declined)",
    "shape: the PRB's own pivots and rigid links; stress from the bending moment of the end "
    "loads recovered from the PRB's spring forces by pinv(J^T), at the root, pivots and tip",
)


class PRBModel:
    """A PRB model of a single cantilever defined by a PRB matrix (subclasses pick it)."""

    # small- or intermediate-deflection kinematics: a tip beyond the member's reach under
    # loads is this model's error, not a stretch (reports.api.checked)
    approximate_kinematics = True

    name = "prb"
    card = ModelCard(name="prb", family="prb", summary="PRB chain", assumptions=_COMMON)

    OPTIONS = dict(SHAPES)

    def __init__(self, matrix: object = None, shapes: bool = True) -> None:
        self._matrix = None if matrix is None else check_matrix(matrix)
        self.shapes = bool(shapes)

    # subclasses override: (matrix, tip-angle factor, note) for this cantilever, or a reason
    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """PRB matrix, tip-angle factor and a note for this cantilever, or why not."""
        if self._matrix is None:
            return "no PRB matrix given"
        return self._matrix, 1.0, ""

    def _beam(self, scene: Scene) -> Cantilever | str:
        beam = cantilever_of(scene)
        if isinstance(beam, str):
            return beam
        if beam.follower:
            return (
                "follower tip loads are non-conservative; energy-based PRB models take dead loads"
            )
        if scene.analysis.kind != "load":
            return f"analysis kind {scene.analysis.kind!r}: PRB models follow a load ramp only"
        if not (math.isfinite(beam.EI) and beam.EI > 0):
            return "flexural rigidity EI of the beam is not given"
        return beam

    def _prepare(self, scene: Scene) -> tuple[Cantilever, tuple] | str:
        """The cantilever and its ``setup``, or the reason this model declines the scene
        (kept for the last scene: ``applies_to`` and ``solve`` ask for the same one)."""
        last = self.__dict__.get("_ready")
        if last is not None and last[0] is scene:
            return last[1]
        ready = self._prepare_new(scene)
        self._ready = (scene, ready)
        return ready

    def _prepare_new(self, scene: Scene) -> tuple[Cantilever, tuple] | str:
        beam = self._beam(scene)
        if isinstance(beam, str):
            return beam
        s = self.setup(beam)
        if isinstance(s, str):
            return s
        nj = int(np.isfinite(s[0][:, 0]).sum())
        if beam.guided and nj < 2:
            return "a guided tip needs at least two PRB joints (tip angle held at zero)"
        return beam, s

    def applies_to(self, scene: Scene) -> str | None:
        """None if this PRB model can solve the scene, else the reason."""
        ready = self._prepare(scene)
        return ready if isinstance(ready, str) else None

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of the scene's load ramp."""
        ready = self._prepare(scene)  # checked and set up once
        if isinstance(ready, str):
            return not_applicable(scene, self.name, ready)
        beam, (matrix, rot_factor, note) = ready
        chain = self._chain_of(matrix, beam)
        f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
        path = equilibrium_path(chain, f1, load_factors(scene), guided=beam.guided)
        steps = []
        failed = "" if path.ok else path.reason
        # residual max |grad V| in EI/L (forces times L); the path already demanded it
        res = path.residuals * (chain.L / chain.EI)
        bad = np.flatnonzero(~(res <= RESIDUAL_TOL))
        m = len(path.factors) if bad.size == 0 else int(bad[0])
        if bad.size:
            failed = (
                f"residual {res[m]:.2e} EI/L above {RESIDUAL_TOL:g} at factor {path.factors[m]:.6g}"
            )
        # per-step quantities for all reported states at once (batched numpy)
        Q = path.states[:m]
        # plain floats from here (one conversion per array, not one per entry)
        tips, energy = chain.tips(Q).tolist(), chain.strain_energy(Q).tolist()
        per_step = zip(
            path.factors[:m].tolist(),
            tips,
            energy,
            path.iterations[:m].tolist(),
            path.stable,
            res[:m].tolist(),
            path.cuts[:m].astype(float).tolist(),
        )
        outputs = output_map(scene, beam)
        for lam, (x, y, phi), e, its, stable, r, cuts in per_step:
            rot = 0.0 if beam.guided else rot_factor * phi
            steps.append(
                Step(
                    factor=lam,
                    outputs=outputs(x, y, rot),
                    energy=e,
                    iterations=its,
                    stable=stable,
                    info={"residual": r, "step_cuts": cuts},
                )
            )
        extras = {
            "prb_matrix": matrix.tolist(),
            "tip_angle_factor": rot_factor,
            # chain coordinates [psi (rad), u (length)] per reported step (mechanism assembly)
            "prb_states": Q.tolist(),
        }
        if failed:
            return Solution(scene.name, self.name, "failed", failed, tuple(steps), extras)
        msg = "converged" + (f"; {note}" if note else "")
        if np.any(np.isfinite(matrix[:, 1])) and chain.ne == 0:
            msg += "; axial springs treated as rigid (EA not given)"
        msg += unstable_note(steps)
        return Solution(scene.name, self.name, "converged", msg, tuple(steps), extras)

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """Shapes and stress of the reported states from the PRB itself (not timed as solve).

        Shape: the PRB's own pivots and rigid links (its tip is the reported tip).  End loads
        from the spring forces through pinv(J^T) (``info`` ``load_fx``, ``load_fy``,
        ``load_m``, ``jt_rank``); stress from the bending moment these loads give at the
        root, every pivot and the tip, ``m + (tip - p) x f`` (linear along a rigid link).
        """
        if not sol.steps or not self.shapes:
            return sol
        beam = self._beam(scene)
        chain = self._chain_of(np.asarray(sol.extras["prb_matrix"]), beam)
        Q = np.asarray(sol.extras["prb_states"], dtype=float).reshape(len(sol.steps), chain.n)
        f1 = np.array([beam.fx, beam.fy, 0.0 if beam.guided else beam.m])
        lam = np.array([s.factor for s in sol.steps])
        loads, rank = recover_tip_loads_batch(chain, Q, None if beam.guided else lam[:, None] * f1)
        shapes, stress = shape_and_stress(scene, beam, chain, Q, loads)
        stress = [None] * len(Q) if stress is None else stress.tolist()
        steps = []
        for step, xy, (fx, fy, fm), r, sig in zip(
            sol.steps, shapes, loads.tolist(), rank.tolist(), stress
        ):
            info = {**step.info, "load_fx": fx, "load_fy": fy, "load_m": fm, "jt_rank": float(r)}
            steps.append(
                Step(
                    step.factor,
                    step.outputs,
                    step.energy,
                    step.iterations,
                    step.stable,
                    {beam.member: xy},
                    sig,
                    info,
                )  # fmt: skip
            )
        return replace(sol, steps=tuple(steps))

    def _chain_of(self, matrix: np.ndarray, beam: Cantilever) -> PRBChain:
        """The PRBChain of this PRB matrix and beam, built once for a solve and its
        postprocess (the last one is kept)."""
        key = (matrix.tobytes(), matrix.shape, beam.L, beam.EI, beam.EA)
        last = self.__dict__.get("_chain")
        if last is None or last[0] != key:
            self._chain = last = (key, PRBChain(matrix, beam.L, beam.EI, beam.EA))
        return last[1]


# ---------------------------------------------------------------------------------------------
# The registered PRB models
# ---------------------------------------------------------------------------------------------


class PRBShort(PRBModel):
    """Small-length flexural pivot applied to the whole beam: pivot at L/2, K = EI/L."""

    card = ModelCard(
        name="prb-short",
        family="prb",
        summary="small-length flexural pivot: one pivot at mid-length, K = EI/L",
        assumptions=_COMMON + ("the flexible segment is short next to the rigid link it joins",),
        validity=(
            "accurate when the flexible length l is much shorter than the rigid segment it "
            "connects (Howell & Midha 1994); on a whole cantilever it is a one-spring model "
            "with large errors"
        ),
        references=(
            "Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",
            "Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.4",
            _SEED,
        ),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.PRB_SHORT, shapes)

    def solve(self, scene: Scene) -> Solution:
        """As every PRB model, flagged outside its validity range: a single-beam scene is a
        uniform beam, never a short flexural pivot next to a rigid link."""
        sol = super().solve(scene)
        if sol.status != "converged":
            return sol
        why = "a uniform beam is not a short flexural pivot (Howell & Midha 1994)"
        extras = {**sol.extras, "validity_warning": True, "validity_message": why}
        msg = f"{sol.message}; outside validity range: {why}"
        return dataclasses.replace(sol, message=msg, extras=extras)


class PRB1R(PRBModel):
    """Howell's PRB-1R with load-ratio-dependent gamma(n), K_Theta(n), c_theta(n)."""

    card = ModelCard(
        name="prb-1r",
        family="prb",
        summary="Howell's 1R model: characteristic pivot, gamma(n), K_Theta(n), c_theta(n)",
        assumptions=_COMMON
        + (
            "parameters depend on the load ratio n = axial/transverse tip force (n > 0 "
            "compressive); fixed along a proportional load ramp",
            "tip slope = c_theta * Theta (parametric angle coefficient)",
            "a pure end moment uses Howell's moment parameters gamma 0.7346, K_Theta 2.0643, "
            "c_theta 1.5164; a force combined with a moment is declined",
            "K_Theta is a large-deflection average: at small loads the model is stiffer than "
            "linear theory by the factor K_Theta/(3 gamma) (about 3.8 % at n = 0)",
            "pinv(J^T) has rank 1: end loads for shape/stress completed from the applied loads",
        ),
        validity=(
            "tip locus of the characteristic radius within 0.5 % of the deflection up to "
            "Theta_max ~ 64.3 deg for n = 0 (Howell 2001 Table 5.1); fits cover -5 < n <= 10; "
            "pure moment: tip slope to ~124.4 deg"
        ),
        references=(
            "Howell & Midha, J. Mech. Des. 117:156-165, 1995, doi 10.1115/1.2826101",
            "Howell, Midha & Norton, J. Mech. Des. 118:126-131, 1996, doi 10.1115/1.2826843",
            "Howell, Compliant Mechanisms, Wiley 2001, Sec. 5.5-5.6, Table 5.1",
        ),
    )

    OPTIONS = {**SHAPES, "params": Option("str", choices=("fit", "average"), doc="gamma(n)")}

    def __init__(self, params: str = "fit", shapes: bool = True) -> None:
        super().__init__(None, shapes)
        if params not in ("fit", "average"):
            raise ValueError("prb-1r option params must be 'fit' or 'average'")
        self.params = params

    def solve(self, scene: Scene) -> Solution:
        """As ``PRBModel.solve``; states past Howell's Theta_max get a validity warning
        (64.3 deg for forces -- tabulated for n = 0 -- and 124.4 deg / c_theta for a moment)."""
        sol = super().solve(scene)
        theta = np.abs([q[0] for q in sol.extras.get("prb_states", ())])
        moment = sol.extras.get("tip_angle_factor") == T.HOWELL_MOMENT["c_theta"]
        p = T.HOWELL_MOMENT if moment else T.HOWELL_N0
        limit = p["Theta_max_deg"] / (p["c_theta"] if moment else 1.0)
        past = np.flatnonzero(np.degrees(theta) > limit)
        if past.size == 0:
            return sol
        j = int(past[0])
        warn = (
            f"PRB angle Theta {np.degrees(theta.max()):.1f} deg > Howell's {limit:.1f} deg "
            f"(from factor {sol.steps[j].factor:.4g})"
        )
        extras = {**sol.extras, "validity_warning": True, "validity_message": warn}
        msg = f"{sol.message}; outside validity range: {warn}"
        return dataclasses.replace(sol, message=msg, extras=extras)

    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """Howell's parameters for this cantilever's load ratio."""
        fx, fy, m = beam.fx, beam.fy, beam.m
        if fx == 0.0 and fy == 0.0 and m != 0.0:
            p = T.HOWELL_MOMENT
            return T.prb1r_matrix(p["gamma"], p["K_Theta"]), p["c_theta"], "pure-moment parameters"
        if m != 0.0:
            return "tip force combined with a moment: Howell's PRB-1R covers one or the other"
        if fy == 0.0 and fx != 0.0:
            return "purely axial tip force: the PRB-1R load ratio n is unbounded"
        n = -fx / abs(fy) + 0.0 if fy != 0.0 else 0.0  # + 0.0: no '-0' in messages
        # Howell's K_Theta fit jumps at n = -1 and -2.5 (2.716 / 2.720 at -1): a load ratio
        # that is a breakpoint up to the round-off of the drawing's frame (a load at -45 deg
        # drawn rotated or mirrored) must land on the same side of it
        n = round(n, 9) + 0.0
        if self.params == "average":
            p = T.HOWELL_AVERAGE
            return T.prb1r_matrix(p["gamma"], p["K_Theta"]), p["c_theta"], "average parameters"
        lo, hi = T.HOWELL_N_RANGE
        if not lo < n <= hi:
            return f"load ratio n = {n:.3g} outside Howell's fitted range ({lo:g}, {hi:g}]"
        g, k, c = T.howell_gamma(n), T.howell_k_theta(n), T.howell_c_theta(n)
        return T.prb1r_matrix(g, k), c, f"n = {n:.4g}: gamma {g:.4f}, K_Theta {k:.4f}, c {c:.4f}"


class PRB2R(PRBModel):
    """Two-joint PRB model with parameters derived here (no checked published set found)."""

    card = ModelCard(
        name="prb-2r",
        family="prb",
        summary="2R chain, parameters fitted here to the elastica (see prb_tables.PRB_2R_FIT)",
        assumptions=_COMMON
        + (
            "parameters are NOT a published set: derived with prb_fit.fit_prb(2) against the "
            "exact elastica for a transverse tip force and a pure end moment",
            "pinv(J^T) has rank 2: end loads for shape/stress completed from the applied loads",
        ),
        validity=(
            "fitted for a transverse tip force PL^2/EI <= 10 and an end moment ML/EI <= 2: "
            "max tip position error 3.8 % of L, tip angle 0.024 rad (measured at the fit)"
        ),
        references=(_REF, _SEED, "FlexBench derivation: reduced_models/beam/prb_tables.py"),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.PRB_2R, shapes)


class PRB3R(PRBModel):
    """Su's PRB-3R (gamma 0.10/0.35/0.40/0.15) with one of the three stiffness sets."""

    kset = "average"
    # class-level card for listings; instances replace it with the chosen stiffness set
    card = ModelCard(
        name="prb-3r",
        family="prb",
        summary="Su's 3R model (gamma 0.10/0.35/0.40/0.15), one of Su's three stiffness sets",
        assumptions=_COMMON,
        references=("Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148",),
    )

    OPTIONS = {**SHAPES, "stiffness": Option("str", choices=tuple(sorted(T.SU_K)))}

    def __init__(self, stiffness: str | None = None, shapes: bool = True) -> None:
        kset = stiffness or self.kset
        if kset not in T.SU_K:
            raise ValueError(f"prb-3r option stiffness must be one of {sorted(T.SU_K)}")
        super().__init__(T.prb3r_matrix(kset), shapes)
        self.kset = kset
        self.card = ModelCard(
            name="prb-3r" if kset == "average" else f"prb-3r-{kset}",
            family="prb",
            summary=f"Su's 3R model, stiffness set: {T.SU_SOURCE[kset]}",
            assumptions=_COMMON
            + (
                "load-independent parameters: gamma 0.10 (rigid root), 0.35, 0.40, 0.15; "
                f"k = {', '.join(str(k) for k in T.SU_K[kset])} (EI/L)",
            ),
            validity=(
                "combined tip force and moment; Su reports errors much smaller than the 1R "
                "model and a 1.2 % maximum tip-deflection error in his four-bar example vs FEA"
            ),
            references=(
                "Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148, Sec. 4, "
                "Eq. (24), (25), (27), Table 1",
                _SEED,
            ),
        )


class PRB3RForce(PRB3R):
    """PRB-3R with Su's stiffness set optimised for a pure tip force (Eq. 27)."""

    kset = "force"


class PRB3RMoment(PRB3R):
    """PRB-3R with Su's stiffness set optimised for a pure end moment (Eq. 25)."""

    kset = "moment"


class PRB2RPR(PRBModel):
    """PRB-2(RP)R: Su's 3R with prismatic springs in the two middle segments (derived)."""

    card = ModelCard(
        name="prb-2rpr",
        family="prb",
        summary="3R chain whose two middle links stretch: axial extension included",
        assumptions=_COMMON
        + (
            "revolute parameters = Su's PRB-3R (Table 1); prismatic springs DERIVED here: "
            "series axial compliance equals L/EA, split in proportion to segment length",
            "needs EA (area) for the axial springs; without it the links are rigid",
        ),
        validity="as PRB-3R for bending; axial stretch exact for a straight bar in tension",
        references=(_REF, "Su 2009, doi 10.1115/1.3046148", _SEED),
    )

    def __init__(self, shapes: bool = True) -> None:
        super().__init__(T.prb2rpr_matrix(), shapes)


class PRBFSM(PRBModel):
    """Finite segment model: N elements, a spring N EI/L at each element centre (or end)."""

    card = ModelCard(
        name="prb-fsm-N",
        family="prb",
        summary="finite segment model: N rigid elements, springs N EI/L at element centres",
        assumptions=_COMMON,
        references=("Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",),
    )

    OPTIONS = {**SHAPES, "placement": Option("str", choices=("mid", "end"), doc="springs")}

    def __init__(self, n: int, placement: str = "mid", shapes: bool = True) -> None:
        super().__init__(T.fsm_matrix(int(n), placement), shapes)
        where = "element centres" if placement == "mid" else "proximal element ends"
        self.card = ModelCard(
            name=f"prb-fsm-{n}",
            family="prb",
            summary=f"finite segment model, {n} elements, springs N EI/L at the {where}",
            assumptions=_COMMON
            + (
                "each element of length L/N is a small-length flexural pivot at its centre "
                "(midpoint rule: tip error O(1/N^2)); placement='end' gives O(1/N)",
            ),
            validity="converges to the inextensible elastica as N grows (rate asserted in tests)",
            references=(
                "Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",
                _REF,
                _SEED,
            ),
        )


class PRBCustom(PRBModel):
    """PRB matrix given in the case file: [[models]] name = "prb-custom", options.matrix."""

    card = ModelCard(
        name="prb-custom",
        family="prb",
        summary="user PRB matrix [[k_theta, k_ex, gamma], ...] from the case file",
        assumptions=_COMMON + ("parameters as given by the user (e.g. from flexbench fit-prb)",),
        validity="whatever the matrix was fitted for",
        references=(_REF, _SEED),
    )

    OPTIONS = {
        **SHAPES,
        "matrix": Option("matrix", doc="PRB matrix [[k_theta, k_ex, gamma], ...]"),
        "tip_angle_factor": Option("float", 0.0, 10.0, doc="tip slope / last link angle"),
    }

    def __init__(
        self, matrix: object = None, tip_angle_factor: float = 1.0, shapes: bool = True
    ) -> None:
        self._error = None
        try:
            super().__init__(matrix, shapes)
        except ValueError as exc:
            super().__init__(None, shapes)
            self._error = f"options.matrix: {exc}"
        self.rot_factor = float(tip_angle_factor)

    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """The user's matrix, or why it cannot be used."""
        if self._error:
            return self._error
        if self._matrix is None:
            return "prb-custom needs options.matrix = [[k_theta, k_ex, gamma], ...] in the case"
        return self._matrix, self.rot_factor, ""
