"""The FE reference models ``fem-N`` and ``fem-auto`` and their registry.

``fem-N`` discretises every flexible member with N corotational elements (``assembly.build``)
and runs the scene's analysis with the solvers of ``static.py``:

* ``load``: the factors ``load_factors(scene)`` are reached exactly by load control with step
  cutting; if load control stalls (a limit point), arc-length continues along the path until
  the factor is crossed again and Newton lands on it (``Step.info['snap'] = 1``).
* ``path``: arc-length from factor 0; every converged step is reported until ``stop_output``
  reaches ``stop_value`` (landed exactly by displacement control) or the factor reaches
  ``factor_end``; limit points (load maxima/minima) are refined and inserted as steps
  (``info['limit_point'] = +1 max / -1 min``) and listed in ``extras['limit_points']``.
* ``distance``: displacement control on the driver coordinate; ``Step.factor`` = load factor.
* ``energy``: the driver is displacement-controlled with a unit driving force/torque; the scene
  loads stay at ``factor_end``; outputs ``driver.force`` / ``driver.torque`` = the reaction;
  ``Step.factor`` = driver coordinate.

``fem-auto`` runs a mesh sequence and Richardson-extrapolates (``richardson.py``).
"""

from __future__ import annotations

import numpy as np

from cases.schema import Scene
from fem_reference.assembly import FEMSystem, build, representable
from fem_reference.statics import static as S
from fem_reference.statics.bifurcation import Watch, is_conservative
from fem_reference.statics.driver_post import post_process
from fem_reference.statics.inertia import state_stability
from fem_reference.statics.integrity import violation
from reduced_models.base import ModelCard, Solution, Step, load_factors, not_applicable

MODELS: dict[str, str] = {
    "fem-N": "fem_reference.models:FEM",
    "fem-auto": "fem_reference.auto:FEMAuto",
    "replay": "fem_reference.replay.model:Replay",
}
DEFAULT_NAMES: tuple[str, ...] = ("fem-auto", "replay")

_REFS = (
    "Crisfield, Non-linear Finite Element Analysis of Solids and Structures, Vol. 1, Wiley 1991,"
    " Ch. 7 (corotational beam) and Ch. 9 (arc-length)",
    "Battini & Pacoste, CMAME 191:1755-1789 (2002), doi 10.1016/S0045-7825(01)00352-8",
    "Roache, Verification and Validation in Computational Science and Engineering, 1998 (RE)",
)
# declared options (checked by ``reduced_models.registry.build``): (kind, lo, hi, choices, doc)
FEM_OPTIONS: dict[str, tuple] = {
    "rtol": ("float", 1e-14, 1e-4, (), "Newton force tolerance / force scale"),
    "max_iter": ("int", 2, 1000, (), "Newton iterations per solve"),
    "arc_length": ("float", 1e-12, 1e3, (), "initial arc length (W-norm)"),
    "arc_length_max": ("float", 1e-12, 1e3, (), "largest arc length"),
    "stability": ("bool", None, None, (), "tangent stability test per step"),
    "rigid_factor": ("float", 1e2, 1e12, (), "stiff rigid links: stiffness / member stiffness"),
    "rigid_links": ("str", None, None, ("exact", "stiff"), "exact constraints or stiff elements"),
    "dense_max": ("int", 1, 100_000, (), "largest dense eigenproblem"),
    "limit_points": ("bool", None, None, (), "refine limit points of paths"),
    "bifurcation": ("bool", None, None, (), "detect bifurcations and switch branch"),
}
_OPTION_KEYS = tuple(FEM_OPTIONS)


def _local(st: S.State) -> object | None:
    """Element state of ``st`` from the solver's own last evaluation there (bit-identical to
    recomputing it), or None."""
    ev = st.ev
    return ev.st if ev is not None and ev.u is st.u and ev.lam == st.lam else None


