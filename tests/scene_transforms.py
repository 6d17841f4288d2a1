"""The same scene written another way (tests/test_metamorphic.py).

Each ``Encoding`` rewrites a validated ``Scene`` into an equivalent one -- rotated, mirrored,
translated, in other units, with renamed and reordered nodes, reversed members, or a pin
written as a clamp plus a pinned member end -- and maps the outputs of a solution of the
rewritten scene back to the original encoding.  A correct model gives the same answer in
every encoding; a difference is an encoding-dependent answer (a bug).

The geometric and unit part is one affine map of the plane and one change of units::

    x' = Lf * (Q @ (x - P)) + P'        Q = R(angle) @ diag(mirror, 1)
    force' = Ff * force                 (length unit divided by Lf, force unit by Ff)

so lengths scale by ``Lf``, forces by ``Ff``, moments and energies by ``Ff * Lf``, moduli and
stresses by ``Ff / Lf**2``, densities by ``Ff / Lf**4`` (time kept), rotations by
``det Q`` (a mirror turns them).  ``scene`` returns None where the case format cannot write
the transformed scene (a driver or an output direction along ``x``/``y`` under a 37 deg
rotation; a sweep of a quantity the transform changes), with the reason in ``why``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from cases.schema import Scene

_POINT_Q = ("x", "y", "ux", "uy", "rot")


@dataclass(frozen=True)
class Encoding:
    """One way of writing a scene differently.

    Attributes
    ----------
    name : short label used in test ids.
    angle_deg : rotation of the drawing (deg, counter-clockwise) about ``about``.
    mirror : reflect x -> -x (about ``about``) before rotating.
    about : the fixed point P of the map, as a fraction of the scene's length scale L from
        its first node (an arbitrary point, not the origin).
    shift : translation added after the map (in units of L, before scaling).
    Lf, Ff : new length and force measure of one old unit (m -> mm: Lf = 1000); set per
        scene from ``units`` by ``for_scene``.
    units : scene units label -> (new label, Lf, Ff): a change of units (None: unchanged).
    rename : give every node a new id (and reverse the node list).
    reverse : draw every member from its end b to its end a and reverse the member list.
    weld_pin : write a pinned support holding one welded member as a clamp and a pinned end.
    """

    name: str
    angle_deg: float = 0.0
    mirror: bool = False
    about: tuple[float, float] = (0.0, 0.0)
    shift: tuple[float, float] = (0.0, 0.0)
    Lf: float = 1.0
    Ff: float = 1.0
    units: dict[str, tuple[str, float, float]] | None = None
    rename: bool = False
    reverse: bool = False
    weld_pin: bool = False

    def for_scene(self, scene: Scene) -> Encoding:
        """This encoding with the length and force factors of the scene's units change."""
        if not self.units or scene.units not in self.units:
            return self
        _, Lf, Ff = self.units[scene.units]
        return replace(self, Lf=Lf, Ff=Ff)

    # -- the affine map ----------------------------------------------------------------------
    @property
    def Q(self) -> np.ndarray:
        """Rotation (and mirror) matrix, shape (2, 2)."""
        c, s = math.cos(math.radians(self.angle_deg)), math.sin(math.radians(self.angle_deg))
        return np.array([[c, -s], [s, c]]) @ np.diag([-1.0 if self.mirror else 1.0, 1.0])

    @property
    def det(self) -> float:
        """+1, or -1 for a mirror: the factor on rotations, moments and signed angles."""
        return -1.0 if self.mirror else 1.0

    def _axes_kept(self) -> bool:
        """True when x stays along +-x and y along y (a driver direction stays writable)."""
        return abs(math.remainder(self.angle_deg, 180.0)) < 1e-12

    def _frame(self, scene: Scene) -> tuple[np.ndarray, np.ndarray]:
        """(P, P') of the map for this scene (length units: old, new)."""
        L = length_scale(scene)
        n0 = np.array([scene.nodes[0].x, scene.nodes[0].y])
        P = n0 + L * np.asarray(self.about)
        return P, self.Lf * (P + L * np.asarray(self.shift))

    def point(self, scene: Scene, xy: np.ndarray) -> np.ndarray:
        """Old coordinates (..., 2) -> new coordinates."""
        P, P2 = self._frame(scene)
        return self.Lf * (np.asarray(xy) - P) @ self.Q.T + P2

    def point_back(self, scene: Scene, xy: np.ndarray) -> np.ndarray:
        """New coordinates (..., 2) -> old coordinates."""
        P, P2 = self._frame(scene)
        return (np.asarray(xy) - P2) @ self.Q / self.Lf + P

    def node_id(self, nid: str) -> str:
        return f"renamed_{nid[::-1]}_{len(nid)}" if self.rename else nid

    # -- the scene ---------------------------------------------------------------------------
    def scene(self, scene: Scene) -> Scene | None:
        """The scene in this encoding, or None where the format cannot write it (``why``)."""
        if self.why(scene):
            return None
        Lf, Ff, det = self.Lf, self.Ff, self.det
        xy = self.point(scene, np.array([[n.x, n.y] for n in scene.nodes]))
        nodes = tuple(
            replace(n, id=self.node_id(n.id), x=float(p[0]), y=float(p[1]))
            for n, p in zip(scene.nodes, xy, strict=True)
        )
        # a stable-position synthesis moves its link's end b (the contract): that link keeps
        # its direction, or another node would move
        syn = scene.analysis.synthesis
        keep = set(syn.members) if syn is not None and syn.goal == "stable-position" else set()
        members = tuple(self._member(m, m.id not in keep) for m in scene.members)
        supports = tuple(self._support(s) for s in scene.supports)
        loads = tuple(self._load(ld, scene) for ld in scene.loads)
        springs = tuple(
            replace(
                t,
                node=self.node_id(t.node),
                stiffness=t.stiffness * Ff * Lf,
                free_angle_deg=det * t.free_angle_deg,
                rest_angle_deg=None,  # resolved into free_angle_deg by the loader
            )
            for t in scene.torsion_springs
        )
        booms = tuple(
            replace(
                b,
                a=self.node_id(b.a),
                b=self.node_id(b.b),
                force=b.force * Ff,
                length=b.length * Lf,
            )
            for b in scene.booms
        )
        outputs = tuple(replace(o, node=self.node_id(o.node)) for o in scene.outputs)
        if self.rename:
            nodes = nodes[::-1]
        if self.reverse:
            members = members[::-1]
        if self.weld_pin:
            supports, members = self._weld_pin(scene, supports, members)
        units = (self.units or {}).get(scene.units, (scene.units,))[0]
        return replace(
            scene,
            units=units,
            nodes=nodes,
            members=members,
            supports=supports,
            loads=loads,
            torsion_springs=springs,
            booms=booms,
            outputs=outputs,
            analysis=self._analysis(scene),
        )

    def why(self, scene: Scene) -> str:
        """Why the case format cannot write ``scene`` in this encoding ('' when it can)."""
        an = scene.analysis
        if not self._axes_kept():
            if an.driver is not None and an.driver.kind == "displacement":
                return "a displacement driver along x/y cannot be rotated by an oblique angle"
            if an.ma is not None and an.ma.direction in ("x", "y"):
                return "an MA direction along x/y cannot be rotated by an oblique angle"
            if an.stop_output and quantity(an.stop_output) in ("x", "y", "ux", "uy"):
                return "a stop output along x/y cannot be rotated by an oblique angle"
            if an.synthesis is not None and an.synthesis.output:
                if quantity(an.synthesis.output) in ("x", "y", "ux", "uy"):
                    return "a synthesis target along x/y cannot be rotated"
        keys = [an.sweep_key] if an.sweep_key else []
        keys += [k for ax in an.grid for k in ax.keys]
        if keys and (self.Lf != 1.0 or self.Ff != 1.0 or self.mirror):
            return "a sweep of a dimensional or signed quantity (not rewritten here)"
        if self.units is not None and scene.units not in self.units:
            return f"no other units to write {scene.units} scenes in"
        if self.weld_pin and self.name == "weldpin" and not self._weld_pin_nodes(scene):
            return "no pinned support holding a single welded member"
        return ""

    def _member(self, m, reversible: bool = True):
        Lf, Ff = self.Lf, self.Ff
        scaled = {
            "E": Ff / Lf**2,
            "I": Lf**4,
            "A": Lf**2,
            "thickness": Lf,
            "width": Lf,
            "k": Ff / Lf,
            "free_length": Lf,
            "density": Ff / Lf**4,
        }
        kw = {f: getattr(m, f) * s for f, s in scaled.items() if getattr(m, f) is not None}
        kw.update(a=self.node_id(m.a), b=self.node_id(m.b), sweep_deg=self.det * m.sweep_deg)
        if self.reverse and reversible:
            kw.update(
                a=kw["b"], b=kw["a"], end_a=m.end_b, end_b=m.end_a, sweep_deg=-kw["sweep_deg"]
            )
        return replace(m, **kw)

    def _support(self, s):
        ang = s.angle_deg
        if s.type == "slider":
            ang = (180.0 - ang if self.mirror else ang) + self.angle_deg
        return replace(s, node=self.node_id(s.node), angle_deg=ang)

    def _load(self, ld, scene: Scene):
        f = self.Ff * (self.Q @ np.array([ld.fx, ld.fy]))
        kw = dict(fx=float(f[0]), fy=float(f[1]), moment=self.det * self.Ff * self.Lf * ld.moment)
        if ld.node is not None:
            kw["node"] = self.node_id(ld.node)
        syn = scene.analysis.synthesis
        keep = syn is not None and syn.goal == "stable-position" and ld.member in syn.members
        if self.reverse and ld.fraction is not None and not keep:
            kw["fraction"] = 1.0 - ld.fraction
        return replace(ld, **kw)

    def _analysis(self, scene: Scene):
        an = scene.analysis
        kw = {}
        if an.driver is not None:
            kw["driver"] = self._driver(an.driver)
        if an.stop_output is not None and an.stop_value is not None:
            kw["stop_value"] = self.value_to(scene, an.stop_output, an.stop_value)
        syn = an.synthesis
        if syn is not None and syn.goal == "stiffness":  # target: a value of its output
            kw["synthesis"] = replace(syn, target=self.value_to(scene, syn.output, syn.target))
        elif syn is not None and syn.goal == "critical-load":  # a force or a torque
            force = an.driver is not None and an.driver.kind == "displacement"
            scale = self.Ff if force else self.Ff * self.Lf
            kw["synthesis"] = replace(syn, target=syn.target * scale)
        elif syn is not None and syn.goal == "stable-position":  # a driver coordinate
            kw["synthesis"] = replace(syn, target=self.driver_to(scene, syn.target))
        return replace(an, **kw)

    def _driver(self, d):
        sign = self._direction_sign(d.direction if d.kind == "displacement" else "rot")
        scale = self.Lf if d.kind == "displacement" else 1.0
        return replace(
            d,
            start=sign * scale * d.start,
            stop=sign * scale * d.stop,
            node=self.node_id(d.node) if d.node else None,
        )

    def _direction_sign(self, direction: str | None) -> float:
        """Sign a coordinate along ``direction`` (x, y, rot) takes in the new encoding (axes
        kept: a 180 deg turn flips x and y, a mirror flips x and rot)."""
        turn = -1.0 if abs(math.remainder(self.angle_deg, 360.0)) > 90.0 else 1.0
        if direction == "rot":
            return self.det
        return turn * (self.det if direction == "x" else 1.0)

    def driver_to(self, scene: Scene, value: float) -> float:
        """A driver coordinate (Step.factor of an energy/kinematics analysis) -> new."""
        d = scene.analysis.driver
        if d is None:
            return value
        if d.kind == "displacement":
            return self._direction_sign(d.direction) * self.Lf * value
        return self.det * value

    def value_to(self, scene: Scene, key: str, value: float) -> float:
        """A single output value (of a key whose quantity needs no partner) -> new encoding."""
        q = quantity(key)
        if q in ("x", "y"):
            n = next(o.node for o in scene.outputs if o.name == key.rsplit(".", 1)[0])
            old = np.array([scene.node(n).x, scene.node(n).y])
            axis = 0 if q == "x" else 1
            new0 = self.point(scene, old)
            return float(new0[axis] + self._direction_sign(q) * self.Lf * (value - old[axis]))
        if q in ("ux", "uy"):
            return self._direction_sign(q[1]) * self.Lf * value
        return value * self._unit(scene, key)

    def _unit(self, scene: Scene, key: str) -> float:
        """Factor (sign included) of a non-point output in the new encoding."""
        Lf, Ff, det = self.Lf, self.Ff, self.det
        q = quantity(key)
        if key == "energy":
            return Ff * Lf
        if key == "driver.force":
            return Ff * self._direction_sign(scene.analysis.driver.direction)
        if key == "driver.torque":
            return Ff * Lf * det
        if key == "max_stress":
            return Ff / Lf**2
        if key == "ma":
            ma = scene.analysis.ma
            s_in = (
                self._direction_sign(scene.analysis.driver.direction or "rot")
                if ma.input == "driver"
                else 1.0
            )
            return s_in * self._direction_sign(ma.direction)
        if q == "rot":
            return det
        if q == "length":
            return Lf
        return 1.0

    # -- the weld + pin rewrite --------------------------------------------------------------
    def _weld_pin_nodes(self, scene: Scene) -> list[str]:
        """Pinned-support nodes holding exactly one member, welded, no spring, no moment."""
        out = []
        for s in scene.supports:
            if s.type != "pin":
                continue
            ends = [
                (m, e)
                for m in scene.members
                for e, nid in (("a", m.a), ("b", m.b))
                if nid == s.node and m.kind == "flexible"
            ]
            springs = [t for t in scene.torsion_springs if t.node == s.node]
            moments = [ld for ld in scene.loads if ld.node == s.node and ld.moment]
            booms = [b for b in scene.booms if s.node in (b.a, b.b)]
            if len(ends) == 1 and getattr(ends[0][0], f"end_{ends[0][1]}") == "weld":
                if not (springs or moments or booms):
                    out.append(s.node)
        return out

    def _weld_pin(self, scene: Scene, supports, members):
        nodes = {self.node_id(n) for n in self._weld_pin_nodes(scene)}
        supports = tuple(replace(s, type="clamp") if s.node in nodes else s for s in supports)
        members = tuple(
            replace(
                m,
                end_a="pin" if m.a in nodes else m.end_a,
                end_b="pin" if m.b in nodes else m.end_b,
            )
            for m in members
        )
        return supports, members

    def skipped_keys(self, scene: Scene) -> set[str]:
        """Output keys whose meaning the encoding changes (a clamp's node rotation is 0
        where the pinned member end turns): not compared."""
        if not self.weld_pin:
            return set()
        nodes = set(self._weld_pin_nodes(scene))
        return {f"{o.name}.rot" for o in scene.outputs if o.node in nodes}

    # -- outputs back ------------------------------------------------------------------------
    def outputs_back(self, scene: Scene, out: dict[str, float]) -> dict[str, float]:
        """Outputs of a solution of the new scene -> the original encoding."""
        back = {}
        for o in scene.outputs:
            p = o.name
            if f"{p}.x" in out and f"{p}.y" in out:
                xy = self.point_back(scene, np.array([out[f"{p}.x"], out[f"{p}.y"]]))
                back[f"{p}.x"], back[f"{p}.y"] = float(xy[0]), float(xy[1])
            if f"{p}.ux" in out and f"{p}.uy" in out:
                u = np.array([out[f"{p}.ux"], out[f"{p}.uy"]]) @ self.Q / self.Lf
                back[f"{p}.ux"], back[f"{p}.uy"] = float(u[0]), float(u[1])
        for k, v in out.items():
            if k not in back:
                back[k] = v / self._unit(scene, k)
        return back

    def factor_back(self, scene: Scene, factor: float) -> float:
        """Step.factor of the new scene -> original (a driver coordinate where it is one)."""
        if scene.analysis.kind in ("energy", "kinematics") or (
            scene.analysis.kind == "synthesis" and scene.analysis.driver is not None
        ):
            return factor / self.driver_to(scene, 1.0)
        return factor


