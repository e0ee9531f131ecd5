"""Sparse direct solves for symmetric positive definite stiffness matrices, and
the sparse products of the time steps.

Three tools, all on Intel MKL (shipped by the ``pypardiso`` wheel):

- :class:`SPDSolver`, a factorisation reused for many right-hand sides;
  given ``schur_dofs`` it also returns the dense Schur complement
  ``S = K_cc - K_ci K_ii^-1 K_ic`` of those DOFs, and with
  ``keep_factor=True`` the same factorisation still solves the full system
  (``iparm[35] = 2``: PARDISO factors ``S`` itself and its solve phase 33 is
  forward substitution 331, the Schur block 332 and backward substitution
  333), so one factorisation serves both;
- :func:`condensed_compliance`, the compliance ``P K^-1 P^T`` on a small set
  of DOFs (the contact zone): ``P K^-1 P^T = S^-1``. This costs about one
  factorisation, where column-by-column solves cost one back-substitution per
  contact DOF (about 50 s for 2,300 DOFs at 40k DOF, against 1.2 s);
- :class:`SparseProduct`, ``A @ x`` for a matrix used many times over (the
  stiffness product of every explicit step, the stiffness and mass products
  of every Newmark step) by MKL's inspector-executor sparse BLAS, which
  analyses the matrix once and streams it at about twice the speed of
  scipy's CSR loop.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import logging
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from fe_impact.errors import SolverError

logger = logging.getLogger(__name__)

_PARDISO_ERRORS = {
    -1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
    -4: "zero pivot: the stiffness matrix is singular (is every body supported?)",
    -7: "diagonal matrix is singular", -8: "32-bit integer overflow",
}


def _mkl_rt_file() -> str | None:
    """The ``mkl_rt`` library of the installed ``mkl`` wheel, from its file list.

    pypardiso, which brings that wheel, searches for the library by walking
    every folder of the environment, once when it is imported and once per
    solver object: 2.4 s in each sweep worker on a cold disk cache (6,000
    folders in ``.venv``), where the wheel's own record names it in 0.02 s.
    None if the wheel or the file is not there (then pypardiso searches).
    """
    from importlib import metadata

    try:
        files = metadata.files("mkl") or []
    except metadata.PackageNotFoundError:
        return None
    for f in files:
        name = f.name
        if "mkl_rt" in name and (".so" in name or name.endswith((".dylib", ".dll"))):
            path = Path(f.locate()).resolve()
            if path.is_file():
                return str(path)
    return None


@functools.cache
def _mkl_rt() -> ctypes.CDLL:
    """The MKL runtime library (loaded once): from the ``mkl`` wheel's file list,
    else the way pypardiso finds it."""
    lib = None
    path = _mkl_rt_file()
    if path is not None:
        try:
            lib = ctypes.CDLL(path)
        except OSError as exc:
            logger.debug("could not load %s (%s): searching as pypardiso does", path, exc)
    if lib is None:
        from pypardiso.pardiso_wrapper import PyPardisoSolver

        lib = PyPardisoSolver().libmkl
    return lib


@functools.cache
def _mkl_pardiso():
    """The MKL ``pardiso`` entry point (looked up once: every factorisation asks
    for it)."""
    fn = _mkl_rt().pardiso
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
        DOFs whose Schur complement :attr:`schur` (dense, shape (m, m), in
        the order of ``schur_dofs`` sorted) is formed during factorisation.
    keep_factor : bool
        With ``schur_dofs``: keep the whole factorisation so that
        :meth:`solve` still solves ``K x = b`` (PARDISO's ``iparm[35] = 2``);
        otherwise only :attr:`schur` is available. The factor then ends
        with the dense Schur block, so a solve costs more than with a plain
        factorisation (+25% measured on a 116k-DOF tooth pair with 5,042
        Schur DOFs), while the factorisation costs the same as a
        Schur-only one.
    """

    def __init__(self, K: sp.spmatrix, schur_dofs: np.ndarray | None = None,
                 keep_factor: bool = False) -> None:
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
        self.solvable = schur_dofs is None or keep_factor
        ns = 0
        if schur_dofs is not None:
            ns = len(schur_dofs)
            if ns == 0:
                raise ValueError("schur_dofs is empty: give at least one DOF, or None")
            self._perm[np.asarray(schur_dofs)] = 1
            # dense Schur complement returned in x; 2: the factorisation also
            # solves the full system (phases 331, 332, 333 or 33)
            self._iparm[35] = 2 if keep_factor else 1
        self._released = False
        self._dense: np.ndarray | None = None
        if ns == self.n:
            # Every DOF in the Schur block (a model of rigid bodies only): S is K
            # itself. MKL PARDISO's Schur path with an empty interior reads out of
            # bounds (a segfault in mkl_pds_permutetips, seen on a 1-DOF model,
            # depending on the heap's layout), so it is not called.
            self.schur = K.toarray()
            self._dense = self.schur.copy() if keep_factor else None
            self.factor_nnz = (self.n * (self.n + 1)) // 2
            self._released = True    # nothing held by PARDISO
            return
        out = np.zeros(ns * ns if ns else 1)
        self._call(12, np.zeros(1), out)
        if ns:
            self.schur = out.reshape(ns, ns)
        self.factor_nnz = int(self._iparm[17])

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
        if not self.solvable:
            raise RuntimeError("a Schur-complement factorisation without keep_factor=True "
                               "cannot solve full systems")
        if self._dense is not None:
            return np.linalg.solve(self._dense, np.asarray(b, dtype=float))
        if self._released:
            raise RuntimeError("this factorisation was released")
        b = np.asfortranarray(b, dtype=float)
        x = np.zeros_like(b)
        self._call(33, b, x)
        return np.ascontiguousarray(x)

    def forward(self, b: np.ndarray) -> np.ndarray:
        """Forward substitution (PARDISO phase 331) of a kept Schur factorisation.

        The result's Schur-DOF entries are the right-hand side ``y_s`` of the
        Schur system ``S x_s = y_s``; with ``x_s`` written back in their place,
        :meth:`backward` gives the solution of ``K x = b``. A right-hand side
        on the Schur DOFs alone passes unchanged (its interior part is zero).
        """
        if self._iparm[35] != 2:
            raise RuntimeError("forward/backward need a Schur factorisation with keep_factor")
        b = np.asfortranarray(b, dtype=float)
        if self._dense is not None:   # no interior DOFs: y = b
            return b.copy(order="F")
        y = np.zeros_like(b)
        self._call(331, b, y)
        return y

    def backward(self, y: np.ndarray) -> np.ndarray:
        """Backward substitution (phase 333) from :meth:`forward`'s result with the
        Schur DOFs' solution in place."""
        y = np.asfortranarray(y, dtype=float)
        if self._dense is not None:   # no interior DOFs: x = y
            return np.ascontiguousarray(y)
        x = np.zeros_like(y)
        self._call(333, y, x)
        return np.ascontiguousarray(x)

    def release(self) -> None:
        """Free PARDISO's memory (also done on garbage collection)."""
        self._dense = None
        if not self._released:
            self._call(-1, np.zeros(1), np.zeros(1))
            self._released = True

    def __del__(self) -> None:
        try:
            self.release()
        except Exception:  # interpreter shutdown: nothing sensible to do
            pass


