"""Reduced models of compliant beams and mechanisms, behind one interface (``base``)."""

from reduced_models.base import Model, ModelCard, Solution, Step
from reduced_models.registry import DEFAULT_NAMES, MODELS, UnknownModelError, make, parse

__all__ = [
    "DEFAULT_NAMES",
    "MODELS",
    "Model",
    "ModelCard",
    "Solution",
    "Step",
    "UnknownModelError",
    "make",
    "parse",
]