def quantity(key: str) -> str:
    """``tip.uy`` -> ``uy``; ``boom.length`` -> ``length``; ``energy`` -> ``energy``."""
    return key.rsplit(".", 1)[-1]


def length_scale(scene: Scene) -> float:
    """The scene's length scale: the largest member length (length units)."""
    return max(scene.member_length(m.id) for m in scene.members)


#: the other unit system of each (label, length factor, force factor): m <-> mm, and a
#: dimensionless scene measured in thousandths of its length unit
UNITS_MM = {
    "m-N-Pa": ("mm-N-MPa", 1e3, 1.0),
    "mm-N-MPa": ("m-N-Pa", 1e-3, 1.0),
    "nondim": ("nondim", 1e3, 1.0),
}

#: the encodings every case is tried in (one change each, then all at once)
ENCODINGS = (
    Encoding("rotate37", angle_deg=37.0, about=(0.31, -0.72)),
    Encoding("mirror", mirror=True, about=(-0.43, 0.17)),
    Encoding("translate", shift=(12.5, -7.25)),
    Encoding("units", units=UNITS_MM),
    Encoding("unitsdown", units={"nondim": ("nondim", 1e-3, 1e3)}),
    Encoding("relabel", rename=True),
    Encoding("reverse", reverse=True),
    Encoding("weldpin", weld_pin=True),
    Encoding(
        "all",
        angle_deg=37.0,
        mirror=True,
        about=(0.31, -0.72),
        shift=(3.0, 2.0),
        units=UNITS_MM,
        rename=True,
        weld_pin=True,
    ),
)
