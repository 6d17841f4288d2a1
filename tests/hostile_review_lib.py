"""Outside review of issue 23 (not collected by pytest): scene writer, encodings, truths.

A scene is a plain dict shaped like its TOML file.  ``encodings`` rewrites it (rotated,
mirrored, translated, other units, nodes renamed and reordered, members reversed) and gives
the map that brings the encoded outputs back; ``elastica_path`` is an independent
(extensible) elastica of a cantilever under a dead or follower tip force, solved here by
shooting with scipy, sharing nothing with the project's models.
"""

from __future__ import annotations

import copy
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

# ----------------------------------------------------------------------------- TOML writer


def _val(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_val(x) for x in v) + "]"
    raise TypeError(type(v))


def _table(lines: list[str], header: str, d: dict) -> None:
    lines.append(header)
    subs = []
    for k, v in d.items():
        if isinstance(v, dict):
            subs.append((k, v))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            subs.append((k, v))
        else:
            lines.append(f"{k} = {_val(v)}")
    name = header.strip("[]")
    for k, v in subs:
        if isinstance(v, dict):
            _table(lines, f"[{name}.{k}]", v)
        else:
            for item in v:
                _table(lines, f"[[{name}.{k}]]", item)
    lines.append("")


def to_toml(scene: dict) -> str:
    """TOML text of a scene dict (tables first as [x], arrays of tables as [[x]])."""
    lines: list[str] = []
    for k, v in scene.items():
        if isinstance(v, dict):
            _table(lines, f"[{k}]", v)
        else:
            for item in v:
                _table(lines, f"[[{k}]]", item)
    return "\n".join(lines)


# ----------------------------------------------------------------------------- encodings

LENGTH_KEYS = ("x", "y", "ux", "uy")


def _rot2(v, th):
    c, s = math.cos(th), math.sin(th)
    return c * v[0] - s * v[1], s * v[0] + c * v[1]


def rigid_motion(scene: dict, th_deg: float, mirror: bool, shift=(0.0, 0.0)) -> dict:
    """The scene mirrored (x -> -x, first), rotated by th_deg about the origin, translated."""
    sc = copy.deepcopy(scene)
    th = math.radians(th_deg)
    sg = -1.0 if mirror else 1.0

    def pt(x, y):
        x, y = _rot2((sg * x, y), th)
        return x + shift[0], y + shift[1]

    def vec(x, y):
        return _rot2((sg * x, y), th)

    for n in sc["nodes"]:
        n["x"], n["y"] = pt(n["x"], n["y"])
    for m in sc.get("members", []):
        if "sweep_deg" in m and mirror:
            m["sweep_deg"] = -m["sweep_deg"]
    for s in sc.get("supports", []):
        if s.get("type") == "slider":
            a = s.get("angle_deg", 0.0)
            s["angle_deg"] = (180.0 - a if mirror else a) + th_deg
    for ld in sc.get("loads", []):
        ld["fx"], ld["fy"] = vec(ld.get("fx", 0.0), ld.get("fy", 0.0))
        if mirror and "moment" in ld:
            ld["moment"] = -ld["moment"]
    for t in sc.get("torsion_springs", []):
        if mirror and "free_angle_deg" in t:
            t["free_angle_deg"] = -t["free_angle_deg"]
        if "rest_angle_deg" in t:
            raise ValueError("rest_angle_deg: no rigid-motion rule")
    dr = sc.get("analysis", {}).get("driver")
    sgn = 1.0  # the driver coordinate's sign
    if dr:
        if dr["kind"] == "rotation":
            sgn = sg
        else:
            dr["direction"], sgn = _axis(vec(*_AXES[dr["direction"]]))
        dr["start"], dr["stop"] = sgn * dr["start"], sgn * dr["stop"]
    an = sc.get("analysis", {})
    if "stop_output" in an and an["stop_output"].split(".")[-1] in LENGTH_KEYS:
        raise ValueError("stop_output in a direction: no rigid-motion rule")
    if an.get("ma", {}).get("direction") in ("x", "y"):
        an["ma"]["direction"] = _axis(vec(*_AXES[an["ma"]["direction"]]))[0]
    syn = an.get("synthesis", {})
    if syn.get("goal") == "stiffness":  # the target is a value of the output
        p, q = syn["output"].rsplit(".", 1)
        if q == "rot":
            syn["target"] *= sg
        elif q in LENGTH_KEYS:
            if q in ("x", "y"):
                raise ValueError("synthesis target on a position: no rigid-motion rule")
            ax, so = _axis(vec(*_AXES[q[1]]))
            syn["output"], syn["target"] = f"{p}.u{ax}", so * syn["target"]
    elif syn.get("goal") == "stable-position":  # the target is a driver coordinate
        syn["target"] *= sgn
    return sc


