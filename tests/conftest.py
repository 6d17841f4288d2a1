"""Test-session set-up: one BLAS thread, as in the runner's workers and ``flexbench solve``.

The suite's linear algebra is small and banded, far below threaded BLAS's break-even; on the
2-core CI machine threaded OpenBLAS made single FE solves up to 80x slower.  The variables
cover BLAS libraries loaded later (scipy ships its own OpenBLAS); ``pin_blas`` the loaded ones.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from reports import timing  # noqa: E402  (after the variables, so a BLAS loaded now obeys)

timing.pin_blas()
