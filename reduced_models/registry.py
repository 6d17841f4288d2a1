"""The explicit registry of reduced models and name parsing.

``MODELS`` maps a family name to a factory.  Parametrised names carry an integer suffix:
``linear-8`` -> ``MODELS["linear-N"](8)``, ``cbcm-4`` -> ``MODELS["cbcm-N"](4)``,
``prb-fsm-12`` -> ``MODELS["prb-fsm-N"](12)``.  Plain names map to a factory called with no
argument.  ``DEFAULT_NAMES`` is the set a default benchmark run uses.

Modules register themselves here by name only: the dict below is the single place that says
which models exist (other registries, like the FE reference's, are merged by ``reports``).
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable

from reduced_models.base import Model
from reduced_models.options import validate

# name (with "-N" for parametrised families) -> "module:factory"
_ENTRIES: dict[str, str] = {
    "elastica": "reduced_models.beam.elastica:Elastica",
    "elastica-bvp": "reduced_models.beam.elastica_bvp:ElasticaBVP",
    "linear-N": "reduced_models.beam.linear:LinearChain",
    "bcm": "reduced_models.beam.bcm:BCM",
    "cbcm-N": "reduced_models.beam.bcm:ChainedBCM",
    "prb-short": "reduced_models.beam.prb:PRBShort",
    "prb-1r": "reduced_models.beam.prb:PRB1R",
    "prb-2r": "reduced_models.beam.prb:PRB2R",
    "prb-3r": "reduced_models.beam.prb:PRB3R",
    "prb-3r-force": "reduced_models.beam.prb:PRB3RForce",
    "prb-3r-moment": "reduced_models.beam.prb:PRB3RMoment",
    "prb-2rpr": "reduced_models.beam.prb:PRB2RPR",
    "prb-fsm-N": "reduced_models.beam.prb:PRBFSM",
    "prb-custom": "reduced_models.beam.prb:PRBCustom",
    "thesis-force-method": "reduced_models.thesis.force_method:ThesisForceMethod",
    "kinetostatic": "reduced_models.mechanism.model:Kinetostatic",
    "mixed": "reduced_models.mechanism.model:Mixed",
    "linear-auto": "reduced_models.auto:LinearAuto",
    "cbcm-auto": "reduced_models.auto:CBCMAuto",
    "prb-fsm-auto": "reduced_models.auto:PRBFSMAuto",
}
# single-beam families: scenes that are not a plain cantilever go to the mechanism assembler
_SINGLE_BEAM = tuple(
    f"reduced_models.beam.{m}:" for m in ("elastica", "elastica_bvp", "linear", "bcm", "prb")
)

# concrete names a default benchmark run tries on every case
DEFAULT_NAMES: tuple[str, ...] = (
    "elastica",
    "elastica-bvp",
    "linear-1",
    "linear-8",
    "bcm",
    "cbcm-2",
    "cbcm-8",
    "prb-short",
    "prb-1r",
    "prb-2r",
    "prb-3r",
    "prb-2rpr",
    "prb-fsm-4",
    "prb-fsm-16",
    "kinetostatic",
    "mixed",
    "linear-auto",
    "cbcm-auto",
    "prb-fsm-auto",
)


def factory(target: str) -> Callable[..., Model]:
    """Import a ``"module:Factory"`` registry target."""
    module, attr = target.split(":")
    return getattr(importlib.import_module(module), attr)


MODELS: dict[str, str] = dict(_ENTRIES)

_PARAM = re.compile(r"^(?P<family>[a-z0-9-]+?)-(?P<n>\d+)$")


class UnknownModelError(ValueError):
    """A model name the registry does not know (message names it and lists valid names)."""


def parse(name: str, table: dict[str, str] | None = None) -> tuple[str, int | None]:
    """Split ``"cbcm-4"`` into ``("cbcm-N", 4)``; plain names give ``(name, None)``.

    ``table`` is the registry to look in (default ``MODELS``; ``reports`` passes the merged
    registry of every package).
    """
    table = MODELS if table is None else table
    if name in table:
        return name, None
    m = _PARAM.match(name)
    if m and f"{m['family']}-N" in table:
        n = int(m["n"])
        if n < 1:
            raise UnknownModelError(f"model {name!r}: N must be a positive integer")
        return f"{m['family']}-N", n
    raise UnknownModelError(
        f"unknown model {name!r}; known: {', '.join(sorted(table))} (N = positive integer)"
    )


def build(name: str, target: str, n: int | None, options: dict | None = None) -> Model:
    """Instantiate a parsed model (``n`` as first positional argument, options as kwargs)."""
    make_ = factory(target)
    kwargs = dict(options or {})
    declared = getattr(make_, "OPTIONS", None)
    if declared is not None:  # names, types and ranges declared next to the model
        validate(name, declared, kwargs)
    model = make_(n, **kwargs) if n is not None else make_(**kwargs)
    model.name = name
    if target.startswith(_SINGLE_BEAM):
        from reduced_models.routing import routed  # the assembler is imported on first use

        model = routed(model, name, options)
    return model


def make(name: str, options: dict | None = None) -> Model:
    """Build a model from its registry name (``options`` from the case, e.g. a PRB matrix)."""
    family, n = parse(name)
    return build(name, MODELS[family], n, options)