_AXES = {"x": (1.0, 0.0), "y": (0.0, 1.0)}


def _axis(e) -> tuple[str, float]:
    """(axis name, sign) of a unit vector on a coordinate axis."""
    if abs(abs(e[0]) - 1) < 1e-12:
        return "x", math.copysign(1.0, e[0])
    if abs(abs(e[1]) - 1) < 1e-12:
        return "y", math.copysign(1.0, e[1])
    raise ValueError("a driver or ma direction off the axes after the rotation")


def back_rigid(out: dict, factor: float, scene: dict, th_deg, mirror, shift):
    """Outputs of the encoded scene brought back to the base frame (None for unknown keys)."""
    th = math.radians(th_deg)
    sg = -1.0 if mirror else 1.0
    res = {}
    pts = {k.rsplit(".", 1)[0] for k in out if k.rsplit(".", 1)[-1] in ("x", "y", "ux")}
    for p in pts:
        if f"{p}.x" in out:
            x, y = out[f"{p}.x"] - shift[0], out[f"{p}.y"] - shift[1]
            x, y = _rot2((x, y), -th)
            res[f"{p}.x"], res[f"{p}.y"] = sg * x, y
        if f"{p}.ux" in out:
            u, v = _rot2((out[f"{p}.ux"], out[f"{p}.uy"]), -th)
            res[f"{p}.ux"], res[f"{p}.uy"] = sg * u, v
        if f"{p}.rot" in out:
            res[f"{p}.rot"] = sg * out[f"{p}.rot"]
    dr = scene.get("analysis", {}).get("driver")
    dsg = 1.0
    if dr and dr["kind"] == "rotation" or _searched_crank(scene, out):
        dsg = sg
    elif dr:
        d = (1.0, 0.0) if dr["direction"] == "x" else (0.0, 1.0)
        e = _rot2((sg * d[0], d[1]), th)
        dsg = e[0] + e[1]
    for k, v in out.items():
        if k in res or k.rsplit(".", 1)[0] in pts:
            continue
        if k == "driver.force":
            res[k] = dsg * v
        elif k == "driver.torque":
            res[k] = sg * v
        elif k.endswith(".angle"):
            res[k] = sg * v
        elif k == "ma":
            res[k] = _ma_sign(scene, th, sg, dsg) * v
        else:
            res[k] = v
    return res, dsg * factor if _driver_factor(scene) or _searched_crank(scene, out) else factor


def _searched_crank(scene: dict, out: dict) -> bool:
    """A bistable search that drives the path it reports by a crank of its choice (a driver
    torque output): the factor is that crank's angle, turned by a mirror."""
    syn = scene.get("analysis", {}).get("synthesis", {})
    return syn.get("goal") == "bistable" and "driver.torque" in out


def _driver_factor(scene: dict) -> bool:
    """Whether the step factor is the driver's coordinate (in a distance analysis the driver
    coordinate is the target and the factor the load factor: invariant)."""
    an = scene.get("analysis", {})
    return "driver" in an and an.get("kind") != "distance"


def _ma_sign(scene: dict, th: float, sg: float, dsg: float) -> float:
    """Sign of the drawn ``ma`` over the encoded one: ma = d(input)/d(output coordinate)
    (times an energy ratio that no rigid motion changes), so it flips with the output axis and,
    for a driver input, with the driver's coordinate."""
    ma = scene["analysis"]["ma"]
    so = sg
    if ma["direction"] in _AXES:
        d = _AXES[ma["direction"]]
        so = _axis(_rot2((sg * d[0], d[1]), th))[1]
    return so * (dsg if ma.get("input", "driver") == "driver" else 1.0)


