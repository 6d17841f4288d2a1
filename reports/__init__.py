"""FlexBench reports: the one place that knows every model registry.

``reports.solve(scene, "prb-3r") -> Solution``, ``reports.make_model(name, scene)``,
``reports.model_names()``, ``reports.recommend(scene, tol)``, ``reports.load_run(DIR)`` (a run
folder as pandas DataFrames, ``reports.frames``).  The rooms inside:

* ``api`` (this package's door to every model) and ``cli`` (the ``flexbench`` command) on top;
* ``run/``: the benchmark matrix run, timed, guarded, journalled and stored
  (``reports.run.runner.run_matrix``; ``reports.run.compare`` checks regressions);
* ``verdicts/``: what a solution is worth: errors on the yardstick, tolerances, grades, the
  recommender and its pick, claims, atlases, predicted errors;
* ``render/``: report.html/.md, the teaching page and their figures;
* ``bench/``: benchmarks against limits and peers, memory and browser probes.

Nothing imports ``reports``.
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
    "load_run",
    "make_model",
    "model_names",
    "registry_table",
    "recommend",
    "solve",
]


def __getattr__(name: str) -> object:
    """``reports.recommend`` and ``reports.load_run`` on first use: a one-off ``solve`` does
    not import the recommender (and its statistics, fractions, decimal) or pandas."""
    if name == "recommend":
        from reports.verdicts.recommend import recommend

        return recommend
    if name == "load_run":
        from reports.frames import load_run

        return load_run
    raise AttributeError(f"module 'reports' has no attribute {name!r}")
