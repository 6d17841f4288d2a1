"""Mechanical advantage along the solution path (``[analysis.ma]``, output ``ma``).

From the power balance along the motion, F_in ds_in = dU + F_out ds_out (U elastic energy),

    ma = F_out / F_in = (1 - (dU/dt) / (F_in ds_in/dt)) / ((ds_out/dt) / (ds_in/dt)),

with t the path parameter (driver coordinate, or load factor for a load input) and every
derivative taken along the path tangent of the converged state (one KKT solve).  Without
stored energy (kinematics) this is the kinematic advantage ds_in/ds_out.  Where a rate is zero
(e.g. F_in = 0 at the unloaded state) the output is NaN.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from reduced_models.base import Step


def _out_index(run: object, name: str, direction: str) -> list[int]:
    """Unknowns whose mean is the output coordinate (a rot: ``cases.node_rotation``)."""
    s = run.s
    node = next(o.node for o in s.scene.outputs if o.name == name)
    if direction == "rot":
        return list(s.lay.node_rot[node])
    return [s.lay.node_dof[node] + (0 if direction == "x" else 1)]


def _nan_div(a: float, b: float) -> float:
    return float(a / b) if b != 0.0 and np.isfinite(b) else float("nan")


def add_ma(run: object) -> list[Step]:
    """Steps of ``run`` with output ``ma`` added (see module doc)."""
    s, solver, a = run.s, run.solver, run.scene.analysis
    spec = a.ma
    io = _out_index(run, spec.output, spec.direction)
    f = s.free
    pos = {int(i): k for k, i in enumerate(f)}
    out = []
    for step, st in zip(run.steps, run.states):
        ma = float("nan")
        if a.kind == "kinematics":
            c, J = s.cons(st.q)
            rhs = np.zeros(len(c))
            rhs[solver.driver_index()] = 1.0
            dq = np.zeros(s.n)
            dq[f] = np.linalg.lstsq(J[:, f], rhs, rcond=None)[0]
            ma = _nan_div(1.0, dq[io].mean())
        elif spec.input == "driver" and s.driver_row is not None:
            lam_free = a.kind == "distance"
            dx = solver.tangent(st, "driver", lam_free)
            dq = np.zeros(s.n)
            dq[f] = dx[: len(f)]
            gU, _ = s.grad_hess(st.q, 0.0)
            F_in = -float(st.mu[solver.driver_index()]) if not lam_free else float("nan")
            ma = _nan_div(1.0 - _nan_div(float(gU @ dq), F_in), dq[io].mean())
        elif spec.input != "driver" and a.kind == "load":
            ld = next(x for x in s.scene.loads if x.id == spec.input)
            mag = float(np.hypot(ld.fx, ld.fy))
            if ld.node is not None and mag > 0 and int(s.lay.node_dof[ld.node]) in pos:
                dx = solver.tangent(st, "lam")
                dq = np.zeros(s.n)
                dq[f] = dx[: len(f)]
                i = s.lay.node_dof[ld.node]
                ds_in = (ld.fx * dq[i] + ld.fy * dq[i + 1]) / mag
                gU, _ = s.grad_hess(st.q, 0.0)
                work = st.lam * mag * ds_in
                ma = _nan_div(1.0 - _nan_div(float(gU @ dq), work), _nan_div(dq[io].mean(), ds_in))
        outs = dict(step.outputs)
        outs["ma"] = ma
        out.append(replace(step, outputs=outs))
    return out