def scale_units(scene: dict, sl: float, sf: float, units: str) -> dict:
    """The scene with lengths times sl and forces times sf (declared as ``units``)."""
    sc = copy.deepcopy(scene)
    sc["case"]["units"] = units
    for n in sc["nodes"]:
        n["x"] *= sl
        n["y"] *= sl
    for m in sc.get("members", []):
        for k, p in (("E", sf / sl**2), ("I", sl**4), ("A", sl**2), ("width", sl)):
            if k in m:
                m[k] *= p
        for k in ("thickness", "free_length"):
            if k in m:
                m[k] *= sl
        if "k" in m:
            m["k"] *= sf / sl
        if "density" in m:
            raise ValueError("density: not converted here")
    for ld in sc.get("loads", []):
        for k in ("fx", "fy"):
            if k in ld:
                ld[k] *= sf
        if "moment" in ld:
            ld["moment"] *= sf * sl
    for t in sc.get("torsion_springs", []):
        t["stiffness"] *= sf * sl
    for b in sc.get("booms", []):
        b["force"] *= sf
        b["length"] *= sl
        if "stop_stiffness" in b:
            b["stop_stiffness"] *= sf / sl
    an = sc.get("analysis", {})
    dr = an.get("driver")
    if dr and dr["kind"] == "displacement":
        dr["start"] *= sl
        dr["stop"] *= sl
    syn = an.get("synthesis", {})
    if syn.get("goal") == "stiffness" and syn["output"].rsplit(".", 1)[-1] in LENGTH_KEYS:
        syn["target"] *= sl
    elif syn.get("goal") == "stable-position" and dr["kind"] == "displacement":
        syn["target"] *= sl
    elif syn.get("goal") == "critical-load":  # a driving force or torque
        syn["target"] *= sf * (sl if dr["kind"] == "rotation" else 1.0)
    if "stop_output" in an:
        last = an["stop_output"].rsplit(".", 1)[-1]
        if last in LENGTH_KEYS:
            an["stop_value"] *= sl
        elif last != "rot":
            raise ValueError("stop_output: no unit rule")
    return sc


def back_units(out: dict, factor: float, scene: dict, sl: float, sf: float):
    res = {}
    for k, v in out.items():
        last = k.rsplit(".", 1)[-1]
        if last in LENGTH_KEYS or last == "length":
            res[k] = v / sl
        elif k == "driver.force":
            res[k] = v / sf
        elif k == "driver.torque":
            res[k] = v / (sf * sl)
        elif k == "ma":
            res[k] = v / sl ** _ma_length_power(scene)
        else:
            res[k] = v
    dr = scene.get("analysis", {}).get("driver")
    if _driver_factor(scene) and dr["kind"] == "displacement":
        factor = factor / sl
    return res, factor


def _ma_length_power(scene: dict) -> int:
    """Power of length in ``ma`` = d(input)/d(output): +1 for a length input (a displacement
    driver, a load's travel), -1 for a length output (direction x or y)."""
    an = scene["analysis"]
    ma = an["ma"]
    dr = an.get("driver")
    length_in = ma.get("input", "driver") != "driver" or dr["kind"] == "displacement"
    return int(length_in) - int(ma["direction"] in _AXES)


