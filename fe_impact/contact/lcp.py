"""Penalty contact forces as a linear complementarity problem.

With the contact compliance ``C = B G B^T`` of the points' gaps (``G`` the
compliance of the DOFs ``B`` reads, condensed from the stiffness) and the
penalty law ``lambda = eps w <-g>``, the forces solve a small dense LCP;
:func:`solve_penalty_lcp` serves the static solver's contact iterations and
the Newmark step's condensed contact.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import nnls

logger = logging.getLogger(__name__)


def solve_penalty_lcp(B: sp.csr_matrix | None, G: np.ndarray | None, h: np.ndarray,
                      eps_w: np.ndarray, active: np.ndarray | None = None,
                      max_iter: int = 60, C: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Contact forces with ``lam = eps_w <-(h + C lam)>_+``, ``C = B G B^T``.

    This is the linear complementarity problem ``0 <= lam _|_ M lam + h >= 0``
    with ``M = C + diag(1/eps_w)`` symmetric positive definite, solved by a
    primal-dual active set (semismooth Newton) method; if that cycles, by
    non-negative least squares on the Cholesky factor, which is exact.

    Contact forces push the bodies apart, so a point whose gap ``h`` is open
    before contact forces act rarely closes: the problem is solved on the
    points with ``h`` below a small margin, and the others are checked
    afterwards and added if they do penetrate.

    Parameters
    ----------
    active : bool array, optional
        Warm start for the active set (from a previous iteration).
    C : ndarray, optional
        ``B G B^T`` if already known (then ``B`` and ``G`` are not used).

    Returns
    -------
    lam : ndarray
        Forces (N) at the points.
    iterations : int
        Active-set iterations.
    """
    n = len(h)
    lam = np.zeros(n)
    if n == 0:
        return lam, 0
    margin = 0.05 * max(-h.min(), 0.0)
    rows = h < margin
    if active is not None:
        rows |= active
    total = 0
    while True:
        idx = np.flatnonzero(rows)
        if C is None:
            BG = B[idx] @ G
            Cs = np.asarray(B[idx] @ BG.T).T
        else:
            Cs = C[np.ix_(idx, idx)]
        sub, its = _active_set(Cs, h[idx], eps_w[idx],
                               None if active is None else active[idx], max_iter)
        total += its
        lam[:] = 0.0
        lam[idx] = sub
        rest = np.flatnonzero(~rows)
        if len(rest) == 0:
            return lam, total
        w_rest = h[rest] + (B[rest] @ (BG.T @ sub) if C is None else C[np.ix_(rest, idx)] @ sub)
        missed = rest[w_rest < 0]
        if len(missed) == 0:
            return lam, total
        rows[missed] = True


def _active_set(C: np.ndarray, h: np.ndarray, eps_w: np.ndarray, active, max_iter: int):
    n = len(h)
    M = 0.5 * (C + C.T)
    M[np.diag_indices(n)] += 1.0 / eps_w
    active = (h < 0) if active is None else active.copy()
    for it in range(1, max_iter + 1):
        lam = np.zeros(n)
        if active.any():
            idx = np.flatnonzero(active)
            lam[idx] = sla.solve(M[np.ix_(idx, idx)], -h[idx], assume_a="pos")
        w = M @ lam + h
        new = (active & (lam > 0)) | (~active & (w < 0))
        if np.array_equal(new, active):
            return np.maximum(lam, 0.0), it
        active = new
    logger.debug("active-set iteration cycled; using NNLS")
    L = np.linalg.cholesky(M)
    lam, _ = nnls(L.T, -sla.solve_triangular(L, h, lower=True))
    return lam, max_iter
