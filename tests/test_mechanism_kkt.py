"""Fused KKT assembly and the sparse path of the mechanism assembler (issue 9, speed).

References (never the fused path's own numbers):
* the residual and KKT matrix against the global dense assembly of ``MechanismSystem``
  (``grad_hess``, ``cons``, ``curvature``: per-term scatter, FD-checked in test_mechanism) and
  against central finite differences of the residual itself, on random states;
* the sparse path against the dense one: the same matrices, the same equilibria and the same
  stability verdicts on scenes with stable and unstable equilibria;
* the certified sparse LDL^T inertia against the eigenvalues of random KKT matrices.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import cases
from reduced_models.mechanism import analyses, kkt_sparse
from reduced_models.mechanism.builder import build
from reduced_models.mechanism.kkt import Assembly
from reduced_models.mechanism.model import member_spec
from reduced_models.mechanism.newton import Solver, State

SCENES = [
    ("das2d-parallel-guide-26dof", "cbcm-2"),  # chains + loads on a rigid link
    ("das2d-ex2-parallelogram", "prb-2rpr"),  # PRB joints, stretch unknowns
    ("das2d-ex3-bistable-switch", "mixed"),  # chains and PRB joints together
    ("das2d-ex4-bistable-fourbar", "linear-4"),  # inextensible chain + driver row
    ("das2d-ex5-constant-force", "kinetostatic"),  # rigid links and torsion springs only
]


def _plain(case: str, model: str):
    scene = cases.load(case)
    if model == "mixed":
        return build(scene, lambda m: member_spec(m.model, m.model_options))
    if model == "kinetostatic":
        return build(scene, lambda m: ("none",))
    return build(scene, lambda m: member_spec(model))


def _system(case: str, model: str):
    """The system with its driver row, as an energy analysis adds it."""
    sysm = _plain(case, model)
    if cases.load(case).analysis.driver is not None:
        sysm.driver_row = sysm.linear.add([sysm.driver_dof], [1.0], 0.0, "driver")
    return sysm


def _state(sysm, rng):
    q = sysm.q0.copy()
    kind = np.array(sysm.lay.kind)[sysm.free]
    step = np.where(kind == "r", 0.2, np.where(kind == "p", 0.5, 0.02 * sysm.lay.Lref))
    q[sysm.free] += step * rng.uniform(-1, 1, len(sysm.free))
    return q, rng.uniform(-1, 1, sysm.m) * sysm.fscale


def _reference(sysm, q, lam, mu):
    """[g + J^T mu; c] and [[H + curvature, J^T], [J, 0]] from the global dense assembly."""
    f = sysm.free
    g, H = sysm.grad_hess(q, lam)
    c, J = sysm.cons(q)
    W = H + sysm.curvature(q, mu)
    Jf = J[:, f]
    K = np.block([[W[np.ix_(f, f)], Jf.T], [Jf, np.zeros((len(c), len(c)))]])
    return np.concatenate([g[f] + Jf.T @ mu, c]), K


@pytest.mark.parametrize("case,model", SCENES)
def test_fused_kkt_equals_global_assembly_and_fd_jacobian(case, model):
    sysm = _system(case, model)
    rng = np.random.default_rng(3)
    asm = Assembly(sysm, sparse=False)
    nf, f = len(sysm.free), sysm.free
    for _ in range(2):
        q, mu = _state(sysm, rng)
        lam = 0.8
        R, K = asm.evaluate(q, lam, mu)
        Rr, Kr = _reference(sysm, q, lam, mu)
        scale = np.abs(Kr).max()
        np.testing.assert_allclose(R, Rr, rtol=0, atol=1e-12 * max(np.abs(Rr).max(), 1.0))
        np.testing.assert_allclose(K, Kr, rtol=0, atol=1e-12 * scale)
        # the KKT matrix is the Jacobian of the residual in (q_free, mu)
        h = 1e-6
        for i in range(K.shape[0]):
            qp, qm, mp, mm = q.copy(), q.copy(), mu.copy(), mu.copy()
            if i < nf:
                qp[f[i]] += h
                qm[f[i]] -= h
            else:
                mp[i - nf] += h
                mm[i - nf] -= h
            col = (asm.evaluate(qp, lam, mp)[0] - asm.evaluate(qm, lam, mm)[0]) / (2 * h)
            np.testing.assert_allclose(col, K[:, i], rtol=1e-5, atol=1e-6 * scale)


def test_distance_solve_column_is_the_load_derivative():
    """With the load factor in the driver multiplier's slot, that column of K is d R / d lam
    (finite differences in lam) and the driver row's J^T entries are gone."""
    sysm = _system("das2d-ex4-bistable-fourbar", "linear-4")
    sv = Solver(sysm, sparse=False)
    q, mu = _state(sysm, np.random.default_rng(5))
    d = sv.driver_index()
    R, K, _ = sv.kkt(State(q, mu, 0.3), lam_free=True)
    h = 1e-6
    dR = (sv.kkt(State(q, mu, 0.3 + h), True)[0] - sv.kkt(State(q, mu, 0.3 - h), True)[0]) / (2 * h)
    np.testing.assert_allclose(K[:, sv.nf + d], dR, rtol=1e-6, atol=1e-9 * np.abs(K).max())