def _rec(
    system: FEMSystem,
    st: S.State,
    factor: float,
    stab: dict | None,
    extra_out: dict | None = None,
    info: dict | None = None,
) -> Step:
    inf = {
        "iterations": float(st.iterations),
        "cuts": float(st.cuts),
        "residual": float(st.residual),
        "load_factor": float(st.lam),
    }
    if stab is not None:  # min_pivot (stable) or min_eig (not positive definite)
        inf.update({k: float(stab[k]) for k in ("min_pivot", "min_eig") if k in stab})
        inf["n_neg"] = float(stab["n_neg"])
    inf.update(st.info or {})
    inf.update(info or {})
    stable = None if stab is None else stab["stable"]
    return system.step(st.u, factor, st.iterations, stable, _local(st), extra_out, inf)


class Runner:
    """Runs one analysis of ``scene`` on one discretisation (see module docstring)."""

    def __init__(self, scene: Scene, n: int, options: dict):
        self.scene, self.n = scene, n
        o = {k: v for k, v in options.items() if k in _OPTION_KEYS}
        self.opts = S.Options(rtol=float(o.get("rtol", 1e-9)), max_iter=int(o.get("max_iter", 25)))
        self.o = o
        a = scene.analysis
        self.system = build(
            scene,
            n,
            rigid_factor=float(o.get("rigid_factor", 1e6)),
            driver_load=a.kind == "energy",
            exact_rigid=o.get("rigid_links", "exact") == "exact",
        )
        if a.kind == "energy":
            self.system.const_factor = a.factor_end
        self.steps: list[Step] = []
        self.states: list[S.State] = []
        self.extras: dict = {"n_elements": n, "ndof": self.system.ndof}
        self.notes: list[str] = []  # said in the message of a converged run
        self.watch: Watch | None = None  # the stability watch of a load run

    # -- helpers ---------------------------------------------------------------------------
    def stab(self, st: S.State, exclude: int | None = None) -> dict | None:
        # follower loads: the tangent is unsymmetric and its symmetric part says nothing
        # about stability (flutter needs a dynamic test): no verdict
        if not self.o.get("stability", True) or not is_conservative(self.system):
            return None
        if exclude is None and self.watch is not None:
            return self.watch.stability(st)  # computed once for the watch and the report
        return state_stability(self.system, st, int(self.o.get("dense_max", 60)), exclude)

    def initial(self, constraint: tuple | None = None) -> S.State:
        """Equilibrium at factor 0 (preloaded springs, constant loads); ramps the preload and
        the constant loads when a direct Newton solve fails."""
        sysm, opts = self.system, self.opts
        u0 = np.zeros(sysm.ndof)
        try:
            return S.newton(sysm, u0, 0.0, opts, constraint)
        except S.SolveError:
            pass
        pre, cf = sysm.preload, sysm.const_factor
        s, h, u, lam, its = 0.0, 0.25, u0, 0.0, 0
        try:
            while s < 1.0:
                s1 = min(1.0, s + h)
                sysm.preload, sysm.const_factor = s1 * pre, s1 * cf
                try:
                    st = S.newton(sysm, u, lam, opts, constraint)
                except S.SolveError as err:
                    h /= 4.0
                    if h < 1e-6:
                        raise S.SolveError(f"initial equilibrium (preload ramp): {err}") from None
                    continue
                s, u, lam, its = s1, st.u, st.lam, its + st.iterations
                h = min(1.5 * h, 1.0)
        finally:
            sysm.preload, sysm.const_factor = pre, cf
        return S.State(u, lam, its, 0, st.residual)

    def ds0(self, st: S.State) -> float:
        a, sysm = self.scene.analysis, self.system
        if "arc_length" in self.o:
            return float(self.o["arc_length"])
        t = S.tangent_lu(sysm, st.u, st.lam).solve(sysm.external(st.u))
        sc = S.Scaler.of(sysm)
        cand = [sc.unorm(t) * abs(a.factor_end) / max(a.steps, 1), 0.05]
        if a.stop_output:  # the stop output should be reached in about ``steps`` steps
            i, c, off = sysm.output_functional(a.stop_output)
            if i >= 0:
                dv = abs(a.stop_value - off - c * st.u[i]) / abs(c)
                ti = abs(c * t[i])  # stop output per unit factor along the initial tangent
                if ti > 0:
                    cand.append(dv / max(a.steps, 1) * sc.unorm(t) / ti)
        # two significant digits: K^-1 f carries the tangent's round-off (a stiff arch's:
        # 3e-8), which moved every later sample of the path with the scene's encoding
        return float(f"{min(cand):.2g}")

    # -- analyses --------------------------------------------------------------------------
    def run(self) -> tuple[str, str]:
        kind = self.scene.analysis.kind
        try:
            if kind == "load":
                self.run_load()
            elif kind == "path":
                return self.run_path()
            elif kind in ("distance", "energy"):
                self.run_driver(kind)
            else:
                return "not-applicable", f"analysis kind {kind!r} is not solved by fem"
        except S.SolveError as err:
            if kind in ("distance", "energy") and self.system.con_dofs.shape[0]:
                return "failed", (
                    f"{err}; the rigid links (exact constraints) admit no equilibrium beyond "
                    "this driver value: a driver beyond the mechanism's reach, or the links lock"
                )
            return "failed", str(err)
        except (np.linalg.LinAlgError, FloatingPointError, ValueError) as err:
            return "failed", f"{type(err).__name__}: {err}"
        return "converged", "; ".join(self.notes)

    def _push(
        self,
        st: S.State,
        factor: float,
        extra_out: dict | None = None,
        exclude: int | None = None,
        info: dict | None = None,
    ) -> None:
        # rigid links stretched, strains beyond the model
        why = violation(self.system, st.u, _local(st))
        if why:
            raise S.SolveError(f"at factor {st.lam:.6g}: {why}")
        self.states.append(st)
        self.steps.append(_rec(self.system, st, factor, self.stab(st, exclude), extra_out, info))
        st.ev = None  # recorded and judged: a kept path need not hold every element state

    def run_load(self) -> None:
        st = self.initial()
        watch = Watch(self.system, self.opts) if self.o.get("bifurcation", True) else None
        if watch is not None:
            watch.dense_max = int(self.o.get("dense_max", 60))
        self.watch = watch  # before the first record: its verdict is the watch's first
        self._push(st, 0.0)
        f = load_factors(self.scene)
        for prev, fk in zip(f[:-1], f[1:]):
            new = S.reach_factor(self.system, st, float(fk), float(fk - prev), self.opts)
            if watch:
                new = watch.snap(st, new)
            st = watch.check(st, new, float(fk)) if watch else new
            self._push(st, float(fk))
        if watch:
            self.extras["critical_points"] = watch.points
            left = {p["factor"] for p in watch.points if p["kind"] == "bifurcation"}
            self.notes += [
                f"snap at factor {p['factor']:.8g}: "
                f"{'a subcritical bifurcation' if p['factor'] in left else 'a limit point'} "
                "passed, the path jumps to another branch (critical_points: from, to)"
                for p in watch.points
                if p["kind"] == "snap"
            ]
            if not watch.note and watch.active and not watch.stable(st):
                watch.note = f"the path ends on an unstable equilibrium (factor {st.lam:.6g})"
            if watch.note:  # the runner does not score models against such a path
                self.notes.append(watch.note)
                self.extras["reference_usable"] = False

    def run_driver(self, kind: str) -> None:
        a, sysm = self.scene.analysis, self.system
        i, c, off = sysm.driver_functional()
        if i < 0:
            raise S.SolveError("the driver coordinate is fixed by a support")
        vals = np.linspace(a.driver.start, a.driver.stop, a.steps + 1)
        st = self.initial(constraint=(i, c, vals[0] - off))
        key = "driver.torque" if a.driver.kind == "rotation" else "driver.force"
        for k, v in enumerate(vals):
            if k:
                st = S.displacement_control(
                    sysm, st, (i, c, off), float(v), float(abs(v - vals[k - 1])), self.opts
                )
            extra = {key: float(st.lam)} if kind == "energy" else {}
            factor = float(v) if kind == "energy" else float(st.lam)
            self._push(st, factor, extra, exclude=i if kind == "energy" else None)

    def run_path(self) -> tuple[str, str]:
        a, sysm, opts = self.scene.analysis, self.system, self.opts
        st = self.initial()
        self._push(st, st.lam)
        ds = self.ds0(st)
        ds_max = float(self.o.get("arc_length_max", 2.0 * ds))
        sgn = 1.0 if a.factor_end >= 0 else -1.0
        arc = S.ArcLength(sysm, st, ds, opts, direction=sgn, ds_max=ds_max)
        func = sysm.output_functional(a.stop_output) if a.stop_output else None
        watch = Watch(sysm, opts) if self.o.get("bifurcation", True) else None

        def val(s: S.State) -> float:
            return func[2] + func[1] * s.u[func[0]] if func[0] >= 0 else func[2]

        if watch is not None and func is not None:
            watch.stop = (val, a.stop_value)

        status, message = "failed", f"stop criterion not reached within {a.max_steps} steps"
        for _ in range(a.max_steps):
            prev = st
            try:
                st = arc.step()
                if watch is not None and sgn * (st.lam - prev.lam) > 0:  # not at a fold
                    new = watch.check(prev, st, st.lam, path=True)
                    if new is not st:  # switched at a bifurcation: trace the new branch on
                        # with steps sized on it (the fundamental path's were sized on a
                        # column's axial shortening: 1e-4 rad of tip rotation per step)
                        st = new
                        ds = max(arc.ds, self.ds0(st))
                        ds_max = max(ds_max, 2.0 * ds)
                        arc = S.ArcLength(sysm, st, ds, opts, direction=sgn, ds_max=ds_max)
            except S.SolveError as err:
                status, message = "failed", str(err)
                break
            if func is not None and (val(prev) - a.stop_value) * (val(st) - a.stop_value) <= 0:
                st = S.displacement_control(
                    sysm, prev, func, a.stop_value, abs(a.stop_value - val(prev)), opts
                )
                self._push(st, st.lam)
                status, message = "converged", ""
                break
            if (prev.lam - a.factor_end) * (st.lam - a.factor_end) <= 0 and st.lam != prev.lam:
                w = (a.factor_end - prev.lam) / (st.lam - prev.lam)
                st = S.newton(sysm, prev.u + w * (st.u - prev.u), a.factor_end, opts)
                self._push(st, st.lam)
                status, message = "converged", ""
                break
            self._push(st, st.lam)
        if watch is not None:
            self.extras["critical_points"] = watch.points
            if watch.note and status == "converged":
                message = watch.note
        if self.o.get("limit_points", True):
            self.limit_points()
        last = self.steps[-1] if self.steps else None
        if status == "converged" and last is not None and last.stable is False and not message:
            message = "the path ends on an unstable equilibrium (traced, not settled there)"
        return status, message

    def limit_points(self) -> None:
        lam = np.array([s.lam for s in self.states])
        found = []
        for k in range(1, len(lam) - 1):
            d1, d2 = lam[k] - lam[k - 1], lam[k + 1] - lam[k]
            if d1 * d2 < 0:
                try:
                    lp = S.refine_extremum(self.system, *self.states[k - 1 : k + 2], self.opts)
                except S.SolveError:
                    continue
                found.append((k, lp))
        self.extras["limit_points"] = []
        for k, lp in reversed(found):
            i = int(lp.info["control_dof"])
            after = (lp.u[i] - self.states[k].u[i]) * (
                self.states[k + 1].u[i] - self.states[k].u[i]
            ) > 0
            pos = k + 1 if after else k
            self.states.insert(pos, lp)
            stab = self.stab(lp)
            if stab is not None:  # the fold itself: a stable and an unstable branch meet
                # there and the potential is cubic along its mode (Koiter), so the state is
                # unstable, whichever sign round-off gives its zero eigenvalue (the same
                # arch in other units said stable at 8.97684, the drawn one unstable)
                stab = {**stab, "stable": False}
            self.steps.insert(pos, _rec(self.system, lp, lp.lam, stab))
        for _, lp in found:
            self.extras["limit_points"].append(
                {
                    "factor": float(lp.lam),
                    "kind": "max" if lp.info["limit_point"] > 0 else "min",
                    "outputs": self.system.outputs(lp.u),
                }
            )


