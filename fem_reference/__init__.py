"""FE reference for FlexBench: 2-D corotational beams on scikit-fem meshes.

Modules: ``corotational`` (batched element kernel, scikit-fem element matrices), ``assembly``
(scene -> ``FEMSystem`` via ``build(scene, n_elements)``) with ``scatter`` (DOF maps and the
precomputed scatter) and ``femsystem`` (residual, band tangent, recovery), ``banded`` (LAPACK
band LU and Cholesky inertia); ``statics/`` (Newton, load and displacement control,
arc-length, bifurcation, integrity, deploy), ``error/`` (Richardson extrapolation, per-member
refinement), ``models`` (``fem-N`` and the ``MODELS`` registry), ``auto`` (``fem-auto``),
``replay/`` (the damped dynamics replay), plus the Reissner cross-check (``reissner``) and the
export (``export``).

Imports are lazy on purpose: importing the package does not pull in scikit-fem or scipy.
"""
