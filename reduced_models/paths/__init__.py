"""Path following for the reduced models: one continuation engine (``engine.minimize_path``:
Newton, load stepping, predicted starts, step cuts and branch keeping) in three arithmetics --
numpy arrays with LAPACK, banded and sparse tangents (``linalg.Arrays``), a list of plain
floats for a few unknowns and one bare float (``floats.Floats``, ``floats.Scalar``) -- and the
``PathResult`` it returns (``path_result``)."""
