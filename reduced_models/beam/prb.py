"""Pseudo-rigid-body (PRB) models of a cantilever: the registered models.

Every PRB model here is a chain of rigid segments described by a PRB matrix
``[[k_theta, k_ex, gamma], ...]`` (see ``prb_tables``): segment i has length gamma_i L (plus an
axial stretch u_i when k_ex_i is finite), a torsion spring k_theta_i EI/L at its proximal end
(absent when infinite) and an axial spring k_ex_i EA/L (rigid when infinite).  Each model
picks its matrix (``setup``); the solve, shapes and stress are the shared
``prb_model.PRBModel``'s, the chain numerics ``prb_chain``'s and ``prb_post``'s.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from cases.schema import Scene
from reduced_models.base import ModelCard, Solution
from reduced_models.beam import prb_tables as T
from reduced_models.beam.prb_das2d import OPTION as DAS2D
from reduced_models.beam.prb_model import COMMON, PRBModel
from reduced_models.beam.single_beam import Cantilever
from reduced_models.options import SHAPES, Option

__all__ = [
    "PRB1R",
    "PRB2R",
    "PRB2RPR",
    "PRB3R",
    "PRB3RForce",
    "PRB3RMoment",
    "PRBCustom",
    "PRBFSM",
    "PRBShort",
]

_REF = "Venkiteswaran & Su, Precis. Eng. 40:46-54, 2015, doi 10.1016/j.precisioneng.2014.10.002"
_SEED = "seed 000_265bc60728766176.txt: PRB matrix, Jacobian, shape and stress slides"


class PRBShort(PRBModel):
    """Small-length flexural pivot applied to the whole beam: pivot at L/2, K = EI/L."""

    card = ModelCard(
        name="prb-short",
        family="prb",
        summary="small-length flexural pivot: one pivot at mid-length, K = EI/L",
        assumptions=COMMON + ("the flexible segment is short next to the rigid link it joins",),
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

    def __init__(self, shapes: bool = True, das2d: bool = False) -> None:
        super().__init__(T.PRB_SHORT, shapes, das2d)

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
        assumptions=COMMON
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

    OPTIONS = {
        **SHAPES,
        **DAS2D,
        "params": Option("str", choices=("fit", "average"), doc="gamma(n)"),
    }

    def __init__(self, params: str = "fit", shapes: bool = True, das2d: bool = False) -> None:
        super().__init__(None, shapes, das2d)
        if params not in ("fit", "average"):
            raise ValueError("prb-1r option params must be 'fit' or 'average'")
        self.params = params

    def solve(self, scene: Scene) -> Solution:
        """As ``PRBModel.solve``; states past Howell's Theta_max get a validity warning
        (64.3 deg for forces -- tabulated for n = 0 -- and 124.4 deg / c_theta for a moment)."""
        sol = super().solve(scene)
        theta = [math.degrees(abs(q[0])) for q in sol.extras.get("prb_states", ())]  # deg
        moment = sol.extras.get("tip_angle_factor") == T.HOWELL_MOMENT["c_theta"]
        p = T.HOWELL_MOMENT if moment else T.HOWELL_N0
        limit = p["Theta_max_deg"] / (p["c_theta"] if moment else 1.0)
        j = next((j for j, t in enumerate(theta) if t > limit), None)
        if j is None:
            return sol
        warn = (
            f"PRB angle Theta {max(theta):.1f} deg > Howell's {limit:.1f} deg "
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
        assumptions=COMMON
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

    def __init__(self, shapes: bool = True, das2d: bool = False) -> None:
        super().__init__(T.PRB_2R, shapes, das2d)


class PRB3R(PRBModel):
    """Su's PRB-3R (gamma 0.10/0.35/0.40/0.15) with one of the three stiffness sets."""

    kset = "average"
    # class-level card for listings; instances replace it with the chosen stiffness set
    card = ModelCard(
        name="prb-3r",
        family="prb",
        summary="Su's 3R model (gamma 0.10/0.35/0.40/0.15), one of Su's three stiffness sets",
        assumptions=COMMON,
        references=("Su, J. Mechanisms Robotics 1(2):021008, 2009, doi 10.1115/1.3046148",),
    )

    OPTIONS = {**SHAPES, **DAS2D, "stiffness": Option("str", choices=tuple(sorted(T.SU_K)))}

    def __init__(
        self, stiffness: str | None = None, shapes: bool = True, das2d: bool = False
    ) -> None:
        kset = stiffness or self.kset
        if kset not in T.SU_K:
            raise ValueError(f"prb-3r option stiffness must be one of {sorted(T.SU_K)}")
        super().__init__(T.prb3r_matrix(kset), shapes, das2d)
        self.kset = kset
        self.card = ModelCard(
            name="prb-3r" if kset == "average" else f"prb-3r-{kset}",
            family="prb",
            summary=f"Su's 3R model, stiffness set: {T.SU_SOURCE[kset]}",
            assumptions=COMMON
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
        assumptions=COMMON
        + (
            "revolute parameters = Su's PRB-3R (Table 1); prismatic springs DERIVED here: "
            "series axial compliance equals L/EA, split in proportion to segment length",
            "needs EA (area) for the axial springs; without it the links are rigid",
        ),
        validity="as PRB-3R for bending; axial stretch exact for a straight bar in tension",
        references=(_REF, "Su 2009, doi 10.1115/1.3046148", _SEED),
    )

    def __init__(self, shapes: bool = True, das2d: bool = False) -> None:
        super().__init__(T.prb2rpr_matrix(), shapes, das2d)


