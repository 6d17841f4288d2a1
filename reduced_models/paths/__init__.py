"""Path following for the reduced models: one step controller (``stepper.follow``: load
stepping, predicted starts, step cuts and branch watch) driving three arithmetic engines --
``continuation`` (numpy, LAPACK/sparse), ``small_path`` (plain floats for a few unknowns) and
``scalar_path`` (one float) -- the ``PathResult`` they return and the banded linear algebra
(``linalg``) they solve with."""
