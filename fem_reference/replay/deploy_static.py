"""``replay`` on a deploy scene started at the deployed state (option ``deploy_start =
"static"``): the FE deploy equilibrium (``statics.deploy.FEDeploy``, same mesh) is taken as
the settled state with the boom locked, checked settled by the replay's own test, and probed
-- the modal kick and the thesis's 1 N impulse on J4 (``deploy._ProbeBoth``).  The thesis
perturbed its ADAMS models "at equilibrium" (seed 001, Chapter 5); this gives a sweep's
perturbation verdicts without replaying each deployment (~1/10 of the cost).  One boom only
(the FE deploy drives one); no time history.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from cases.schema import Scene
from fem_reference.assembly import build
from fem_reference.replay import integrator as ev
from fem_reference.replay.run import _Run
from fem_reference.statics.deploy import DeployError, FEDeploy, booms_as_locks
from reduced_models.base import Solution, Step


def deployed_state(d: FEDeploy, scene: Scene) -> np.ndarray:
    """FE equilibrium with the boom locked at its length (the path of ``solve_deploy``)."""
    q, mu = np.zeros(d.sys.ndof), 0.0
    ell0, Lend = d.ell(q), scene.booms[0].length
    q, mu, _ = d.newton(q, mu, d.F, ell0)
    n = scene.analysis.steps
    for k in range(1, n + 1):
        a, b = ell0 + (k - 1) / n * (Lend - ell0), ell0 + k / n * (Lend - ell0)
        q, mu, _ = d.follow(q, mu, a, b)
        if mu <= 0.0:
            raise DeployError(f"the boom stalls before {Lend:g} (push balanced at ~{b:.6g})")
    return d.newton(q, mu - d.F, 0.0, Lend)[0]


def replay_static(scene: Scene, model: object, probes: object) -> Solution:
    """Probe the deployed state; ``probes`` is the deploy's ``_ProbeBoth`` hook."""
    name = "replay"
    if len(scene.booms) != 1:
        why = "deploy_start = 'static' drives one boom"
        return Solution(scene.name, name, "not-applicable", why)
    opts = replace(model.options, locks=booms_as_locks(scene), probe="last")
    system = build(scene, model.n_elements)
    try:
        q = deployed_state(FEDeploy(system, scene), scene)
    except (DeployError, np.linalg.LinAlgError) as err:
        return Solution(scene.name, name, "failed", f"static start: {err}")
    run = _Run(system, scene, opts)
    for p in run.integ.pairs:
        p.locked = True
    run.s = run.integ.start(0.0, 0.0, q, np.zeros_like(q))
    try:
        # the FE state is converged to its stiff links' round-off floor, which may be above
        # the replay's settling test: a short hold settles it
        s, chk = run.hold(0.0)
        q = s.q
        eig, pr = probes(run, s, chk, "probe", scene)
    except (ev.ReplayError, RuntimeError, ValueError, np.linalg.LinAlgError) as exc:
        return Solution(scene.name, name, "failed", f"static start: {exc}")
    st = system.step(q, 0.0, 0, pr["stable"])
    out = {**st.outputs, f"{scene.booms[0].id}.length": run.integ.pairs[0].geometry(q)[0]}
    info = {"residual": chk["residual"], "distance": chk["distance"], "lowest_eigenvalue": eig}
    info |= {"probe_peak": pr.get("peak", float("nan"))}
    step = Step(2.0, out, st.energy, 0, pr["stable"], st.shapes, None, info)
    extras = {"probes": [pr], "boom_reached": True, "deploy_start": "static"}
    if probes.impulse is not None:
        extras["impulse_probe"] = probes.impulse
    msg = f"started at the FE deploy equilibrium (boom locked); probe: {pr['verdict']}"
    return Solution(scene.name, name, "converged", msg, (step,), extras)
