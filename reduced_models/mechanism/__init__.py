"""Mechanism assembler: every reduced beam model inside any compliant mechanism.

Rooms: ``topology`` (scene -> unknowns, supports), ``members`` (member energy laws and
potential terms), ``constraints`` (loop closure, sliders, drivers), ``system`` (evaluation:
gradients, Hessians, reduced KKT blocks), ``builder`` (scene -> system), ``newton``
(constrained Newton, continuation, reduced-Hessian stability), ``pathfollow`` (arc-length),
``analyses`` (load, distance, energy, kinematics), ``advantage`` (mechanical advantage),
``synthesis`` (flexural-stiffness and critical-load synthesis), ``model`` (registry-facing
models: ``kinetostatic``, ``mixed`` and the route of every reduced model name).

Extending (booms, other elements): append a term with ``energy(q)`` / ``local(q)`` to
``MechanismSystem.terms`` or a constraint family with ``values`` / ``jacobian`` /
``curvature`` to ``MechanismSystem.constraints`` before ``finish()``.
"""
