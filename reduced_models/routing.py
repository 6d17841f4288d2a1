"""The mechanism route of the registered single-beam models (``registry.build`` applies it).

``routed(model, name, options)`` puts the ``Routed`` mixin in front of a single-beam model's
class: plain cantilever scenes keep the specialised solver, every other scene goes through
the mechanism assembler (``reduced_models.mechanism.model.MechanismModel``) with the same
model name.  The assembler -- and with it scipy's sparse and LAPACK layers -- is imported
only when a scene needs it: a cantilever solved by ``prb-3r`` imports none of it
(``flexbench solve`` of a reduced model pays its own imports only, issue 12).
"""

from __future__ import annotations

import functools

from cases.schema import Scene
from reduced_models.base import Model, Solution, not_applicable
from reduced_models.beam.single_beam import cantilever_of


class Routed:
    """Mixin put in front of a registered single-beam model's class (``routed``): plain
    cantilever scenes keep the specialised solver, every other scene goes through the
    assembler with the same model name.  ``isinstance`` and attributes are unchanged."""

    _mech_args: tuple[str, dict | None]

    @functools.cached_property
    def _mech(self) -> Model:
        """The assembler with this model name (built, and imported, on first use)."""
        from reduced_models.mechanism.model import MechanismModel

        return MechanismModel(*self._mech_args)

    def _route(self, scene: Scene) -> tuple[str, str | None]:
        if not isinstance(cantilever_of(scene), str):
            return "inner", None
        if len(scene.members) == 1:
            inner_reason = super().applies_to(scene)
            if inner_reason is None:
                return "inner", None
            mech_reason = self._mech.applies_to(scene)
            if mech_reason is None:
                return "mech", None
            return "none", f"{inner_reason}; mechanism assembler: {mech_reason}"
        return "mech", None

    def applies_to(self, scene: Scene) -> str | None:
        """None, or why neither the single-beam solver nor the assembler applies."""
        where, reason = self._route(scene)
        if where == "inner":
            return super().applies_to(scene)
        return reason if where == "none" else self._mech.applies_to(scene)

    def solve(self, scene: Scene) -> Solution:
        """Single-beam solver for cantilevers, the assembler for everything else."""
        where, reason = self._route(scene)
        if where == "inner":
            return super().solve(scene)
        if where == "none":
            return not_applicable(scene, self.name, reason)
        sol = self._mech.solve(scene)
        return Solution(sol.case, self.name, sol.status, sol.message, sol.steps, sol.extras)

    def postprocess(self, scene: Scene, sol: Solution) -> Solution:
        """The single-beam model's post-processing for its own answers, the assembler's
        (shapes and stress of the kept states) for the others."""
        inner = getattr(super(), "postprocess", None)
        if self._route(scene)[0] != "inner":
            from reduced_models.mechanism.model import postprocess

            return postprocess(scene, sol)
        if inner is None:
            return sol
        return inner(scene, sol)


_ROUTED: dict[type, type] = {}


def routed(model: Model, name: str, options: dict | None = None) -> Model:
    """Give ``model`` (a registered single-beam model) the mechanism route (``Routed``)."""
    cls = type(model)
    sub = _ROUTED.get(cls)
    if sub is None:
        sub = type(cls.__name__, (Routed, cls), {"__module__": cls.__module__})
        _ROUTED[cls] = sub
    model.__class__ = sub
    model._mech_args = (name, options)
    return model
