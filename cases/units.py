"""Consistent unit systems of a scene and the conversion of a scene between them.

Every declared system except ``nondim`` is a consistent (length, force) pair; stress and
modulus are force / length^2 (Pa = N/m^2, MPa = N/mm^2, psi = lbf/in^2), moment and energy
force x length, mass force x s^2 / length, so the solvers are unit-agnostic and a scene
converted here solves to the same answer, converted.  The factors are exact by definition
(NIST SP 811: 1 in = 0.0254 m, 1 lbf = 4.4482216152605 N).
"""

from __future__ import annotations

import dataclasses

from cases.schema import Scene

#: system -> (metres per length unit, newtons per force unit)
SYSTEMS: dict[str, tuple[float, float]] = {
    "m-N-Pa": (1.0, 1.0),
    "mm-N-MPa": (1e-3, 1.0),
    "in-lbf-psi": (0.0254, 4.4482216152605),
}
#: (length, force) exponents of an output's quantity, by the key's last part or its name
_TRANSLATION = ("x", "y", "ux", "uy")
_DIMS = {"driver.force": (0, 1), "driver.torque": (1, 1), "energy": (1, 1)}


def factors(src: str, dst: str) -> tuple[float, float]:
    """(length, force) factors from ``src`` units to ``dst`` units: a length in ``src`` times
    the first is the length in ``dst``.  Raises ValueError for ``nondim`` or an unknown name."""
    for u in (src, dst):
        if u not in SYSTEMS:
            raise ValueError(f"units {u!r} have no conversion (known: {', '.join(SYSTEMS)})")
    (ls, fs), (ld, fd) = SYSTEMS[src], SYSTEMS[dst]
    return ls / ld, fs / fd


def output_dims(key: str) -> tuple[int, int]:
    """(length, force) exponents of an output key: translations (1, 0), rotations, load
    factor and mechanical advantage (0, 0), driver force (0, 1), torque and energy (1, 1);
    a displacement driver's coordinate ``factor`` is handled by ``convert``."""
    if key in _DIMS:
        return _DIMS[key]
    return (1, 0) if key.rsplit(".", 1)[-1] in _TRANSLATION else (0, 0)


def convert(scene: Scene, units: str) -> Scene:
    """``scene`` written in ``units``: geometry, sections, moduli, springs, loads, booms, a
    displacement driver's range, the path's stop value and the references' values.  A
    synthesis target has goal-dependent units and is refused (ValueError), as is ``nondim``."""
    L, F = factors(scene.units, units)
    if scene.analysis.synthesis is not None:
        raise ValueError("a synthesis scene is not converted (its target's units vary by goal)")

    def opt(v: float | None, s: float) -> float | None:
        return None if v is None else v * s

    nodes = tuple(dataclasses.replace(n, x=n.x * L, y=n.y * L) for n in scene.nodes)
    members = tuple(
        dataclasses.replace(
            m,
            E=opt(m.E, F / L**2),
            I=opt(m.I, L**4),
            A=opt(m.A, L**2),
            thickness=opt(m.thickness, L),
            width=opt(m.width, L),
            k=opt(m.k, F / L),  # a linear spring member: force per length
            free_length=opt(m.free_length, L),
            density=opt(m.density, F / L**4),  # force s^2 / length^4
        )
        for m in scene.members
    )
    loads = tuple(
        dataclasses.replace(ld, fx=ld.fx * F, fy=ld.fy * F, moment=ld.moment * F * L)
        for ld in scene.loads
    )
    springs = tuple(
        dataclasses.replace(t, stiffness=t.stiffness * F * L) for t in scene.torsion_springs
    )
    booms = tuple(
        dataclasses.replace(b, force=b.force * F, length=b.length * L) for b in scene.booms
    )
    a = scene.analysis
    drv = a.driver
    if drv is not None and drv.kind == "displacement":
        drv = dataclasses.replace(drv, start=drv.start * L, stop=drv.stop * L)
    stop = a.stop_value
    if stop is not None and a.stop_output is not None:
        stop *= _scale(output_dims(a.stop_output), L, F)
    a = dataclasses.replace(a, driver=drv, stop_value=stop)
    dist = a.driver is not None and a.driver.kind == "displacement"
    refs = tuple(
        dataclasses.replace(
            r,
            value=r.value * _scale(output_dims(r.output), L, F),
            tolerance=r.tolerance * (_scale(output_dims(r.output), L, F) if r.abs_tolerance else 1),
            at_factor=None if r.at_factor is None else r.at_factor * (L if dist else 1.0),
        )
        for r in scene.references
    )
    return dataclasses.replace(
        scene,
        units=units,
        nodes=nodes,
        members=members,
        loads=loads,
        torsion_springs=springs,
        booms=booms,
        analysis=a,
        references=refs,
    )


def _scale(dims: tuple[int, int], L: float, F: float) -> float:
    return L ** dims[0] * F ** dims[1]


__all__ = ["SYSTEMS", "convert", "factors", "output_dims"]