class PRBFSM(PRBModel):
    """Finite segment model: N elements, a spring N EI/L at each element centre (or end)."""

    card = ModelCard(
        name="prb-fsm-N",
        family="prb",
        summary="finite segment model: N rigid elements, springs N EI/L at element centres",
        assumptions=COMMON,
        references=("Howell & Midha, J. Mech. Des. 116:280-290, 1994, doi 10.1115/1.2919359",),
    )

    OPTIONS = {**SHAPES, **DAS2D, "placement": Option("str", choices=("mid", "end"), doc="springs")}

    def __init__(
        self, n: int, placement: str = "mid", shapes: bool = True, das2d: bool = False
    ) -> None:
        super().__init__(T.fsm_matrix(int(n), placement), shapes, das2d)
        where = "element centres" if placement == "mid" else "proximal element ends"
        self.card = ModelCard(
            name=f"prb-fsm-{n}",
            family="prb",
            summary=f"finite segment model, {n} elements, springs N EI/L at the {where}",
            assumptions=COMMON
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
        assumptions=COMMON + ("parameters as given by the user (e.g. from flexbench fit-prb)",),
        validity="whatever the matrix was fitted for",
        references=(_REF, _SEED),
    )

    OPTIONS = {
        **SHAPES,
        **DAS2D,
        "matrix": Option("matrix", doc="PRB matrix [[k_theta, k_ex, gamma], ...]"),
        "tip_angle_factor": Option("float", 0.0, 10.0, doc="tip slope / last link angle"),
    }

    def __init__(
        self,
        matrix: object = None,
        tip_angle_factor: float = 1.0,
        shapes: bool = True,
        das2d: bool = False,
    ) -> None:
        self._error = None
        try:
            super().__init__(matrix, shapes, das2d)
        except ValueError as exc:
            super().__init__(None, shapes, das2d)
            self._error = f"options.matrix: {exc}"
        self.rot_factor = float(tip_angle_factor)

    def setup(self, beam: Cantilever) -> tuple[np.ndarray, float, str] | str:
        """The user's matrix, or why it cannot be used."""
        if self._error:
            return self._error
        if self._matrix is None:
            return "prb-custom needs options.matrix = [[k_theta, k_ex, gamma], ...] in the case"
        return self._matrix, self.rot_factor, ""
