"""The ``replay`` model: which analyses the damped dynamics replay runs and how (load
factors by ``run.replay_system``; energy by ``driver``; distance and path by
``servo``; deploy by ``deploy``), its stated mesh error (``honesty``),
and its outputs (animated GIF, VTU/XDMF series)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cases.schema import Scene
from fem_reference.assembly import build, representable
from fem_reference.replay import honesty as honest
from fem_reference.replay.events import locks_from_options
from fem_reference.replay.run import ReplayOptions, replay_system
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable

# -- the model ---------------------------------------------------------------------------------

_REFERENCES = (
    "J. Chung & G. M. Hulbert, J. Appl. Mech. 60:371-375 (1993), doi 10.1115/1.2900803 "
    "(generalised-alpha)",
    "H. M. Hilber, T. J. R. Hughes & R. L. Taylor, Earthq. Eng. Struct. Dyn. 5:283-292 (1977), "
    "doi 10.1002/eqe.4290050306 (HHT-alpha)",
    "M. Arnold & O. Bruls, Multibody Syst. Dyn. 18:185-202 (2007), "
    "doi 10.1007/s11044-007-9084-0 (generalised-alpha with constraints)",
    "F. A. Charney, J. Struct. Eng. 134(4):581-592 (2008), "
    "doi 10.1061/(ASCE)0733-9445(2008)134:4(581) (initial-stiffness damping artefacts)",
    "Deployable six-bar thesis (seeds/001), Ch. 5: MSC/ADAMS replay, 1 N impulse probes, "
    "BISTOP boom stop and its chatter",
)


_DECLINED = {  # analyses with nothing to replay, and why
    "kinematics": "a linkage without flexible members has no elastic state to settle "
    "(its rigid-body motion is the kinetostatic solver's)",
    "synthesis": "the replay replays a given scene, it does not design one (the synthesised "
    "scene is re-solved by fem-auto in the report)",
}


class Replay:
    """``replay``: damped generalised-alpha replay of the FE scene (see module docstring).

    Parameters
    ----------
    n_elements : elements per flexible member (the discretisation of ``fem-<n_elements>``).
    events : boom locks (``LengthLock`` or tables ``{kind="lock-length", a, b, length,
        force}``).  factors : load factors to replay instead of the analysis' (lets a ``path``
        scene be replayed under load control).  Other keywords: ``ReplayOptions`` fields.
    """

    name = "replay"
    card = ModelCard(
        name="replay",
        family="replay",
        summary="damped dynamics replay (MSC-ADAMS style) of the corotational FE scene: "
        "generalised-alpha, one continuous load ramp settled at each reported factor, "
        "tangent test and impulse probes of stability",
        assumptions=(
            "same corotational discretisation as fem-N; consistent mass from Member.density "
            "(default 7850 kg/m^3, 7.85e-9 t/mm^3, 7.35e-4 lbf s^2/in^4, 1 nondim)",
            "mass-proportional damping, critical on the lowest mode of (K0, M) (optional "
            "Rayleigh with the current tangent); settled states do not depend on it",
            "a state is settled when velocity, acceleration and the static distance K^-1 r "
            "are all below settle_tol * L (1e-7 L by default)",
            "stability: the tangent test at each settled state (lowest eigenvalue of (K, M)) "
            "where it is clear (|eig| >= 0.05 omega_1^2), a kick along the lowest mode (or a "
            "nodal impulse) that returns / departs where it is near zero and at the last "
            "state (probe = 'all': at every state); distance/path: under load control at the "
            "settled factor, as the FE tests; follower loads: no static verdict (stable = "
            "None, extras['stability'])",
            "a DOF without mass (a node joining only springs) gets a point mass (the mean "
            "translational one); settled states do not depend on it",
            "boom events: exact length lock with a plastic latch (no penalty stop)",
            "fixed mesh (n_elements, default 32): settled to the static FE of that mesh, which "
            "differs from fem-auto by its discretisation error -- estimated and stated in the "
            "message (extras mesh_error_estimate); snap-through reported where the static "
            "path loses stability, the dynamic onset alongside",
        ),
        validity="load, energy (driver moved as a prescribed motion), distance and path "
        "(a servo holds the driver / stop coordinate and sets the load factor) and deploy "
        "analyses of any scene the FE reference represents; transients are only as physical "
        "as the damping (quasi-static replay, not a vibration model)",
        references=_REFERENCES,
    )

    # declared options (checked by ``reduced_models.registry.build``): (kind, lo, hi, choices)
    OPTIONS = {
        "n_elements": ("int", 1, 100_000),
        "zeta": ("float", 1e-3, 100.0),
        "damping": ("str", None, None, ("mass", "current", "initial")),
        "rho_inf": ("float", 0.0, 1.0),
        "ramp_periods": ("float", 1e-2, 1e4),
        "settle_tol": ("float", 1e-14, 1e-2),
        "lte_tol": ("float", 1e-10, 1.0),
        "dt_max": ("float", 1e-6, 1e3),
        "max_hold": ("float", 1.0, 1e6),
        "probe": ("str", None, None, ("auto", "all", "last", "none")),
        "probe_amplitude": ("float", 1e-12, 1.0),
        "probe_node": ("str",),
        "probe_impulse": ("floats",),
        "jump_dissipation": ("float", 1e-6, 1.0),
        "history_samples": ("int", 2, 10_000_000),
        "frames": ("int", 1, 100_000),
        "time_limit_s": ("float", 1e-3, 1e6),
        "deploy_start": ("str", None, None, ("dynamic", "static")),
    }

    def __init__(
        self, n_elements: int = 32, events: object = (), factors: object = None, **options: object
    ) -> None:
        self.n_elements = int(n_elements)
        self.factors = None if factors is None else np.asarray(factors, dtype=float)
        known = set(ReplayOptions.__dataclass_fields__)
        bad = sorted(set(options) - known)
        if bad:
            raise ValueError(f"replay: unknown options {bad}")
        if "probe_impulse" in options:
            options["probe_impulse"] = tuple(options["probe_impulse"])
        self.options = ReplayOptions(locks=locks_from_options(events), **options)

    def applies_to(self, scene: Scene) -> str | None:
        """None, or why the replay cannot run ``scene``."""
        if scene.analysis.kind in ("load", "distance", "path") and not any(
            m.kind == "flexible" for m in scene.members
        ):
            # only beam elements carry mass: a rigid bar on a torsion spring, ramped or
            # driven, "did not settle within 400 T1" or underflowed its time step
            return (
                "no flexible member: the replay's inertia is the flexible members' (rigid "
                "links and springs have none to integrate; kinetostatic or fem-auto solve the "
                "scene statically)"
            )
        if scene.analysis.kind == "energy" and self.factors is None:
            from fem_reference.replay.driver import applies  # driver moved as a motion

            return applies(scene)
        kind = scene.analysis.kind
        if kind in ("distance", "path") and self.factors is None:
            from fem_reference.replay.servo import applies  # a servo holds the coordinate

            return applies(scene)
        if kind in _DECLINED and self.factors is None:
            return f"{kind} analyses: {_DECLINED[kind]}"
        if kind not in ("load", "deploy") and self.factors is None:
            return f"{kind} analyses: the replay only ramps a load factor"
        return representable(scene)

    def solve(self, scene: Scene) -> Solution:
        """Settled equilibrium path of ``scene`` with probes, histories, jumps."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        if scene.analysis.kind == "deploy":  # the scene's booms are the lock events
            from fem_reference.replay.deploy import replay_deploy

            return replay_deploy(scene, self)
        if scene.analysis.kind == "energy" and self.factors is None:
            from fem_reference.replay.driver import solve_energy

            return solve_energy(scene, self.n_elements, self.options)
        if scene.analysis.kind in ("distance", "path") and self.factors is None:
            from fem_reference.replay.servo import solve_checked

            return solve_checked(scene, self.n_elements, self.options)
        system = build(scene, self.n_elements)
        lams = load_factors(scene) if self.factors is None else self.factors
        sol = replay_system(system, lams, scene=scene, case=scene.name, options=self.options)
        if sol.status != "converged" or self.factors is not None:
            return sol
        # its error against fem-auto, stated (the fine mesh's answer: its own last state)
        switched = bool(sol.extras.get("jumps"))
        est = honest.mesh_error(scene, self.n_elements, dict(sol.steps[-1].outputs), switched)
        if est is None:
            return sol
        worst = honest.worst_mesh_error(est, system.length_scale())
        msg = f"{sol.message}; mesh error vs fem-auto ~{worst:.1e} L (n = {self.n_elements})"
        extras = {**sol.extras, "mesh_error_estimate": est, "mesh_error_worst": worst}
        return replace(sol, message=msg, extras=extras)


