"""One door to every model: the merged registry, model construction and ``solve``.

``reduced_models.registry.MODELS`` and (when the FE package provides it)
``fem_reference.models.MODELS`` both map a name (``"linear-N"`` for parametrised families) to
``"module:Factory"``.  This module merges them, parses concrete names (``"cbcm-4"``,
``"fem-64"``) and builds models with the case's options.  ``solve`` never raises for a model
that crashes: the exception becomes a ``failed`` Solution (a user mistake -- unknown model,
bad options -- still raises, so the CLI can say so).  ``solution_json`` is a Solution as the
``flexbench solve --json`` object of DESIGN.md.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import traceback
from typing import Any

from cases.limits import RIGID_STRETCH_MAX, STRAIN_MAX, state_violation
from cases.schema import Scene
from reduced_models import registry as _registry
from reduced_models.base import Model, ModelCard, Solution, not_applicable, post_process
from reduced_models.options import OptionError
from reports.verdicts.errors import SPEED_BASELINES  # noqa: F401  (re-exported)

UnknownModelError = _registry.UnknownModelError


# problems met while importing optional registries (shown by ``flexbench models``)
REGISTRY_WARNINGS: list[str] = []


def _fem_registry() -> tuple[dict[str, str], tuple[str, ...]]:
    """The FE package's registry, or empty when it does not exist yet."""
    try:
        mod = importlib.import_module("fem_reference.models")
    except ModuleNotFoundError as exc:
        if exc.name not in ("fem_reference", "fem_reference.models"):
            _warn(f"fem_reference.models: {exc}")
        return {}, ()
    except Exception as exc:  # a broken sibling registry must not take the CLI down
        _warn(f"fem_reference.models: {type(exc).__name__}: {exc}")
        return {}, ()
    return dict(getattr(mod, "MODELS", {})), tuple(getattr(mod, "DEFAULT_NAMES", ()))


def _warn(text: str) -> None:
    if text not in REGISTRY_WARNINGS:
        REGISTRY_WARNINGS.append(text)


def registry_table() -> dict[str, str]:
    """Merged registry: name (``family-N`` for parametrised families) -> ``"module:Factory"``."""
    table = dict(_registry.MODELS)
    fem, _ = _fem_registry()
    for key, target in fem.items():
        table.setdefault(key, target)
    return table


def default_names() -> tuple[str, ...]:
    """Concrete model names a default run tries on every case."""
    _, fem_defaults = _fem_registry()
    return tuple(dict.fromkeys(tuple(_registry.DEFAULT_NAMES) + fem_defaults))


def model_names() -> list[str]:
    """Every registry key, sorted (parametrised families appear as ``family-N``)."""
    return sorted(registry_table())


def resolve(name: str, table: dict[str, str] | None = None) -> tuple[str, int | None, str]:
    """Parse a concrete name into ``(registry key, N or None, "module:Factory")``.

    Raises
    ------
    UnknownModelError
        For a name no registry knows, or ``family-0``.
    """
    if table is None:
        try:  # a reduced model needs no FE import (the merged table prefers these entries)
            key, n = _registry.parse(name, _registry.MODELS)
            return key, n, _registry.MODELS[key]
        except UnknownModelError:
            table = registry_table()
    key, n = _registry.parse(name, table)
    return key, n, table[key]


factory = _registry.factory
build = _registry.build


def make_model(name: str, scene: Scene | None = None, options: dict | None = None) -> Model:
    """Build a model by name with ``scene.model_options(name)`` (or explicit ``options``).

    Raises
    ------
    UnknownModelError
        Unknown name.
    ValueError
        Options the model's constructor rejects (message names the model).
    """
    _, n, target = resolve(name)
    if options is None:
        options = scene.model_options(name) if scene is not None else {}
    where = f"{scene.path}: " if scene is not None and scene.path else ""
    try:
        return build(name, target, n, options)
    except OptionError as exc:  # already names model, option and reason
        raise OptionError(f"{where}[[models]] bad options: {exc}") from exc
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}model {name!r}: bad options {options!r}: {exc}") from exc


def check_options(scene: Scene, name: str, target: str, options: dict) -> None:
    """Raise ``OptionError`` (naming the case file) when ``options`` break the model's
    declared ``OPTIONS`` (names, types, ranges); models without a declaration pass."""
    declared = getattr(factory(target), "OPTIONS", None)
    if declared is None:
        return
    try:
        _registry.validate(name, declared, options)
    except OptionError as exc:
        where = f"{scene.path}: " if scene.path else ""
        raise OptionError(f"{where}[[models]] bad options: {exc}") from None


