"""The two codes of ``reports.bench.fem`` on one problem: the benchmark scenes (a slender
cantilever, ``flexure_scene``; catalog cases), a FlexBench ``fem-N`` run and an OpenSeesPy
corotational ``elasticBeamColumn`` run, each prepared outside the clock and timed when
called (see ``fem.py`` for the protocol)."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from cases.schema import Analysis, Load, Member, Node, Output, Scene, Support

# -- scenes -------------------------------------------------------------------------------------


def flexure_scene(load: float = 10.0, slenderness: float = 100.0) -> Scene:
    """Cantilever L = 1, EI = 1, EA L^2/EI = 12 (L/t)^2 (a steel flexure with L/t = 100 gives
    1.2e5), dead tip force P L^2/EI = ``load`` downwards (dimensionless units)."""
    ea = 12.0 * slenderness**2
    return Scene(
        name="bench-flexure",
        title=f"Cantilever PL^2/EI = {load:g}, EA L^2/EI = {ea:.3g}",
        units="nondim",
        nodes=(Node("A", 0.0, 0.0), Node("B", 1.0, 0.0)),
        members=(Member("beam", "A", "B", "flexible", E=1.0, I=1.0, A=ea),),
        supports=(Support("A", "clamp"),),
        loads=(Load("P", fy=-float(load), node="B"),),
        analysis=Analysis(kind="load", steps=20),
        outputs=(Output("tip", "B"),),
    )


def bench_scene(case: str, steps: int) -> Scene:
    """``flexure`` or a catalog case name, with ``steps`` equal load steps and no references."""
    if case == "flexure":
        scene = flexure_scene()
    else:
        import cases

        scene = cases.load(case)
    a = dataclasses.replace(scene.analysis, kind="load", steps=int(steps), factor_end=1.0)
    return dataclasses.replace(scene, analysis=a, references=(), models=())


def scale_loads(scene: Scene, factor: float) -> Scene:
    """The scene with every load multiplied by ``factor``."""
    loads = tuple(
        dataclasses.replace(ld, fx=ld.fx * factor, fy=ld.fy * factor, moment=ld.moment * factor)
        for ld in scene.loads
    )
    return dataclasses.replace(scene, loads=loads)


@dataclass(frozen=True)
class Cantilever:
    """The data OpenSees needs: one straight member clamped at ``a``, a dead load at ``b``."""

    x0: float
    y0: float
    x1: float
    y1: float
    E: float
    I: float
    A: float
    fx: float
    fy: float
    moment: float
    tip: str

    @property
    def length(self) -> float:
        """Member length (length units)."""
        return math.hypot(self.x1 - self.x0, self.y1 - self.y0)

    @property
    def load_scale(self) -> float:
        """|P| L^2 / EI of the full load (dimensionless)."""
        return math.hypot(self.fx, self.fy) * self.length**2 / (self.E * self.I)


def cantilever_of(scene: Scene) -> Cantilever:
    """Extract a single-member cantilever with dead tip loads (ValueError otherwise)."""
    if len(scene.members) != 1 or scene.members[0].kind != "flexible":
        raise ValueError(f"{scene.name}: the benchmark needs exactly one flexible member")
    m = scene.members[0]
    sup = scene.support_at(m.a)
    if sup is None or sup.type != "clamp" or len(scene.supports) != 1:
        raise ValueError(f"{scene.name}: the benchmark needs one clamp at the member's first node")
    if any(ld.node != m.b or ld.follower for ld in scene.loads):
        raise ValueError(f"{scene.name}: the benchmark needs dead loads at the free end only")
    I = m.I if m.I is not None else m.width * m.thickness**3 / 12.0
    A = m.A if m.A is not None else m.width * m.thickness
    a, b = scene.node(m.a), scene.node(m.b)
    tip = next((o.name for o in scene.outputs if o.node == m.b), None)
    if tip is None:
        raise ValueError(f"{scene.name}: no output at the free end")
    f = [sum(getattr(ld, q) for ld in scene.loads) for q in ("fx", "fy", "moment")]
    return Cantilever(a.x, a.y, b.x, b.y, float(m.E), float(I), float(A), *f, tip)


# -- one run of each code -----------------------------------------------------------------------


@dataclass
class Run:
    """Outcome of one timed run."""

    status: str  # converged | failed
    iterations: int
    wall_s: float
    cpu_s: float
    tip: tuple[float, float, float] | None  # (ux, uy, rot) at the full load
    message: str = ""


def _clock(fn: Callable[[], tuple[str, int, tuple | None, str]]) -> Run:
    w0, c0 = time.perf_counter(), time.process_time()
    status, its, tip, msg = fn()
    return Run(status, its, time.perf_counter() - w0, time.process_time() - c0, tip, msg)


def _fb_result(steps: list, status: str, message: str, key: str) -> tuple:
    its = int(sum(s.iterations for s in steps))
    last = steps[-1] if steps else None
    if status != "converged" or last is None or abs(last.factor - 1.0) > 1e-12:
        return "failed", its, None, message or "did not reach the full load"
    o = last.outputs
    return "converged", its, (o[f"{key}.ux"], o[f"{key}.uy"], o[f"{key}.rot"]), ""


def flexbench_runner(scene: Scene, n: int, mode: str) -> Callable[[], Run]:
    """Prepare one FlexBench run; calling the result performs and times it."""
    key = cantilever_of(scene).tip
    if mode == "e2e":
        import reports

        def e2e() -> tuple:
            sol = reports.solve(scene, f"fem-{n}")
            return _fb_result(list(sol.steps), sol.status, sol.message, key)

        return lambda: _clock(e2e)
    from fem_reference.models import Runner

    def prepared() -> Run:
        runner = Runner(scene, n, {"stability": False})  # built outside the clock

        def solve() -> tuple:
            status, message = runner.run()
            return _fb_result(runner.steps, status, message, key)

        return _clock(solve)

    return prepared


@dataclass(frozen=True)
class OSConfig:
    """OpenSees analysis settings for one comparison."""

    algorithm: tuple = ("Newton",)
    steps: int = 20
    system: str = "BandGen"
    test: str = "EnergyIncr"
    rel_tol: float = 1e-16  # x |P| L (EnergyIncr) -- an absolute tolerance in OpenSees
    max_iter: int = 50

    def label(self) -> str:
        """Short description for the table."""
        return f"{self.algorithm[0]}/{self.steps} steps/{self.system}"


def _os_build(ops: Any, c: Cantilever, n: int, cfg: OSConfig) -> None:
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    xs = np.linspace(c.x0, c.x1, n + 1)
    ys = np.linspace(c.y0, c.y1, n + 1)
    for i in range(n + 1):
        ops.node(i + 1, float(xs[i]), float(ys[i]))
    ops.fix(1, 1, 1, 1)
    ops.geomTransf("Corotational", 1)
    for i in range(n):
        ops.element("elasticBeamColumn", i + 1, i + 1, i + 2, c.A, c.E, c.I, 1)
    ops.timeSeries("Linear", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(n + 1, c.fx, c.fy, c.moment)
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system(cfg.system)
    f = max(math.hypot(c.fx, c.fy) * c.length, abs(c.moment), 1e-300)
    ops.test(cfg.test, cfg.rel_tol * f, cfg.max_iter)
    ops.algorithm(*cfg.algorithm)
    ops.integrator("LoadControl", 1.0 / cfg.steps)
    ops.analysis("Static")


def _os_analyze(ops: Any, n: int, steps: int) -> tuple:
    its = 0
    for k in range(steps):
        ok = ops.analyze(1)
        its += int(ops.testIter())
        if ok != 0:
            return "failed", its, None, f"analyze returned {ok} in step {k + 1}/{steps}"
        tip = ops.nodeDisp(n + 1)
    return "converged", its, (tip[0], tip[1], tip[2]), ""


def opensees_runner(ops: Any, scene: Scene, n: int, cfg: OSConfig, mode: str) -> Callable:
    """Prepare one OpenSees run; calling the result performs and times it."""
    c = cantilever_of(scene)
    if mode == "e2e":

        def e2e() -> tuple:
            _os_build(ops, c, n, cfg)
            return _os_analyze(ops, n, cfg.steps)

        return lambda: _clock(e2e)

    def solve() -> tuple:
        return _os_analyze(ops, n, cfg.steps)

    def prepared() -> Run:
        _os_build(ops, c, n, cfg)  # outside the clock
        return _clock(solve)

    return prepared


def import_opensees() -> Any:
    """``openseespy.opensees``, or the exception that importing it raised."""
    try:
        import openseespy.opensees as ops
    except Exception as exc:  # noqa: BLE001 - ImportError or its RuntimeError on missing BLAS
        return exc
    return ops
