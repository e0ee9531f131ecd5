"""Sparse direct solves for symmetric positive definite stiffness matrices.

Two tools, both on Intel MKL PARDISO (shipped by the ``pypardiso`` wheel):

- :class:`SPDSolver`, a factorisation reused for many right-hand sides;
- :func:`condensed_compliance`, the compliance ``P K^-1 P^T`` on a small set
  of DOFs (the contact zone). PARDISO returns the Schur complement
  ``S = K_cc - K_ci K_ii^-1 K_ic`` of those DOFs during factorisation
  (``iparm[35] = 1``), and ``P K^-1 P^T = S^-1``. This costs about one
  factorisation, where column-by-column solves cost one back-substitution per
  contact DOF (about 50 s for 2,300 DOFs at 40k DOF, against 1.2 s).
"""

from __future__ import annotations

import ctypes
import functools
import logging

import numpy as np
import scipy.sparse as sp

from fe_impact.errors import SolverError

logger = logging.getLogger(__name__)

_PARDISO_ERRORS = {
    -1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
    -4: "zero pivot: the stiffness matrix is singular (is every body supported?)",
    -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
}


@functools.cache
def _mkl_pardiso():
    """The MKL ``pardiso`` entry point, found the way pypardiso finds it (once: the
    search takes 0.1-0.3 s, and every factorisation asked for it)."""
    from pypardiso.pardiso_wrapper import PyPardisoSolver

    fn = PyPardisoSolver().libmkl.pardiso
    i32 = ctypes.POINTER(ctypes.c_int32)
    fn.argtypes = ([ctypes.POINTER(ctypes.c_int64)] + [i32] * 5
                   + [ctypes.c_void_p, i32, i32, i32, i32, i32, i32,
                      ctypes.c_void_p, ctypes.c_void_p, i32])
    fn.restype = None
    return fn


def limit_threads(n: int = 1):
    """A threadpoolctl limit of ``n`` threads that also reaches MKL's PARDISO.

    threadpoolctl only limits the libraries loaded when the limit is set, and
    MKL is loaded at the first factorisation: without loading it here first,
    two single-threaded workers on two cores each ran PARDISO on two threads
    and the cases took about twice as long.
    """
    from threadpoolctl import threadpool_limits

    _mkl_pardiso()
    return threadpool_limits(limits=n)


