"""FE reference for FlexBench: 2-D corotational beams on scikit-fem meshes.

Modules: ``corotational`` (batched element kernel, scikit-fem element matrices), ``assembly``
(scene -> ``FEMSystem`` via ``build(scene, n_elements)``), ``static`` (Newton, load and
displacement control, arc-length, stability), ``richardson`` (observed order, extrapolation,
``fem-auto``), ``models`` (``fem-N``, ``fem-auto`` and the ``MODELS`` registry), plus the
Reissner cross-check, the dynamic replay and the export written alongside.

Imports are lazy on purpose: importing the package does not pull in scikit-fem or scipy.
"""