@pytest.mark.parametrize("case,model", SCENES)
def test_sparse_and_dense_assembly_agree(case, model):
    sysm = _system(case, model)
    q, mu = _state(sysm, np.random.default_rng(11))
    Rd, Kd = Assembly(sysm, sparse=False).evaluate(q, 0.6, mu)
    Rs, Ks = Assembly(sysm, sparse=True).evaluate(q, 0.6, mu)
    assert sp.issparse(Ks) and not sp.issparse(Kd)
    np.testing.assert_array_equal(Rs, Rd)
    np.testing.assert_allclose(Ks.toarray(), Kd, rtol=0, atol=1e-13 * np.abs(Kd).max())


@pytest.mark.parametrize(
    "case,model",
    [
        ("das2d-parallel-guide-26dof", "cbcm-2"),
        ("das2d-ex4-bistable-fourbar", "linear-4"),  # stable and unstable equilibria
        ("das2d-ex5-constant-force", "kinetostatic"),
    ],
)
def test_sparse_path_gives_the_dense_answers_and_verdicts(case, model):
    scene = cases.load(case)
    runs = []
    for sparse in (False, True):
        r = analyses.Run(_plain(case, model), {"sparse": sparse})
        r.lazy = True
        r.load() if scene.analysis.kind == "load" else r.driver(scene.analysis.kind)
        runs.append(r)
    dense, sparse = runs
    assert len(dense.steps) == len(sparse.steps) == scene.analysis.steps + 1
    for a, b in zip(dense.states, sparse.states, strict=True):
        np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-9 * dense.s.lay.Lref)
    verdicts = [s.stable for s in dense.steps]
    assert verdicts == [s.stable for s in sparse.steps]
    assert None not in verdicts
    if case.startswith("das2d-ex4"):  # driver released at the force zeros: both verdicts
        eq = [e["kind"] for e in sparse.extras["equilibria"]]
        assert eq == [e["kind"] for e in dense.extras["equilibria"]]
        assert "stable" in eq and "unstable" in eq


def _random_kkt(rng, nf: int, m: int, zeros: int) -> sp.csc_matrix:
    """Banded symmetric indefinite W (``zeros`` zero diagonal entries, as rigid-link angles
    and multiplier-like axial forces have) bordered by a sparse full-rank J."""
    W = sp.diags(
        [rng.uniform(-1, 1, nf - k) for k in range(3)]
        + [rng.uniform(-1, 1, nf - k) for k in (1, 2)],
        [0, 1, 2, -1, -2],
    ).toarray()
    W = 0.5 * (W + W.T) + np.diag(rng.uniform(0.5, 2.0, nf))
    W[np.diag_indices(nf)] *= rng.choice([-1.0, 1.0], nf)
    idx = rng.choice(nf, zeros, replace=False)
    W[idx, idx] = 0.0
    J = np.zeros((m, nf))
    for k in range(m):
        J[k, rng.choice(nf, 4, replace=False)] = rng.uniform(-1, 1, 4)
        J[k, idx[k % zeros] if zeros else k] = 1.0
    K = np.block([[W, J.T], [J, np.zeros((m, m))]])
    return sp.csc_matrix(K)


def test_certified_sparse_ldl_counts_the_negative_eigenvalues():
    rng = np.random.default_rng(2024)
    certified = 0
    for trial in range(40):
        nf, m = int(rng.integers(8, 40)), int(rng.integers(1, 6))
        K = _random_kkt(rng, nf, m, zeros=min(m, 3))
        ev = np.linalg.eigvalsh(K.toarray())
        fac = kkt_sparse.ldl(K, nf)
        if fac is None:
            continue
        certified += 1
        solve, d, rel = fac
        n_neg, _ = kkt_sparse.inertia(d, rel)
        assert n_neg == int(np.count_nonzero(ev < 0)), trial
        b = rng.standard_normal(nf + m)
        np.testing.assert_allclose(K @ solve(b), b, atol=1e-8 * np.abs(b).max())
    assert certified >= 30  # the certificate is the rule, not the exception


def test_dense_inertia_of_bunch_kaufman_factors_counts_the_negative_eigenvalues():
    """``newton._inertia`` (1x1 and 2x2 pivots of LAPACK dsytrf) against eigvalsh."""
    from scipy.linalg import lapack

    from reduced_models.mechanism.newton import _inertia

    rng = np.random.default_rng(9)
    two = 0
    for trial in range(40):  # small systems (plain floats) and large ones (vectorised)
        nf, m = (
            int(rng.integers(4, 30) if trial % 4 else rng.integers(130, 200)),
            int(rng.integers(0, 5)),
        )
        K = _random_kkt(rng, nf, m, zeros=min(m, 3)).toarray() if m else None
        if K is None:
            A = rng.standard_normal((nf, nf))
            K = A + A.T
        lu, piv, info = lapack.dsytrf(K, lower=1)[:3]
        two += int(np.any(piv < 0))
        n_neg, rel = _inertia(lu, piv)
        assert n_neg == int(np.count_nonzero(np.linalg.eigvalsh(K) < 0)), trial
    assert two >= 10  # 2x2 pivots were exercised