class SPDSolver:
    """Cholesky-type factorisation of an SPD matrix (PARDISO, mtype 2).

    Parameters
    ----------
    K : sparse matrix, shape (n, n)
        Symmetric positive definite; only its upper triangle is read.
    schur_dofs : array of int, optional
        DOFs whose Schur complement is formed during factorisation; then
        only :attr:`schur` is available, not :meth:`solve`.
    """

    def __init__(self, K: sp.spmatrix, schur_dofs: np.ndarray | None = None) -> None:
        self._fn = _mkl_pardiso()
        self._U = sp.triu(K, format="csr")
        self._U.sort_indices()
        self._ia = (self._U.indptr + 1).astype(np.int32)  # PARDISO is 1-based here
        self._ja = (self._U.indices + 1).astype(np.int32)
        self.n = K.shape[0]
        self._pt = np.zeros(64, dtype=np.int64)
        self._iparm = np.zeros(64, dtype=np.int32)
        self._iparm[0] = 1    # use the values below, not the defaults
        self._iparm[1] = 2    # METIS nested dissection
        self._iparm[9] = 8    # pivot perturbation 1e-8 (unused for SPD)
        self._iparm[17] = -1  # report nonzeros of the factor
        self._perm = np.zeros(self.n, dtype=np.int32)
        self.schur: np.ndarray | None = None
        ns = 0
        if schur_dofs is not None:
            ns = len(schur_dofs)
            self._perm[np.asarray(schur_dofs)] = 1
            self._iparm[35] = 1   # dense Schur complement returned in x
        out = np.zeros(ns * ns if ns else 1)
        self._call(12, np.zeros(1), out)
        if ns:
            self.schur = out.reshape(ns, ns)
        self.factor_nnz = int(self._iparm[17])
        self._released = False

    def _call(self, phase: int, b: np.ndarray, x: np.ndarray) -> None:
        err = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)
        nrhs = 1 if b.ndim == 1 else b.shape[1]
        one = ctypes.c_int32(1)
        self._fn(self._pt.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)), ctypes.byref(one),
                 ctypes.byref(one), ctypes.byref(ctypes.c_int32(2)),
                 ctypes.byref(ctypes.c_int32(phase)), ctypes.byref(ctypes.c_int32(self.n)),
                 self._U.data.ctypes.data, self._ia.ctypes.data_as(i32),
                 self._ja.ctypes.data_as(i32), self._perm.ctypes.data_as(i32),
                 ctypes.byref(ctypes.c_int32(nrhs)), self._iparm.ctypes.data_as(i32),
                 ctypes.byref(ctypes.c_int32(0)), b.ctypes.data, x.ctypes.data,
                 ctypes.byref(err))
        if err.value != 0:
            msg = _PARDISO_ERRORS.get(err.value, f"PARDISO error {err.value}")
            raise SolverError(f"sparse factorisation failed: {msg}")

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` for one (n,) or several (n, k) right-hand sides."""
        if self.schur is not None:
            raise RuntimeError("a Schur-complement factorisation cannot solve full systems")
        b = np.asfortranarray(b, dtype=float)
        x = np.zeros_like(b)
        self._call(33, b, x)
        return np.ascontiguousarray(x)

    def release(self) -> None:
        """Free PARDISO's memory (also done on garbage collection)."""
        if not self._released:
            self._call(-1, np.zeros(1), np.zeros(1))
            self._released = True

    def __del__(self) -> None:
        try:
            self.release()
        except Exception:  # interpreter shutdown: nothing sensible to do
            pass


def condensed_cholesky(K: sp.spmatrix, dofs: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor ``L`` of the Schur complement ``S`` of ``K`` onto ``dofs``.

    ``S^-1 = (K^-1)[dofs][:, dofs]``, so ``B (K^-1)_cc B^T = W^T W`` with
    ``W = L^-1 B^T``: a triangular solve with one column per contact row,
    cheaper than forming the compliance when the rows are fewer than the DOFs.
    """
    dofs = np.asarray(dofs)
    if np.any(np.diff(dofs) <= 0):
        raise ValueError("dofs must be sorted and unique")
    if len(dofs) == 0:
        return np.zeros((0, 0))
    solver = SPDSolver(K, schur_dofs=dofs)
    S = solver.schur
    solver.release()
    from scipy.linalg import lapack

    c, info = lapack.dpotrf(S, lower=1, clean=1, overwrite_a=1)
    if info != 0:
        raise SolverError("the condensed contact stiffness is not positive definite: "
                          "a body touching the contact zone is not supported")
    return c


def condensed_compliance(K: sp.spmatrix, dofs: np.ndarray) -> np.ndarray:
    """Compliance ``(K^-1)[dofs][:, dofs]`` of an SPD matrix, via the Schur complement.

    Parameters
    ----------
    K : sparse matrix, shape (n, n)
    dofs : array of int, shape (m,)
        Sorted, unique DOF indices.

    Returns
    -------
    ndarray, shape (m, m)
        Symmetric positive definite compliance on ``dofs`` in that order.
    """
    c = condensed_cholesky(K, dofs)
    if c.size == 0:
        return c
    from scipy.linalg import lapack

    # LAPACK potri: inverse from the Cholesky factor in place, ~6x faster than inv().
    G, info = lapack.dpotri(c, lower=1, overwrite_c=1)
    if info != 0:
        raise SolverError(f"inverting the condensed contact stiffness failed (info {info})")
    G = np.tril(G) + np.tril(G, -1).T
    return G
