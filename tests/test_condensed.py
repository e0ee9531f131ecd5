"""The condensed contact's linear algebra against dense linear algebra: the rotation
into the zone frames, the solves and the Schur complement from one factorisation
(also after a plain factorisation takes the solves over), and the zone compliance."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from fe_impact.contact.condensed import ZoneCompliance, ZoneSolver, rotate

# Every comparison below is a backward-stable factorisation or product of matrices
# with condition number < 10 (the SPD matrix of _spd, Gershgorin) or of an orthogonal
# rotation, against LAPACK on the same matrix: errors are a few eps times the
# condition number, 1e-12 leaves a factor 100.
TOL = 1e-12
N_NODES = 20
ZONE = np.arange(4, 12)          # the "zone nodes", rotated into their frames


def _spd(seed: int = 0) -> sp.csr_matrix:
    """A sparse SPD matrix on 20 nodes of 3 coordinates: full 3 x 3 blocks between
    neighbouring nodes, kept diagonally dominant (eigenvalues in about [1, 9])."""
    rng = np.random.default_rng(seed)
    n = 3 * N_NODES
    i = np.repeat(np.arange(N_NODES - 1), 9)
    a = np.tile(np.repeat(np.arange(3), 3), N_NODES - 1)
    b = np.tile(np.tile(np.arange(3), 3), N_NODES - 1)
    c = rng.uniform(-0.5, 0.5, len(i))
    off = sp.coo_matrix((c, (3 * i + a, 3 * (i + 1) + b)), shape=(n, n))
    off = off + off.T
    dominance = np.asarray(abs(off).sum(axis=1)).ravel()
    return (off + sp.diags(1.0 + dominance + rng.random(n))).tocsr()


def _frames(seed: int = 1) -> tuple[sp.csr_matrix, np.ndarray]:
    """``R``: random rotations of the zone nodes' coordinates, identity elsewhere;
    and the condensed coordinates: each zone node's first (normal) slot."""
    n = 3 * N_NODES
    F = Rotation.random(len(ZONE), random_state=seed).as_matrix()
    blocks = [sp.identity(3) for _ in range(N_NODES)]
    for k, node in enumerate(ZONE):
        blocks[node] = sp.csr_matrix(F[k])
    R = sp.block_diag(blocks, format="csr")
    assert R.shape == (n, n)
    return R, 3 * ZONE


def _schur(A: np.ndarray, dofs: np.ndarray) -> np.ndarray:
    rest = np.setdiff1d(np.arange(len(A)), dofs)
    return A[np.ix_(dofs, dofs)] - A[np.ix_(dofs, rest)] @ np.linalg.solve(
        A[np.ix_(rest, rest)], A[np.ix_(rest, dofs)])


def test_rotate_is_the_triple_product():
    K = _spd()
    R, _ = _frames()
    expected = (R.T @ K @ R).toarray()
    np.testing.assert_allclose(rotate(K, R).toarray(), expected, rtol=0,
                               atol=TOL * np.abs(expected).max())
    # the identity rotates nothing
    np.testing.assert_array_equal(rotate(K, sp.identity(K.shape[0], format="csr")).toarray(),
                                  K.toarray())


@pytest.mark.parametrize("schur_solves", [0, 3, 100])
def test_zone_solver_solves_and_condenses_from_one_factorisation(schur_solves):
    # Solves equal numpy's on K, before and after the plain factorisation takes
    # over (after schur_solves right-hand sides), and the Schur complement is the
    # rotated matrix's, also when condensed again after the takeover.
    K = _spd()
    dense = K.toarray()
    R, dofs = _frames()
    solver = ZoneSolver(K, schur_solves)
    S = solver.condense(R, dofs)
    schur = _schur((R.T @ K @ R).toarray(), dofs)
    np.testing.assert_allclose(S, schur, rtol=0, atol=TOL * np.abs(schur).max())
    rng = np.random.default_rng(2)
    for k in range(6):
        b = rng.standard_normal(K.shape[0]) if k % 2 else rng.standard_normal((K.shape[0], 2))
        x = solver.solve(b)
        expected = np.linalg.solve(dense, b)
        np.testing.assert_allclose(x, expected, rtol=0, atol=TOL * np.abs(expected).max())
    assert solver.solves == 9
    assert (solver._plain is not None) == (schur_solves < 9)
    R2, dofs2 = _frames(seed=5)
    S2 = solver.condense(R2, dofs2[:5])
    schur2 = _schur((R2.T @ K @ R2).toarray(), dofs2[:5])
    np.testing.assert_allclose(S2, schur2, rtol=0, atol=TOL * np.abs(schur2).max())
    b = rng.standard_normal(K.shape[0])
    expected = np.linalg.solve(dense, b)
    np.testing.assert_allclose(solver.solve(b), expected, rtol=0,
                               atol=TOL * np.abs(expected).max())
    solver.release()