def rename_reverse(scene: dict) -> dict:
    """Nodes renamed (n_<i>) and listed in reverse, members renamed and reversed (ends
    swapped), tables listed in reverse order; outputs keep their names."""
    sc = copy.deepcopy(scene)
    ren = {n["id"]: f"q{i}_{n['id'].lower()}" for i, n in enumerate(sc["nodes"])}
    for n in sc["nodes"]:
        n["id"] = ren[n["id"]]
    sc["nodes"] = sc["nodes"][::-1]
    held = {t.get("member_a") for t in sc.get("torsion_springs", []) if "rest_angle_deg" in t}
    held |= {t.get("member_b") for t in sc.get("torsion_springs", []) if "rest_angle_deg" in t}
    syn = sc.get("analysis", {}).get("synthesis", {})
    if syn.get("goal") == "stable-position":  # the sized link's end-b node moves: a direction
        held |= set(syn["members"])
    reversed_ = set()
    for m in sc.get("members", []):
        m["from"], m["to"] = ren[m["from"]], ren[m["to"]]
        if m["id"] in held or m.get("model"):
            continue  # an absolute rest angle or a per-member PRB layout depends on direction
        m["from"], m["to"] = m["to"], m["from"]
        ea, eb = m.pop("end_a", "weld"), m.pop("end_b", "weld")
        m["end_a"], m["end_b"] = eb, ea
        if "sweep_deg" in m:
            m["sweep_deg"] = -m["sweep_deg"]
        reversed_.add(m["id"])
    sc["members"] = sc.get("members", [])[::-1]
    for key in ("supports", "loads", "outputs"):
        for t in sc.get(key, []):
            if "node" in t:
                t["node"] = ren[t["node"]]
        if key in sc:
            sc[key] = sc[key][::-1]
    for ld in sc.get("loads", []):
        if "member" in ld and ld["member"] in reversed_:
            ld["fraction"] = 1.0 - ld.get("fraction", 0.5)
    for t in sc.get("torsion_springs", []):
        t["node"] = ren[t["node"]]
    for b in sc.get("booms", []):
        b["from"], b["to"] = ren[b["from"]], ren[b["to"]]
    dr = sc.get("analysis", {}).get("driver")
    if dr and "node" in dr:
        dr["node"] = ren[dr["node"]]
    return sc


def encodings(scene: dict):
    """[(name, encoded scene, back(outputs, factor) -> (outputs, factor))] for every
    encoding that applies to the scene."""
    out = []
    try:  # 37 deg unless a driver, ma or synthesis target is bound to an axis: then 90 deg
        th = 37.0
        rigid_motion(scene, th, False)
    except ValueError:
        th = 90.0
    for name, ang, mir, sh in (
        (f"rot{th:g}", th, False, (0.0, 0.0)),
        ("mirror+shift", 0.0, True, (3.7, -1.9)),
    ):
        L = _extent(scene)
        shift = (sh[0] * L, sh[1] * L)
        try:
            enc = rigid_motion(scene, ang, mir, shift)
        except ValueError:
            continue
        out.append(
            (name, enc, lambda o, f, a=ang, m=mir, s=shift: back_rigid(o, f, scene, a, m, s))
        )
    u = scene["case"]["units"]
    if u == "m-N-Pa":
        conv = [("mm-N-MPa", 1e3, 1.0), ("in-lbf-psi", 1 / 0.0254, 1 / 4.4482216152605)]
    elif u == "mm-N-MPa":
        conv = [("m-N-Pa", 1e-3, 1.0)]
    else:
        conv = [("nondim", 1e3, 1.0), ("nondim", 1e-2, 1e3)]
    for un, sl, sf in conv:
        try:
            enc = scale_units(scene, sl, sf, un)
        except ValueError:
            continue
        out.append(
            (
                f"units:{un}*L{sl:g}*F{sf:.4g}",
                enc,
                lambda o, f, a=sl, b=sf: back_units(o, f, scene, a, b),
            )
        )
    out.append(("renamed+reversed", rename_reverse(scene), lambda o, f: (dict(o), f)))
    return out


def _extent(scene):
    xs = [n["x"] for n in scene["nodes"]] + [n["y"] for n in scene["nodes"]]
    return max(1e-12, max(xs) - min(xs))


# ----------------------------------------------------------------------------- elastica truth


def _shoot(m0, F, L, EI, EA, th0, follower_angle, tipM=0.0, thL=None):
    """Integrate the extensible elastica from the clamp; returns the end state."""
    if follower_angle is not None:
        ang = thL + follower_angle
        Fx, Fy = F * math.cos(ang), F * math.sin(ang)
    else:
        Fx, Fy = F

    def rhs(s, z):
        x, y, th, m = z
        eps = (Fx * math.cos(th) + Fy * math.sin(th)) / EA
        return [
            (1 + eps) * math.cos(th),
            (1 + eps) * math.sin(th),
            m / EI,
            (1 + eps) * (Fx * math.sin(th) - Fy * math.cos(th)),
        ]

    sol = solve_ivp(rhs, (0, L), [0.0, 0.0, th0, m0], rtol=1e-10, atol=1e-12, method="DOP853")
    return sol.y[:, -1]


