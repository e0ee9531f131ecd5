"""PARDISO solves, Schur-complement condensation and MKL's sparse products against
dense linear algebra and scipy."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fe_impact.errors import SolverError
from fe_impact.fe.linalg import (
    SparseProduct,
    SPDSolver,
    _mirror_lower,
    condensed_cholesky,
    condensed_compliance,
    inverse_from_cholesky,
    schur_cholesky,
)


def _spd(n: int = 60, seed: int = 0) -> sp.csr_matrix:
    """A sparse SPD matrix: a 1-D Laplacian, plus the identity, plus random symmetric
    couplings kept diagonally dominant (eigenvalues in about [1, 9]: condition < 10)."""
    rng = np.random.default_rng(seed)
    lap = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    i, j = rng.integers(0, n, 40), rng.integers(0, n, 40)
    keep = i != j
    c = 0.5 * rng.random(keep.sum())
    extra = sp.coo_matrix((c, (i[keep], j[keep])), shape=(n, n))
    extra = extra + extra.T
    dominance = np.asarray(abs(extra).sum(axis=1)).ravel()
    return (lap + sp.eye(n) + extra + sp.diags(dominance)).tocsr()


# Every result below is a backward-stable factorisation of a matrix with condition
# number < 10 (Gershgorin) compared with LAPACK on the same matrix: errors are a few
# eps times the condition number, 1e-12 leaves a factor 100.
TOL = 1e-12


def test_solve_one_and_several_right_hand_sides():
    K = _spd()
    dense = K.toarray()
    assert np.linalg.cond(dense) < 10
    rng = np.random.default_rng(1)
    b = rng.standard_normal(K.shape[0])
    B = rng.standard_normal((K.shape[0], 3))
    solver = SPDSolver(K)
    np.testing.assert_allclose(solver.solve(b), np.linalg.solve(dense, b), rtol=0,
                               atol=TOL * np.abs(np.linalg.solve(dense, b)).max())
    X = solver.solve(B)
    assert X.shape == B.shape
    np.testing.assert_allclose(X, np.linalg.solve(dense, B), rtol=0, atol=TOL * np.abs(X).max())
    assert solver.factor_nnz >= K.shape[0]
    solver.release()
    solver.release()   # twice is harmless


def test_only_the_upper_triangle_is_read():
    # "only its upper triangle is read": garbage below the diagonal changes nothing
    K = _spd()
    spoiled = sp.triu(K) + sp.tril(sp.random(*K.shape, density=0.1, random_state=2), -1)
    b = np.arange(K.shape[0], dtype=float)
    np.testing.assert_allclose(SPDSolver(spoiled.tocsr()).solve(b), SPDSolver(K).solve(b),
                               rtol=TOL)


@pytest.mark.parametrize("dofs", [[0], [3, 17, 18, 40, 59], list(range(0, 60, 7))])
def test_condensed_compliance_is_the_inverse_restricted(dofs):
    K = _spd()
    dofs = np.asarray(dofs)
    G = condensed_compliance(K, dofs)
    inverse = np.linalg.inv(K.toarray())[np.ix_(dofs, dofs)]
    np.testing.assert_allclose(G, inverse, rtol=0, atol=TOL * np.abs(inverse).max())
    np.testing.assert_array_equal(G, G.T)


def test_condensed_cholesky_factors_the_schur_complement():
    # S = K_cc - K_ci K_ii^-1 K_ic = ((K^-1)_cc)^-1, and L is its lower Cholesky factor
    K = _spd().toarray()
    c = np.array([2, 9, 10, 33, 51])
    i = np.setdiff1d(np.arange(len(K)), c)
    schur = K[np.ix_(c, c)] - K[np.ix_(c, i)] @ np.linalg.solve(K[np.ix_(i, i)], K[np.ix_(i, c)])
    L = condensed_cholesky(sp.csr_matrix(K), c)
    np.testing.assert_array_equal(L, np.tril(L))
    assert (np.diag(L) > 0).all()
    np.testing.assert_allclose(L @ L.T, schur, rtol=0, atol=TOL * np.abs(schur).max())
    np.testing.assert_allclose(L, np.linalg.cholesky(schur), rtol=0, atol=1e-11)


def test_condensation_edge_cases_and_errors():
    K = _spd()
    assert condensed_compliance(K, np.array([], dtype=int)).shape == (0, 0)
    with pytest.raises(ValueError, match="sorted and unique"):
        condensed_compliance(K, np.array([5, 3]))
    with pytest.raises(ValueError, match="sorted and unique"):
        condensed_cholesky(K, np.array([3, 3]))
    schur_only = SPDSolver(K, schur_dofs=np.array([1, 2]))
    assert schur_only.schur.shape == (2, 2)
    with pytest.raises(RuntimeError, match="Schur"):
        schur_only.solve(np.ones(K.shape[0]))


@pytest.mark.parametrize("dofs", [[0], [3, 17, 18, 40, 59], list(range(0, 60, 7))])
def test_schur_factorisation_also_solves_the_full_system(dofs):
    # keep_factor: the factorisation that returns the Schur complement (PARDISO
    # iparm[35] = 2) solves K x = b as a plain one does, to round-off (TOL above)
    K = _spd()
    dense = K.toarray()
    dofs = np.asarray(dofs)
    rest = np.setdiff1d(np.arange(len(dense)), dofs)
    schur = dense[np.ix_(dofs, dofs)] - dense[np.ix_(dofs, rest)] @ np.linalg.solve(
        dense[np.ix_(rest, rest)], dense[np.ix_(rest, dofs)])
    rng = np.random.default_rng(3)
    b, B = rng.standard_normal(len(dense)), rng.standard_normal((len(dense), 4))
    both = SPDSolver(K, schur_dofs=dofs, keep_factor=True)
    plain = SPDSolver(K)
    np.testing.assert_allclose(both.schur, schur, rtol=0, atol=TOL * np.abs(schur).max())
    for rhs in (b, B):
        x, x_plain = both.solve(rhs), plain.solve(rhs)
        assert x.shape == rhs.shape
        np.testing.assert_allclose(x, x_plain, rtol=0, atol=TOL * np.abs(x_plain).max())
        np.testing.assert_allclose(x, np.linalg.solve(dense, rhs), rtol=0,
                                   atol=TOL * np.abs(x_plain).max())
    both.release()
    with pytest.raises(RuntimeError, match="released"):
        both.solve(b)
    with pytest.raises(ValueError, match="schur_dofs is empty"):
        SPDSolver(K, schur_dofs=np.array([], dtype=int), keep_factor=True)


def test_cholesky_and_inverse_of_a_schur_complement():
    # schur_cholesky factors in place (no copy of a C-ordered S); the inverse is
    # exactly symmetric and equals numpy's inverse (condition < 10: TOL)
    K = _spd().toarray()
    S = K[:20, :20].copy()
    L = schur_cholesky(S)
    assert np.shares_memory(L, S)
    np.testing.assert_allclose(L @ L.T, K[:20, :20], rtol=0, atol=TOL * np.abs(K).max())
    G = inverse_from_cholesky(L)
    assert G.flags.c_contiguous
    np.testing.assert_array_equal(G, G.T)
    np.testing.assert_allclose(G, np.linalg.inv(K[:20, :20]), rtol=0, atol=TOL)
    with pytest.raises(SolverError, match="not positive definite"):
        schur_cholesky(-np.eye(3))


@pytest.mark.parametrize("n,block", [(1, 4), (10, 3), (17, 512), (40, 7)])
def test_mirror_lower_copies_the_lower_triangle_exactly(n, block):
    # the blocked in-place copy against the obvious tril(G) + tril(G, -1).T
    G = np.random.default_rng(n).standard_normal((n, n))
    expected = np.tril(G) + np.tril(G, -1).T
    np.testing.assert_array_equal(_mirror_lower(G, block), expected)


def test_singular_matrix_is_reported():
    # a free body: the stiffness of two unconnected springs' ends has a zero pivot
    singular = sp.csr_matrix(np.array([[1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    with pytest.raises(SolverError, match="singular|factorisation"):
        SPDSolver(singular).solve(np.ones(3))


@pytest.mark.parametrize("n", [1, 3])
def test_schur_block_of_every_dof_is_the_matrix_itself(n):
    """A model of rigid bodies only puts every DOF in the Schur block (the 1-DOF
    SDOF impact cases). MKL PARDISO's Schur path with an empty interior reads out
    of bounds, so this case is handled without it: S = K exactly, the forward
    substitution passes the right-hand side unchanged, the backward one the Schur
    solution, and a full solve is the dense one (to rounding, TOL)."""
    K = _spd(n, seed=3)
    solver = SPDSolver(K, schur_dofs=np.arange(n), keep_factor=True)
    assert np.array_equal(solver.schur, K.toarray())
    b = np.arange(1.0, n + 1.0)
    x = np.linalg.solve(K.toarray(), b)
    assert np.allclose(solver.solve(b), x, rtol=TOL, atol=0)
    y = solver.forward(b)
    assert np.array_equal(y, b)
    assert np.array_equal(solver.backward(x), x)
    solver.release()
    with pytest.raises(RuntimeError, match="released"):
        solver.solve(b)


def test_mkl_is_found_from_the_wheels_file_list_without_pypardisos_search():
    """The MKL library is located through the ``mkl`` wheel's file list, in a fresh
    process that then factorises and solves without importing pypardiso (whose
    import and solver objects walk the whole environment: 2.4 s a sweep worker on
    a cold disk cache). Falls back to pypardiso only if this lookup breaks, which
    is what this test would catch."""
    import subprocess
    import sys

    code = ("import sys, numpy as np, scipy.sparse as sp\n"
            "from fe_impact.fe import linalg\n"
            "assert linalg._mkl_rt_file() is not None\n"
            "K = sp.diags([-1.0, 4.0, -1.0], [-1, 0, 1], shape=(8, 8)).tocsr()\n"
            "x = linalg.SPDSolver(K).solve(np.ones(8))\n"
            "assert abs(K @ x - 1.0).max() < 1e-12\n"
            "assert 'pypardiso' not in sys.modules, 'pypardiso was imported'\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def _unsorted_with_duplicates(rng, n: int, m: int) -> sp.csr_matrix:
    """A CSR matrix with repeated entries and its column indices shuffled within each row."""
    i, j = rng.integers(0, n, 6 * n), rng.integers(0, m, 6 * n)
    v = rng.standard_normal(6 * n)
    i, j, v = (np.concatenate([a, a[:n]]) for a in (i, j, v))     # n duplicates
    order = np.lexsort((rng.permutation(len(i)), i))             # rows kept, columns shuffled
    indptr = np.searchsorted(i[order], np.arange(n + 1))
    A = sp.csr_matrix((v[order], j[order], indptr), shape=(n, m))
    assert not A.has_sorted_indices
    return A


@pytest.mark.parametrize("shape", [(50, 50), (40, 70), (70, 40)])
def test_sparse_product_is_scipys_product(shape):
    """MKL's analysed product against scipy's on square and rectangular matrices with
    unsorted indices: a sum of at most ~30 terms of size 1 each way, so the two
    orders of summation differ by a few eps (1e-13 absolute leaves a factor 100)."""
    rng = np.random.default_rng(3)
    A = _unsorted_with_duplicates(rng, *shape)
    P = SparseProduct(A, calls=10)
    assert P.uses_mkl
    x = rng.standard_normal(shape[1])
    np.testing.assert_allclose(P @ x, A @ x, rtol=0, atol=1e-13)
    X = rng.standard_normal((shape[1], 3))          # several vectors: scipy's way
    np.testing.assert_allclose(P @ X, A @ X, rtol=0, atol=1e-13)
    P.release()
    np.testing.assert_allclose(P @ x, A @ x, rtol=0, atol=1e-13)   # released: scipy's


def test_sparse_product_keeps_its_own_copy_and_pickles():
    """The product does not change when the caller's matrix does, and a pickled one
    (sent to a worker) gives the same products."""
    import pickle

    A = _spd(40)
    x = np.arange(40.0)
    P = SparseProduct(A)
    want = A @ x
    A.data[:] = 0.0
    np.testing.assert_allclose(P @ x, want, rtol=0, atol=1e-12)
    Q = pickle.loads(pickle.dumps(P))
    assert Q.uses_mkl
    np.testing.assert_allclose(Q @ x, want, rtol=0, atol=1e-12)


def test_sparse_product_of_an_empty_matrix_and_a_wrong_vector():
    P = SparseProduct(sp.csr_matrix((5, 4)))
    assert not P.uses_mkl
    np.testing.assert_array_equal(P @ np.ones(4), np.zeros(5))
    with pytest.raises(ValueError):
        SparseProduct(_spd(6)) @ np.ones(5)


def test_sparse_product_without_a_copy_shares_the_matrix():
    A = _spd(30)
    A.indices = A.indices.astype(np.int32)
    P = SparseProduct(A, copy=False)
    assert P.uses_mkl and np.shares_memory(P.A.data, A.data)
    x = np.linspace(-1.0, 1.0, 30)
    np.testing.assert_allclose(P @ x, A @ x, rtol=0, atol=1e-12)