def card_of(name: str) -> ModelCard | None:
    """The model's card from its factory (class attribute) without solving anything."""
    try:
        _, n, target = resolve(name)
        card = getattr(factory(target), "card", None)
        if card is None or not isinstance(card, ModelCard):
            card = build(name, target, n, {}).card
    except Exception:
        return None
    return card if isinstance(card, ModelCard) else None


def run_model(model: Model, scene: Scene, *, catch: bool = True, post: bool = True) -> Solution:
    """Ask ``applies_to`` then ``solve`` (then ``postprocess`` and the predicted error of a
    reduced model, ``reports.verdicts.predict``, when ``post``); an exception becomes a ``failed``
    Solution.

    The traceback is kept in ``extras["traceback"]`` (``catch=False`` re-raises instead).
    """
    name = getattr(model, "name", type(model).__name__)
    try:
        reason = model.applies_to(scene)
        if reason:
            return not_applicable(scene, name, str(reason))
        sol = model.solve(scene)
        if not isinstance(sol, Solution):
            raise TypeError(f"solve() returned {type(sol).__name__}, not Solution")
        drift = getattr(model, "rigid_link_drift", RIGID_STRETCH_MAX)
        sol = checked(scene, sol, drift, getattr(model, "approximate_kinematics", False))
        return _predicted(name, scene, _post_process(model, scene, sol)) if post else sol
    except Exception as exc:
        if not catch:
            raise
        return Solution(
            case=scene.name,
            model=name,
            status="failed",
            message=f"{type(exc).__name__}: {exc}".splitlines()[0][:500],
            extras={"traceback": traceback.format_exc(limit=8)},
        )


def checked(
    scene: Scene, sol: Solution, rigid_max: float = RIGID_STRETCH_MAX, approximate: bool = False
) -> Solution:
    """``sol``, or, when converged, failed at its first state that is no answer (an infinite
    strain energy, a NaN output,
    a rigid link off its length by more than ``rigid_max``, a member stretched beyond the
    elastic models: the shared ``cases.limits.state_violation``) with the states before it.

    ``approximate``: the model's kinematics are approximate (linear, BCM, PRB): under loads
    alone a tip it places beyond the beam's reach is its *error*, measured against the
    reference like any other, not a stretch, so the strain bound applies to it only where a
    driver imposes the motion (a tip driven past the member's length is no state of it)."""
    if sol.status != "converged":
        return sol
    for k, st in enumerate(sol.steps):
        if math.isinf(st.energy):  # NaN is "not computed"; an infinite energy is no state
            msg = f"at factor {st.factor:.6g}: strain energy is infinite"
            return dataclasses.replace(sol, status="failed", message=msg, steps=sol.steps[:k])
    if scene.analysis.kind == "synthesis":  # its states belong to the synthesised scene,
        rigid_max = math.inf  # whose link lengths the synthesis may have changed
    strain_max = math.inf if approximate and scene.analysis.driver is None else STRAIN_MAX
    steps = enumerate(sol.steps)
    if strain_max == math.inf and all(m.kind != "rigid" for m in scene.members):
        # no length bound can fail: only a non-finite output can (a sum is finite iff
        # every term is), so ``state_violation`` is asked about those steps alone
        isfinite = math.isfinite
        steps = [(k, st) for k, st in steps if not isfinite(sum(st.outputs.values()))]
    for k, st in steps:
        why = state_violation(scene, st.outputs, rigid_max, strain_max)
        if why:
            msg = f"at factor {st.factor:.6g}: {why}"
            return dataclasses.replace(sol, status="failed", message=msg, steps=sol.steps[:k])
    return sol


def _post_process(model: Model, scene: Scene, sol: Solution) -> Solution:
    """The model's ``postprocess`` (shapes, stress), then, for a synthesis the assembler ran,
    the fem-auto re-solve of the synthesised scene (``reports.verdicts.fecheck``)."""
    if getattr(model, "postprocess", None) is None or not sol.steps:
        return sol
    sol = post_process(model, scene, sol)
    if scene.analysis.kind != "synthesis":
        return sol
    from reports.verdicts.fecheck import check_drivers, fe_check

    if scene.analysis.driver is None and "drivers" in sol.extras:  # a bistable driver search
        return check_drivers(scene, sol)
    return fe_check(scene, sol)


