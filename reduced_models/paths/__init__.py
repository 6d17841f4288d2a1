"""Path following for the reduced models: one continuation engine (``engine.minimize_path``:
Newton, load stepping, predicted starts, step cuts and branch keeping) in two arithmetics --
numpy arrays with LAPACK, banded and sparse tangents (``linalg``) and plain floats for a few
unknowns (``floats``) -- and the ``PathResult`` it returns (``path_result``)."""