#: Rows of a dense Cholesky factorisation above which it runs on one BLAS
#: thread (:func:`schur_cholesky`).
THREADED_CHOLESKY_LIMIT = 4096


def schur_cholesky(S: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of a Schur complement returned by :class:`SPDSolver`.

    ``S`` is overwritten when it is C-ordered (as :attr:`SPDSolver.schur`
    is): LAPACK reads the lower triangle of its transposed, Fortran-ordered
    view, the same matrix since PARDISO returns ``S`` exactly symmetric, and
    no copy is made.

    OpenBLAS's threaded Cholesky crashes (SIGSEGV in its threaded rank-k
    update) on large matrices, a known fault of several of its releases
    (OpenBLAS issues 352, 1413, 2821): a 238k-DOF corner contact's condensed
    zone crashed ``fe-impact`` on two threads and runs on one. Above
    :data:`THREADED_CHOLESKY_LIMIT` rows the factorisation therefore runs on one
    BLAS thread (the calibration's workers run on one anyway).

    Raises
    ------
    SolverError
        If ``S`` is not positive definite.
    """
    from scipy.linalg import lapack
    from threadpoolctl import threadpool_limits

    if S.size == 0:
        return np.zeros((0, 0))
    single = threadpool_limits(1, user_api="blas") if len(S) > THREADED_CHOLESKY_LIMIT \
        else contextlib.nullcontext()
    with single:
        c, info = lapack.dpotrf(S.T if S.flags.c_contiguous else S, lower=1, clean=1,
                                overwrite_a=1)
    if info != 0:
        raise SolverError("the condensed contact stiffness is not positive definite: "
                          "a body touching the contact zone is not supported")
    return c


def inverse_from_cholesky(c: np.ndarray) -> np.ndarray:
    """``(L L^T)^-1`` from the lower Cholesky factor ``L``; ``c`` is overwritten.

    LAPACK potri (about 6x faster than ``inv()``) fills the lower triangle;
    the upper one is copied from it in column blocks, in place. The result
    is returned C-ordered (the transposed view of the exactly symmetric
    Fortran-ordered array): a sparse matrix times it is 7x faster than times
    the Fortran-ordered one (0.14 against 0.99 s at 5,042 x 5,042).
    """
    from scipy.linalg import lapack

    if c.size == 0:
        return c
    G, info = lapack.dpotri(c, lower=1, overwrite_c=1)
    if info != 0:
        raise SolverError(f"inverting the condensed contact stiffness failed (info {info})")
    return _mirror_lower(G).T


def _mirror_lower(G: np.ndarray, block: int = 512) -> np.ndarray:
    """Copy the lower triangle of square ``G`` onto its upper one, in place.

    Block by block (0.19 s at 5,042 x 5,042, where ``tril(G) + tril(G, -1).T``
    took 0.81 s and three temporaries of the size of ``G``).
    """
    n = G.shape[0]
    for j0 in range(0, n, block):
        j1 = min(j0 + block, n)
        d = G[j0:j1, j0:j1]
        d[np.triu_indices(j1 - j0, 1)] = d.T[np.triu_indices(j1 - j0, 1)]
        G[j0:j1, j1:] = G[j1:, j0:j1].T
    return G


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
    return schur_cholesky(S)


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
    return inverse_from_cholesky(condensed_cholesky(K, dofs))


# -- sparse products -------------------------------------------------------------------

class _MatrixDescr(ctypes.Structure):
    """MKL's ``struct matrix_descr`` (type, fill mode, diagonal)."""

    _fields_ = [("type", ctypes.c_int), ("mode", ctypes.c_int), ("diag", ctypes.c_int)]


_SPARSE_INDEX_BASE_ZERO = 0
_SPARSE_OPERATION_NON_TRANSPOSE = 10
_GENERAL = _MatrixDescr(20, 42, 50)   # general matrix (full storage, non-unit diagonal)
_SPARSE_MEMORY_NONE = 80              # the analysis keeps no copy of its own (as fast here)


@functools.cache
def _mkl_sparse() -> ctypes.CDLL | None:
    """MKL's inspector-executor sparse BLAS with its argument types, or None if the
    runtime lacks it (then :class:`SparseProduct` uses scipy)."""
    try:
        lib = _mkl_rt()
        vp, i32 = ctypes.c_void_p, ctypes.c_int32
        lib.mkl_sparse_d_create_csr.argtypes = [ctypes.POINTER(vp), ctypes.c_int, i32, i32,
                                                vp, vp, vp, vp]
        lib.mkl_sparse_set_mv_hint.argtypes = [vp, ctypes.c_int, _MatrixDescr, i32]
        lib.mkl_sparse_set_memory_hint.argtypes = [vp, ctypes.c_int]
        lib.mkl_sparse_optimize.argtypes = [vp]
        lib.mkl_sparse_d_mv.argtypes = [ctypes.c_int, ctypes.c_double, vp, _MatrixDescr, vp,
                                        ctypes.c_double, vp]
        lib.mkl_sparse_destroy.argtypes = [vp]
        lib.MKL_Set_Num_Threads_Local.argtypes = [ctypes.c_int]
        for f in ("mkl_sparse_d_create_csr", "mkl_sparse_set_mv_hint",
                  "mkl_sparse_set_memory_hint", "mkl_sparse_optimize", "mkl_sparse_d_mv",
                  "mkl_sparse_destroy", "MKL_Set_Num_Threads_Local"):
            getattr(lib, f).restype = ctypes.c_int
    except (OSError, AttributeError, ImportError) as exc:
        logger.debug("MKL's sparse BLAS is not available (%s): scipy's products", exc)
        return None
    return lib


class SparseProduct:
    """``A @ x`` for a fixed sparse matrix and many vectors ``x``.

    MKL's inspector-executor sparse BLAS analyses the matrix once
    (``mkl_sparse_optimize`` with the expected number of products, asked to
    keep no copy of its own) and then streams it faster than scipy's
    CSR loop: on the explicit benchmark's stiffness (16,440 DOFs, 1.1M
    nonzeros, one core) 0.44 ms a product against 0.75 ms, 0.90 times the
    bandwidth bound of the CSR arrays; on a 117k-DOF tooth pair's (9.1M
    nonzeros, out of cache) 5.3 ms against 6.8 ms, after 0.07 s of analysis.
    Falls back to scipy where MKL's sparse BLAS is missing or refuses the
    matrix, and for anything but one vector.

    A product runs on ``threads`` MKL threads whatever the process's setting:
    on two cores, MKL's second thread made the explicit benchmark's step 1.4-1.8
    times slower than on one (its threads spin between the short products and
    take the core the step's other work runs on).

    Parameters
    ----------
    A : sparse matrix, shape (n, m)
        Made CSR with sorted 32-bit indices and float64 values, which MKL
        reads in place.
    calls : int
        Expected number of products (MKL's hint: how much analysis pays).
    threads : int
        MKL threads of a product.
    copy : bool
        Copy ``A`` first, so that the caller may change it later; without, a
        float64 CSR ``A`` is shared (its indices sorted in place) and must
        not be changed (the solvers' own matrices: no second copy of a
        stiffness that can take a few hundred MB).
    """

    def __init__(self, A: sp.spmatrix, calls: int = 1000, threads: int = 1,
                 copy: bool = True) -> None:
        A = sp.csr_matrix(A, dtype=np.float64, copy=copy)
        A.sum_duplicates()            # canonical: sorted indices, no duplicates
        self.A, self.shape, self._calls, self._threads = A, A.shape, calls, threads
        self._copy = copy
        self._indptr = A.indptr.astype(np.int32, copy=False)
        self._indices = A.indices.astype(np.int32, copy=False)
        self._handle: ctypes.c_void_p | None = None
        lib = _mkl_sparse()
        if lib is None or A.nnz == 0 or A.nnz > np.iinfo(np.int32).max:
            return
        h = ctypes.c_void_p()
        status = lib.mkl_sparse_d_create_csr(
            ctypes.byref(h), _SPARSE_INDEX_BASE_ZERO, self.shape[0], self.shape[1],
            self._indptr.ctypes.data, self._indptr.ctypes.data + 4,
            self._indices.ctypes.data, A.data.ctypes.data)
        if status != 0:
            logger.debug("mkl_sparse_d_create_csr: status %d; scipy's products", status)
            return
        self._handle = h
        status = (lib.mkl_sparse_set_mv_hint(h, _SPARSE_OPERATION_NON_TRANSPOSE, _GENERAL,
                                             max(int(calls), 1))
                  or lib.mkl_sparse_set_memory_hint(h, _SPARSE_MEMORY_NONE)
                  or lib.mkl_sparse_optimize(h))
        if status != 0:
            logger.debug("mkl_sparse_optimize: status %d; scipy's products", status)
            self.release()

    @property
    def uses_mkl(self) -> bool:
        return self._handle is not None

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x)
        if self._handle is None or x.ndim != 1 or x.shape[0] != self.shape[1]:
            return self.A @ x
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.empty(self.shape[0])
        lib = _mkl_sparse()
        before = lib.MKL_Set_Num_Threads_Local(self._threads)
        try:
            status = lib.mkl_sparse_d_mv(_SPARSE_OPERATION_NON_TRANSPOSE, 1.0, self._handle,
                                         _GENERAL, x.ctypes.data, 0.0, y.ctypes.data)
        finally:
            lib.MKL_Set_Num_Threads_Local(before)
        if status != 0:
            raise SolverError(f"sparse product failed: MKL status {status}")
        return y

    def release(self) -> None:
        """Free MKL's analysis (also done on garbage collection)."""
        if self._handle is not None:
            _mkl_sparse().mkl_sparse_destroy(self._handle)
            self._handle = None

    def __del__(self) -> None:
        try:
            self.release()
        except Exception:  # interpreter shutdown: nothing sensible to do
            pass

    def __reduce__(self):
        return SparseProduct, (self.A, self._calls, self._threads, self._copy)