def elastica_path(factors, L, EI, EA, th0, F1, follower=False, substeps=20, guess=None):
    """Natural path of a clamped (at th0) cantilever under a tip force F1 (fx, fy at factor 1),
    dead or follower (the force keeps its angle to the tip tangent); continuation from the
    unloaded state in small load steps.  Returns a list of (x_tip, y_tip, theta_tip)."""
    fang = None
    if follower:
        fang = math.atan2(F1[1], F1[0]) - th0
        Fmag = math.hypot(*F1)
    res = []
    lam_prev = 0.0
    z = np.array([0.0, th0]) if follower else np.array([0.0])
    if guess is not None:
        z[0] = guess
    for lam in factors:
        for k in range(1, substeps + 1):
            lm = lam_prev + (lam - lam_prev) * k / substeps
            if follower:

                def g(v, lm=lm):
                    e = _shoot(v[0], lm * Fmag, L, EI, EA, th0, fang, thL=v[1])
                    return [e[3], e[2] - v[1]]
            else:

                def g(v, lm=lm):
                    e = _shoot(v[0], (lm * F1[0], lm * F1[1]), L, EI, EA, th0, None)
                    return [e[3]]

            z, info, ier, msg = fsolve(g, z, full_output=True, xtol=1e-13)
            if ier != 1 and max(abs(np.asarray(info["fvec"]))) > 1e-9:
                raise RuntimeError(f"truth shooting failed at factor {lm}: {msg}")
        lam_prev = lam
        if follower:
            e = _shoot(z[0], lam * Fmag, L, EI, EA, th0, fang, thL=z[1])
        else:
            e = _shoot(z[0], (lam * F1[0], lam * F1[1]), L, EI, EA, th0, None)
        res.append((e[0], e[1], e[2]))
    return res


def natural_path(factors, L, EI, EA, th0, F1, ds=0.003):
    """Natural path of a cantilever under a dead tip force F1 * factor, traced by
    pseudo-arclength in (base moment / |F1| L, factor) -- no jump across a fold of the
    complementary branches -- then each requested factor solved by Newton in the base moment
    from the interpolated path.  Returns [(x_tip, y_tip, theta_tip)]."""
    ms = math.hypot(*F1) * L

    def res(m0, lam):
        return _shoot(m0 * ms, (lam * F1[0], lam * F1[1]), L, EI, EA, th0, None)[3] / ms

    z, t = np.array([0.0, 0.0]), np.array([0.0, 1.0])
    pts = [z]
    while z[1] < max(factors) + ds:
        zp = z + ds * t

        def g(v, zp=zp, t=t):
            return [res(*v), float(t @ (np.asarray(v) - zp))]

        zn = fsolve(g, zp, xtol=1e-12)
        t = (zn - z) / np.linalg.norm(zn - z)
        z = zn
        pts.append(z)
        if z[1] < pts[-2][1]:
            raise RuntimeError("natural path folds: a limit point, not an imperfect column")
    pts = np.array(pts)
    out = []
    for lam in factors:
        m0 = np.interp(lam, pts[:, 1], pts[:, 0])
        m0 = fsolve(lambda v, lam=lam: [res(v[0], lam)], [m0], xtol=1e-13)[0]
        e = _shoot(m0 * ms, (lam * F1[0], lam * F1[1]), L, EI, EA, th0, None)
        out.append((e[0], e[1], e[2]))
    return out


def buckled_column(P, L, EI, EA):
    """Tip of a perfect cantilever column (clamp at the origin pointing +y, axial load -P)
    on its buckled branch leaning to -x (theta rises above pi/2), from the inextensible
    closed form as the shooting guess."""
    from scipy.optimize import brentq
    from scipy.special import ellipk

    k = brentq(lambda k: ellipk(k * k) * math.sqrt(EI / P) / L - 1.0, 1e-12, 1 - 1e-15)
    m0 = 2 * k * math.sqrt(P * EI)  # base moment, inextensible
    th0 = math.pi / 2

    def g(v):
        return [_shoot(v[0], (0.0, -P), L, EI, EA, th0, None)[3]]

    z = fsolve(g, [m0], xtol=1e-13)
    e = _shoot(z[0], (0.0, -P), L, EI, EA, th0, None)
    return e[0], e[1], e[2]
