"""DAS-2D's PRB shape and accuracy indicator, an option beside the PRB's own links.

Seed 000_265bc60728766176.txt, "Compliant Link Module Demonstration" and "Computing Beam
Shape and Stress": after the energy minimisation the only information of a PRB model is the
deflection of its links; the end loads follow from the spring torques through pinv(J^T)
(``prb_post.recover_tip_loads_batch``), and DAS-2D solves the Euler-Bernoulli (elastica)
cantilever under those loads once per state and draws its shape and stress.  "The difference
between tip location of the PRB Model and the Euler Beam is an indicator for the accuracy of
the PRB Beam for the current problem."

With the model option ``das2d = true`` (PRB models on cantilever scenes) ``das2d_shapes``
replaces the PRB's own links by that Euler shape, its stress by the Euler beam's (largest
``E t |kappa| / 2``), and puts the indicator in ``extras["das2d_indicator"]``:

* ``tip_gap``: per step, |tip_PRB - tip_Euler| / L (dimensionless),
* ``rot_gap``: per step, |theta_PRB - theta_Euler| (rad),
* ``max_tip_gap``, ``max_rot_gap``: their largest values over the path,
* ``failed``: steps at which the elastica could not be solved under the recovered loads
  (their gaps are NaN),
* ``length``: the member length L the gaps are divided by.

The indicator is no error estimate: it measures how far the PRB's kinematics sit from the
exact beam carrying the PRB's own spring loads, which is small when the PRB's tip and its
spring loads are both right, and grows with the PRB's error (``reports/render/das2d_note.py``
sets it beside the error measured against the reference).  The Euler solve is the exact
elastica (``beam.elastica.equilibrium``): the shape then costs an elastica solve per step,
which is why it is an option and the PRB's own links stay the default.
"""

from __future__ import annotations

import numpy as np

from cases.schema import Scene
from reduced_models.beam.prb_chain import PRBChain
from reduced_models.beam.single_beam import Cantilever
from reduced_models.options import Option

OPTION = {
    "das2d": Option(
        "bool",
        doc="DAS-2D shape: the Euler beam under the recovered end loads, and the PRB-vs-Euler "
        "tip gap in extras['das2d_indicator']",
    )
}
N_POINTS = 33  # points of the Euler shape along the member


def euler_states(beam: Cantilever, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The elastica cantilever (length ``beam.L``, ``beam.EI``) under each row of dead end
    loads ``loads`` (m, 3) = (fx, fy, moment) in the beam frame.

    Returns
    -------
    shapes : (m, N_POINTS, 3) beam-frame x, y and curvature kappa (1/length) along the beam.
    tips : (m, 3) tip x, y and rotation theta (rad); NaN rows where the elastica has no
        reachable state under those loads.
    """
    # here, not at the top: scipy.special (0.1-0.2 s to import) only when the option is on
    from reduced_models.beam.elastica import ElasticaError, equilibrium

    L, EI = beam.L, beam.EI
    s = np.linspace(0.0, L, N_POINTS)
    shapes = np.full((len(loads), N_POINTS, 3), np.nan)
    tips = np.full((len(loads), 3), np.nan)
    for k, (fx, fy, m) in enumerate(np.asarray(loads, dtype=float)):
        if fx == 0.0 and fy == 0.0 and m == 0.0:  # unloaded: the straight beam
            shapes[k] = np.column_stack([s, np.zeros_like(s), np.zeros_like(s)])
            tips[k] = (L, 0.0, 0.0)
            continue
        try:
            eq = equilibrium(L, EI, fx, fy, m)
        except ElasticaError:
            continue
        _, kap, x, y, _ = eq.sample(s)
        shapes[k] = np.column_stack([x, y, kap])
        tips[k] = eq.tip()
    return shapes, tips


def indicator(prb_tips: np.ndarray, euler_tips: np.ndarray, L: float) -> dict:
    """DAS-2D's accuracy indicator from the PRB's and the Euler beam's tips (m, 3) each
    (x, y, theta in the beam frame); see the module doc for the keys."""
    d = np.asarray(prb_tips, dtype=float) - np.asarray(euler_tips, dtype=float)
    tip = np.hypot(d[:, 0], d[:, 1]) / L
    rot = np.abs(d[:, 2])
    ok = np.isfinite(tip)
    return {
        "tip_gap": tip.tolist(),
        "rot_gap": rot.tolist(),
        "max_tip_gap": float(tip[ok].max()) if ok.any() else float("nan"),
        "max_rot_gap": float(rot[ok].max()) if ok.any() else float("nan"),
        "failed": np.flatnonzero(~ok).tolist(),
        "length": float(L),
    }


def das2d_shapes(
    scene: Scene,
    beam: Cantilever,
    chain: PRBChain,
    X: np.ndarray,
    F: np.ndarray,
    rot_factor: float = 1.0,
) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """DAS-2D's shapes, stresses and indicator of PRB states X (m, n) whose recovered end
    loads are F (m, 3) (beam frame); ``rot_factor``: the PRB's tip rotation over its last
    link's angle (PRB-1R's c_theta; 0 for a guided tip, whose rotation is held).

    Returns ``(shapes, max_stress, indicator)``: shapes (m, N_POINTS, 2) in global
    coordinates (a step without an Euler state keeps the PRB's own links), max_stress (m,)
    or None without thickness and E, and the ``indicator`` dict.
    """
    shapes, tips = euler_states(beam, F)
    prb = chain.tips(X) * np.array([1.0, 1.0, rot_factor])  # the tip the PRB reports
    ind = indicator(prb, tips, beam.L)
    own = chain.points(X)  # (m, S + 1, 2): the fallback of a step the elastica cannot reach
    out = []
    for k in range(len(X)):
        xy = shapes[k, :, :2] if np.isfinite(tips[k]).all() else own[k]
        out.append(beam.rotate_to_global(xy[None])[0])
    mem = scene.member(beam.member)
    stress = None
    if mem.thickness is not None and mem.E is not None:
        kap = np.abs(shapes[:, :, 2]).max(axis=1)  # NaN where the elastica failed
        stress = mem.E * mem.thickness * kap / 2.0
    return out, stress, ind


__all__ = ["N_POINTS", "OPTION", "das2d_shapes", "euler_states", "indicator"]