def test_condensed_response_is_the_solve_of_a_force_on_the_zone():
    # A force on the condensed coordinates, R_c f: K^-1 R_c f from its condensed
    # part S^-1 f and one backward substitution equals numpy's solve; it counts
    # as a solve, and once the plain factorisation has taken over it is refused.
    K = _spd()
    R, dofs = _frames()
    solver = ZoneSolver(K, 2)
    S = solver.condense(R, dofs)
    f = np.random.default_rng(3).standard_normal(len(dofs))
    expected = np.linalg.solve(K.toarray(), R[:, dofs] @ f)
    x = solver.condensed_response(np.linalg.solve(S, f))
    np.testing.assert_allclose(x, expected, rtol=0, atol=TOL * np.abs(expected).max())
    assert solver.solves == 1
    solver.solve(np.ones(K.shape[0]))
    solver.solve(np.ones(K.shape[0]))      # the third solve: the plain factorisation
    with pytest.raises(RuntimeError, match="kept Schur factorisation"):
        solver.condensed_response(np.zeros(len(dofs)))


def test_zone_solver_without_zone_and_errors():
    K = _spd()
    solver = ZoneSolver(K)
    with pytest.raises(RuntimeError, match="before condense"):
        solver.solve(np.ones(K.shape[0]))
    assert solver.condense(sp.identity(K.shape[0], format="csr"), np.array([], int)).shape \
        == (0, 0)
    b = np.arange(K.shape[0], dtype=float)
    np.testing.assert_allclose(solver.solve(b), np.linalg.solve(K.toarray(), b), rtol=0,
                               atol=TOL * np.abs(np.linalg.solve(K.toarray(), b)).max())
    with pytest.raises(ValueError, match="schur_solves = -1"):
        ZoneSolver(K, -1)


def test_zone_compliance_by_triangular_solves_then_by_the_inverse():
    # B S^-1 B^T by W^T W with W = L^-1 B^T while the rows solved stay under
    # 2 m / 3, then by the explicit inverse: both equal the dense product
    K = _spd().toarray()
    dofs = np.arange(0, 60, 2)                    # m = 30: the inverse after 20 rows
    S = _schur(K, dofs)
    compliance = ZoneCompliance(S.copy())
    rng = np.random.default_rng(4)
    for rows, inverted in ((8, False), (8, False), (8, True), (3, True)):
        Bc = sp.random(rows, len(dofs), density=0.2, random_state=rng, format="csr")
        expected = Bc.toarray() @ np.linalg.solve(S, Bc.toarray().T)
        got = compliance.inner(Bc)
        assert (compliance.G is not None) == inverted
        np.testing.assert_allclose(got, expected, rtol=0, atol=TOL * np.abs(expected).max())


def test_zone_compliance_applies_its_inverse_to_one_vector_or_several():
    # one vector by two triangular passes (forward, backward), several by dpotrs,
    # and both by the inverse once it is formed: each is S^-1 v
    K = _spd().toarray()
    dofs = np.arange(0, 60, 2)
    S = _schur(K, dofs)
    compliance = ZoneCompliance(S.copy())
    rng = np.random.default_rng(5)
    v, V = rng.standard_normal(len(dofs)), rng.standard_normal((len(dofs), 3))
    x, X = np.linalg.solve(S, v), np.linalg.solve(S, V)
    np.testing.assert_allclose(compliance.backward(compliance.forward(v)), x, rtol=0,
                               atol=TOL * np.abs(x).max())
    for inverted in (False, True):
        assert (compliance.G is not None) == inverted
        np.testing.assert_allclose(compliance.apply(v), x, rtol=0, atol=TOL * np.abs(x).max())
        np.testing.assert_allclose(compliance.apply(V), X, rtol=0, atol=TOL * np.abs(X).max())
        compliance.inner(sp.identity(len(dofs), format="csr"))   # 30 rows: forms the inverse
    assert compliance.W is None


def test_zone_compliance_of_no_rows_or_no_zone():
    compliance = ZoneCompliance(np.eye(4))
    assert compliance.inner(sp.csr_matrix((0, 4))).shape == (0, 0)
    assert compliance.solved_rows == 0
    np.testing.assert_array_equal(ZoneCompliance(np.zeros((0, 0))).inner(
        sp.csr_matrix((2, 0))), np.zeros((2, 2)))