def _solution(scene: Scene, name: str, r: Runner, status: str, message: str) -> Solution:
    return Solution(
        case=scene.name,
        model=name,
        status=status,
        message=message,
        steps=tuple(r.steps),
        extras=r.extras,
    )


class FEM:
    """``fem-N``: the corotational reference on N elements per flexible member."""

    card = ModelCard(
        name="fem-N",
        family="fem",
        summary="2-D corotational Euler-Bernoulli beam FE (scikit-fem meshes), N elements per "
        "flexible member; Newton, step cutting, arc-length through limit points",
        assumptions=(
            "Euler-Bernoulli beams: no shear deformation; linear elastic local law",
            "small strains, arbitrarily large rotations (corotational)",
            "rigid links = exact constraints (rigid bodies, Lagrange multipliers; option "
            "rigid_links = 'stiff': one stiff element, relative compliance ~1e-6, stretch "
            "checked <= 1e-4 at every state)",
            "stability from the inertia of the symmetric tangent (banded Cholesky of its "
            "Jacobi-scaled band; negative eigenvalues counted where it is indefinite; "
            "conservative loads only; under follower loads the verdict is None)",
        ),
        validity="any planar scene of the case format; discretisation error O(h^2) in "
        "displacements (use fem-auto for an error estimate)",
        references=_REFS,
    )

    OPTIONS = FEM_OPTIONS

    def __init__(self, n: int | dict[str, int] = 32, **options: object):
        # a dict gives each flexible member its own count (``fem-auto``'s per-member meshes)
        self.n = {k: int(v) for k, v in n.items()} if isinstance(n, dict) else int(n)
        self.name = f"fem-{max(self.n.values(), default=1) if isinstance(n, dict) else self.n}"
        self.options = dict(options)

    def applies_to(self, scene: Scene) -> str | None:
        """None, or why the FE reference cannot represent ``scene``."""
        if scene.analysis.kind == "sweep":
            return "sweep analyses are expanded into single scenes by the runner"
        return representable(scene, check_only=True, exact_rigid=True)

    def runner(self, scene: Scene) -> tuple[Runner, str, str]:
        """Run and return the runner (states kept) with status and message."""
        r = Runner(scene, self.n, self.options)
        status, message = r.run()
        if (
            status == "failed"
            and "singular" in message
            and r.system.con_dofs.shape[0]
            and "rigid_links" not in self.options
        ):  # redundant link constraints (over-constrained links): stiff links carry them
            r = Runner(scene, self.n, {**self.options, "rigid_links": "stiff"})
            status, message = r.run()
            note = (
                "exact rigid-link constraints singular (over-constrained links?): solved with "
                "stiff links (compliance ~1e-6)"
            )
            message = f"{note}; {message}" if message else note
            r.extras["rigid_links"] = "stiff"
        ignored = sorted(set(self.options) - set(_OPTION_KEYS) - {"sequence"})
        if ignored:
            r.extras["ignored_options"] = ignored
        return r, status, message

    def solve(self, scene: Scene) -> Solution:
        """Equilibrium path of ``scene`` (never raises for a numerical failure)."""
        reason = self.applies_to(scene)
        if reason:
            return not_applicable(scene, self.name, reason)
        if scene.analysis.kind == "deploy":
            from fem_reference.statics.deploy_staged import solve_any as solve_deploy

            return solve_deploy(scene, self.name, self.n)
        r, status, message = self.runner(scene)
        return post_process(scene, _solution(scene, self.name, r, status, message))


__all__ = ["DEFAULT_NAMES", "FEM", "MODELS", "Runner"]