# -- outputs -----------------------------------------------------------------------------------


def _frame_shapes(solution: Solution, scene: Scene) -> list[tuple[float, float, dict]]:
    """(t, factor, shapes) per stored frame, recovered on a rebuilt FE system."""
    fr = solution.extras["frames"]
    system = build(scene, int(fr["n_elements"]))
    return [
        (float(t), float(f), system.shapes(q)) for t, f, q in zip(fr["t"], fr["factor"], fr["q"])
    ]


def write_animation(solution: Solution, scene: Scene, path: str, fps: int = 15) -> str:
    """Animated GIF of the replay (deformed members over time) via matplotlib PillowWriter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FuncAnimation, PillowWriter

    frames = _frame_shapes(solution, scene)
    pts = np.vstack([xy for _, _, sh in frames for xy in sh.values()])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.05 * max(hi - lo) + 1e-12
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    lines = {m: ax.plot([], [], lw=2)[0] for m in frames[0][2]}
    title = ax.set_title("")

    def draw(i: int):
        t, f, sh = frames[i]
        for m, xy in sh.items():
            lines[m].set_data(xy[:, 0], xy[:, 1])
        title.set_text(f"{solution.case}  t = {t:.4g}  factor = {f:.4g}")
        return [*lines.values(), title]

    anim = FuncAnimation(fig, draw, frames=len(frames), blit=False)
    anim.save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path


def write_vtu_series(solution: Solution, scene: Scene, directory: str) -> str | None:
    """VTU/PVD/XDMF time series of the replay frames via ``fem_reference.export`` (None if
    that module is unavailable)."""
    try:
        from fem_reference import export
    except ImportError:
        return None
    steps = tuple(
        Step(f, {}, shapes=sh, info={"t": t}) for t, f, sh in _frame_shapes(solution, scene)
    )
    series = Solution(solution.case, "replay-frames", "converged", "", steps)
    return str(export.write_series(directory, series, sections=export.member_sections(scene)))
