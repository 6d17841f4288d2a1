"""The shared model interface: ``Model`` protocol, ``ModelCard``, ``Step`` and ``Solution``.

Every model (reduced or reference) answers two questions about a scene:

* ``applies_to(scene)`` -> ``None`` if it can solve the scene, else a one-line reason;
* ``solve(scene)`` -> ``Solution`` with one ``Step`` per reported load factor.

A model may also have ``postprocess(scene, solution) -> Solution``: what is not part of the
answer's cost -- drawing shapes, recovering stress, exports -- added to a solved
``Solution`` (``post_process`` below calls it when present).  The runner times the solve and
the post-processing separately.

Models never read files, print, or time themselves (the runner measures CPU and wall time).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from cases.schema import Scene

if TYPE_CHECKING:  # pandas and matplotlib are imported only by the notebook methods
    import pandas as pd
    from matplotlib.axes import Axes

STATUSES = ("converged", "failed", "not-applicable")


@dataclass(frozen=True)
class ModelCard:
    """Metadata shown next to every result: what the model assumes and where it is valid.

    Attributes
    ----------
    name : registry name (``prb-3r``, ``cbcm-4``).
    family : ``elastica`` | ``linear`` | ``prb`` | ``bcm`` | ``fem`` | ``replay`` | ...
    summary : one line.
    assumptions : tuple of short statements.
    validity : the range in which the authors claim accuracy.
    references : citations with DOI or table number.
    """

    name: str
    family: str
    summary: str
    assumptions: tuple[str, ...] = ()
    validity: str = ""
    references: tuple[str, ...] = ()


@dataclass(frozen=True)
class Step:
    """One equilibrium state.

    Attributes
    ----------
    factor : load factor (``distance`` analyses: the solved load factor; ``energy``: driver
        coordinate).
    outputs : output key -> value (``tip.uy`` in length units, ``tip.rot`` in rad).
    energy : elastic strain energy stored (force * length).
    iterations : Newton (or equivalent) iterations spent on this step.
    stable : True/False from a stability test (lowest tangent eigenvalue, probe), None if
        not assessed.
    shapes : member id -> (n, 2) array of deformed centre-line points (length units), from
        node a to node b.
    max_stress : largest bending stress magnitude |M| t / (2 I) over all flexible members
        (stress units), None when thickness is unknown or the model cannot recover it.
    info : free-form extra per-step numbers (residual norm, step cuts, eigenvalue, ...).
    """

    factor: float
    outputs: Mapping[str, float]
    energy: float = float("nan")
    iterations: int = 0
    stable: bool | None = None
    shapes: Mapping[str, np.ndarray] = field(default_factory=dict, compare=False)
    max_stress: float | None = None
    info: Mapping[str, float] = field(default_factory=dict, compare=False)

    def __init__(
        self,
        factor: float,
        outputs: Mapping[str, float],
        energy: float = float("nan"),
        iterations: int = 0,
        stable: bool | None = None,
        shapes: Mapping[str, np.ndarray] | None = None,
        max_stress: float | None = None,
        info: Mapping[str, float] | None = None,
    ) -> None:
        # the frozen dataclass's own __init__ stores each field through object.__setattr__
        # (1.6 us a step); a path of small-model steps is built in about that per step
        d = self.__dict__
        d["factor"], d["outputs"], d["energy"] = factor, outputs, energy
        d["iterations"], d["stable"] = iterations, stable
        d["shapes"] = {} if shapes is None else shapes
        d["max_stress"], d["info"] = max_stress, {} if info is None else info


@dataclass(frozen=True)
class Solution:
    """The answer of one model on one scene.

    ``status`` is ``converged`` (every step satisfies the model's equations to its stated
    tolerance), ``failed`` (``message`` says why; ``steps`` holds the converged steps before
    the failure) or ``not-applicable`` (``message`` says why, no steps).
    """

    case: str
    model: str
    status: str
    message: str
    steps: tuple[Step, ...] = ()
    extras: Mapping[str, object] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, got {self.status!r}")

    @property
    def ok(self) -> bool:
        """True when the model converged on every step."""
        return self.status == "converged"

    def path(self, key: str) -> np.ndarray:
        """Values of one output (or ``factor``/``energy``) over the steps, shape (n_steps,)."""
        if key == "factor":
            return np.array([s.factor for s in self.steps])
        if key == "energy":
            return np.array([s.energy for s in self.steps])
        return np.array([s.outputs.get(key, np.nan) for s in self.steps])

    def to_frame(self, units: str | None = None) -> pd.DataFrame:
        """The steps as a tidy pandas DataFrame, one row per step.

        Parameters
        ----------
        units : the case's unit system (``"m-N-Pa"``, ``"mm-N-MPa"``, ``"nondim"``);
            default ``extras["units"]``, which ``reports.solve`` stores.

        Returns
        -------
        DataFrame with columns ``step``, ``factor``, every output key (``tip.uy``, ...),
        ``energy``, ``iterations``, ``stable`` and ``max_stress`` (NaN where not
        recovered).  ``df.attrs["units"]`` maps each column to its unit (``"m"``, ``"rad"``,
        ``"N m"``, ``"-"``); ``df.attrs`` also holds ``case``, ``model``, ``status`` and
        ``message``.
        """
        from reduced_models.notebook import to_frame

        return to_frame(self, units)

    def plot_path(self, y: str = "factor", x: str | None = None, ax: Axes | None = None,
                  **kwargs: object) -> Axes:  # fmt: skip
        """Draw output ``y`` against output ``x`` over the steps (matplotlib).

        Parameters
        ----------
        y, x : output keys, ``"factor"`` or ``"energy"``; ``x`` defaults to the first
            ``*.uy`` output (a load-deflection curve).
        ax : axes to draw on (default: a new figure).
        **kwargs : passed to ``ax.plot`` (``label`` defaults to the model name).

        Returns
        -------
        The axes, labelled with units.
        """
        from reduced_models.notebook import plot_path

        return plot_path(self, y, x, ax, **kwargs)

    def plot_shapes(self, steps: Sequence[int] | None = None, ax: Axes | None = None,
                    **kwargs: object) -> Axes:  # fmt: skip
        """Draw the deformed members at some steps, 1:1 (matplotlib).

        Parameters
        ----------
        steps : step indices (default: about five evenly spaced steps, the last included).
        ax : axes to draw on (default: a new figure).
        **kwargs : passed to ``ax.plot``.

        Returns
        -------
        The axes (equal aspect, lengths in the case's units).

        Raises
        ------
        ValueError
            When no step holds shapes.
        """
        from reduced_models.notebook import plot_shapes

        return plot_shapes(self, steps, ax, **kwargs)

    def _repr_html_(self) -> str:
        """Notebook summary: model, case, status, steps, final outputs, warnings."""
        from reduced_models.notebook import repr_html

        return repr_html(self)


@runtime_checkable
class Model(Protocol):
    """What the registry hands out."""

    name: str
    card: ModelCard

    def applies_to(self, scene: Scene) -> str | None:
        """None if the model can solve ``scene``, else a one-line reason why not."""
        ...

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of ``scene`` (never raises for a numerical failure)."""
        ...


def not_applicable(scene: Scene, model: str, reason: str) -> Solution:
    """A ``not-applicable`` solution with its reason."""
    return Solution(case=scene.name, model=model, status="not-applicable", message=reason)


def load_factors(scene: Scene) -> np.ndarray:
    """Reported load factors of a ``load`` analysis, shape (steps + 1,), starting at 0."""
    a = scene.analysis
    return _ramp(a.factor_end, a.steps).copy()  # a copy: the caller may write to it


@functools.lru_cache(maxsize=64)
def _ramp(end: float, steps: int) -> np.ndarray:
    """``np.linspace(0, end, steps + 1)``, made once per ramp (a linspace costs a small
    model's solve ~10 us)."""
    return np.linspace(0.0, end, steps + 1)


def post_process(model: Model, scene: Scene, sol: Solution) -> Solution:
    """``model.postprocess(scene, sol)`` when the model has that hook and solved something."""
    hook = getattr(model, "postprocess", None)
    if hook is None or not sol.steps:
        return sol
    return hook(scene, sol)
