"""FE reference for FlexBench: 2-D corotational beams on scikit-fem meshes.

Modules: ``corotational`` (batched element kernel, scikit-fem element matrices), ``assembly``
(scene -> ``FEMSystem`` via ``build(scene, n_elements)``) with ``scatter`` (DOF maps and the
precomputed scatter) and ``femsystem`` (residual, band tangent, recovery), ``static`` (load and
displacement control, stability) with ``newton``, ``arclength`` and ``banded`` (LAPACK band LU
and Cholesky inertia), ``richardson`` (observed order, extrapolation,
``fem-auto``), ``models`` (``fem-N``, ``fem-auto`` and the ``MODELS`` registry), plus the
Reissner cross-check, the dynamic replay and the export written alongside.

Imports are lazy on purpose: importing the package does not pull in scikit-fem or scipy.
"""
