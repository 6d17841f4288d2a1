"""End loads of PRB states through pinv(J^T): the square full-rank solve and the SVD agree
with the definition J^T f = tau, and a singular J^T keeps its rank and the known loads."""

import numpy as np

import cases
from reduced_models.beam.prb import PRB3R
from reduced_models.beam.prb_chain import PRBChain
from reduced_models.beam.prb_post import recover_tip_loads_batch


def _chain() -> PRBChain:
    scene = cases.load("cantilever-tip-load")
    beam, (matrix, _, _) = PRB3R()._prepare(scene)
    return PRBChain(matrix, beam.L, beam.EI, beam.EA)


def test_bent_states_solve_jt_f_equals_tau() -> None:
    chain = _chain()
    X = np.array([[-0.1, -0.3, -0.5], [0.2, 0.1, -0.4], [-0.6, -1.0, -1.2]])
    f, rank = recover_tip_loads_batch(chain, X, np.zeros((3, 3)))
    assert rank.tolist() == [3, 3, 3]
    tau = chain.spring_forces(X)
    np.testing.assert_allclose((chain.jacobian_T(X) @ f[:, :, None])[:, :, 0], tau, rtol=1e-12)


def test_straight_state_is_rank_two_and_keeps_the_axial_load() -> None:
    # every pivot on the x axis: J^T's first column (-y of tip minus pivot) is zero, so the
    # axial tip force is not seen by the springs and comes from the known loads
    chain = _chain()
    X = np.zeros((1, 3))
    f, rank = recover_tip_loads_batch(chain, X, np.array([[-2.5, 0.0, 0.0]]))
    assert rank.tolist() == [2]
    np.testing.assert_allclose(f, [[-2.5, 0.0, 0.0]], atol=1e-14)


def test_a_batch_of_straight_and_bent_states() -> None:
    # the unloaded state (rank 2, SVD) beside bent ones (LU) in one batch: each row as alone
    chain = _chain()
    X = np.array([[0.0, 0.0, 0.0], [-0.1, -0.3, -0.5], [0.2, 0.1, -0.4]])
    known = np.array([[-2.5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    f, rank = recover_tip_loads_batch(chain, X, known)
    assert rank.tolist() == [2, 3, 3]
    np.testing.assert_allclose(f[0], known[0], atol=1e-14)
    tau = chain.spring_forces(X[1:])
    np.testing.assert_allclose((chain.jacobian_T(X[1:]) @ f[1:, :, None])[:, :, 0], tau, rtol=1e-12)