def finish(model: Model, scene: Scene, sol: Solution) -> Solution:
    """``sol`` with the model's post-processing (shapes, stress) and predicted error added; an
    exception there leaves the answer as it was and is named in
    ``extras["postprocess_error"]``."""
    try:
        name = getattr(model, "name", type(model).__name__)
        return _predicted(name, scene, _post_process(model, scene, sol))
    except Exception as exc:
        extras = dict(sol.extras, postprocess_error=f"{type(exc).__name__}: {exc}")
        return dataclasses.replace(sol, extras=extras)


def _predicted(name: str, scene: Scene, sol: Solution) -> Solution:
    """``sol`` with a reduced model's predicted error (``reports.verdicts.predict``), after the
    timed solve: the table is a file a report may read and a model may not."""
    from reports.verdicts import predict  # lazy: scipy.ndimage/spatial only when a solve finishes

    return predict.attach(name, scene, sol)


def solve(
    scene: Scene | str, model: str | Model, *, options: dict | None = None, catch: bool = True
) -> Solution:
    """Solve one scene with one model: ``reports.solve(scene, "prb-3r") -> Solution``.

    Parameters
    ----------
    scene : a Scene, or a catalog name / path for ``cases.load``.
    model : registry name or a model instance.
    options : model options (default: the case's ``[[models]]`` options for this name).
    catch : turn exceptions raised by the model into ``failed`` Solutions.

    The Solution's ``extras["units"]`` is the scene's unit system (``Solution.to_frame``
    names each column's unit from it).
    """
    if isinstance(scene, str):
        import cases

        scene = cases.load(scene)
    m = make_model(model, scene, options) if isinstance(model, str) else model
    sol = run_model(m, scene, catch=catch)
    # the unit system, for Solution.to_frame / plot labels in a notebook
    extras = {**sol.extras, "units": scene.units}
    return Solution(sol.case, sol.model, sol.status, sol.message, sol.steps, extras)


# -- the solve --json object ---------------------------------------------------------------
def _floats(x: Any) -> Any:
    """Float or None (JSON has no NaN/inf)."""
    x = float(x)
    return x if math.isfinite(x) else None


def solution_json(sol: Any, wall_s: float) -> dict[str, Any]:
    """The ``solve --json`` object of DESIGN.md (non-finite numbers -> null)."""
    out = {
        "case": sol.case,
        "model": sol.model,
        "status": sol.status,
        "message": sol.message,
        "steps": [
            {
                "factor": _floats(s.factor),
                "outputs": {str(k): _floats(v) for k, v in s.outputs.items()},
                "energy": _floats(s.energy),
                "iterations": int(s.iterations),
                "stable": None if s.stable is None else bool(s.stable),
            }
            for s in sol.steps
        ],
        "wall_s": float(wall_s),
    }
    # Extension (DESIGN.md allows extending, never breaking): the reference's own error
    # estimate, observed orders, limit points, dynamic jumps and validity flags, when present.
    extra = {k: sol.extras[k] for k in _JSON_EXTRAS if k in sol.extras}
    if extra:
        from reports.run.store import extras_json

        out["extras"] = extras_json(extra)
    return out


_JSON_EXTRAS = (
    "error_estimate",
    "observed_order",
    "limit_points",
    "critical_points",
    "reference_usable",
    "off_branch",
    "mesh_error_worst",
    "jumps",
    "validity_warning",
    "validity_message",
    # mechanism analyses (issue 9)
    "equilibria",
    "barrier",
    "synthesis",
    "bistable",
    "drivers",
    "mobility",
    "mobility_rank",
    "range",
    # deploy: the thesis's load totals (Tables 4-5 .. 4-10), its stability number, the booms
    "load_total_rows",
    "part1_load_total",
    "part2_load_total",
    "part1_increments",
    "part2_increments",
    "stability_number",
    "boom_reached",
    "boom_bar_force",
    # deploy: the replay's time history and the thesis's 1 N impulse on J4 (issue 25)
    "time_history",
    "impulse_probe",
    # deploy: the thesis's structure counts and stiffness (Eqs. 2-11, 2-12, 2-46 .. 2-48)
    "structure",
)
