"""``fem-auto``: ``fem-N`` on a mesh sequence, Richardson-extrapolated (``richardson.py``);
scenes with several flexible members meshed per member (``adaptive.py``)."""

from __future__ import annotations

from cases.schema import Scene
from fem_reference.error.adaptive import flexible_ids, relative_estimate, solve_per_member
from fem_reference.error.richardson import combine
from fem_reference.models import _REFS, FEM, FEM_OPTIONS
from fem_reference.statics.driver_post import post_process
from reduced_models.base import ModelCard, Solution, not_applicable


class FEMAuto:
    """``fem-auto``: mesh sequence + Richardson extrapolation with an error estimate.

    Options: ``sequence`` (element counts, default 8, 16, 32, 64) plus the ``fem-N`` options.
    Scenes with two or more flexible members mesh each member as its own error estimate asks
    (``adaptive.py``): the sequence gives the top member's counts; a ``target`` (relative
    error: translations / L, rotations in rad) extends it while the estimate is above.
    ``extras['error_estimate'][key]`` = absolute error estimate at the last step;
    ``extras['observed_order'][key]`` = observed order at the last step.
    """

    card = ModelCard(
        name="fem-auto",
        family="fem",
        summary="fem-N on a mesh sequence, Richardson-extrapolated with observed order and "
        "error estimate per output; several flexible members are meshed each as its own "
        "error estimate asks",
        assumptions=FEM.card.assumptions
        + (
            "asymptotic range: error ~ C h^p",
            "per-member meshes: a member's error shows in its deflection from the chord of "
            "its deformed ends (Richardson indicator from uniform N and 2N meshes)",
        ),
        validity="as fem-N; the error estimate is meaningful when the observed order is near 2",
        references=_REFS,
    )

    OPTIONS = {
        **FEM_OPTIONS,
        "sequence": ("ints", 1, 100_000, (), "element counts"),
        "target": ("float", 1e-14, 1e-1, (), "per-member meshes: relative error target"),
    }

    def __init__(self, sequence: tuple[int, ...] | list[int] = (8, 16, 32, 64), **options):
        self.sequence = tuple(int(n) for n in sequence)
        target = options.pop("target", None)
        self.target = None if target is None else float(target)
        self.options = dict(options)
        self.name = "fem-auto"

    def applies_to(self, scene: Scene) -> str | None:
        """As ``fem-N``."""
        return FEM(1).applies_to(scene)

    def solve(self, scene: Scene) -> Solution:
        """Solve on every mesh and extrapolate (see ``richardson.combine``)."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        if scene.analysis.kind == "deploy":  # no Richardson: the finest mesh of the sequence
            from fem_reference.statics.deploy_staged import solve_any as solve_deploy

            return solve_deploy(scene, self.name, self.sequence[-1])
        if len(flexible_ids(scene)) >= 2:  # each member meshed as its error needs
            sol = solve_per_member(scene, self.name, self.sequence, self.options, self.target)
            return post_process(scene, sol)
        # stability is reported from the finest mesh only: skip the eigen-analysis elsewhere
        coarse = {**self.options, "stability": False}
        runs = [FEM(n, **coarse).runner(scene) for n in self.sequence[:-1]]
        runs.append(FEM(self.sequence[-1], **self.options).runner(scene))
        sol = combine(scene, self.name, self.sequence, runs)
        sol.extras["fidelity"] = {  # what the report shows for every *-auto model
            "n": self.sequence[-1],
            "sequence": list(self.sequence),
            "estimate": relative_estimate(scene, sol),
            "target": None,
        }
        return post_process(scene, sol)


__all__ = ["FEMAuto"]
