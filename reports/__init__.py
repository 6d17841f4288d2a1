"""FlexBench reports: the one place that knows every model registry.

``reports.solve(scene, "prb-3r") -> Solution``, ``reports.make_model(name, scene)``,
``reports.model_names()``; ``reports.runner.run_matrix`` runs the case x model matrix,
``reports.compare`` checks regressions, ``reports.render`` writes report.html/.md, and
``reports.cli`` is the ``flexbench`` command.  Nothing imports ``reports``.
"""

from reports.api import (
    UnknownModelError,
    card_of,
    default_names,
    make_model,
    model_names,
    registry_table,
    solve,
)

__all__ = [
    "UnknownModelError",
    "card_of",
    "default_names",
    "make_model",
    "model_names",
    "registry_table",
    "recommend",
    "solve",
]


def __getattr__(name: str) -> object:
    """``reports.recommend`` on first use: a one-off ``solve`` does not import the
    recommender (and its statistics, fractions, decimal)."""
    if name == "recommend":
        from reports.recommend import recommend

        return recommend
    raise AttributeError(f"module 'reports' has no attribute {name!r}")
