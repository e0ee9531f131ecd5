"""Coulomb friction on the penalty contact: the law, the slip Jacobians, the frictional problem.

Law
---
At each weighted slave node ``a`` (the rows of
:class:`~fe_impact.contact.surfaces.GapState`) the normal force is the penalty
``lambda_a = eps w_a <-g_a>``. The tangential force ``t_a`` (a vector in the
node's tangent plane, acting on the slave and, opposite, on the master) follows
the penalty-regularised Coulomb law by a return mapping (Wriggers,
Computational Contact Mechanics, 2nd ed., 2006, sections 5.2 and 10.4; Laursen,
2002, ch. 5):

- trial (stick): ``t_tr = t_n - eps_t w_a ds``, ``ds`` the slip increment of
  the step, the tangential part of the relative displacement of the slave node
  and its master point, measured with the current projection (the current
  configuration);
- ``|t_tr| <= mu lambda``: stick, ``t = t_tr``; else slip,
  ``t = mu lambda t_tr / |t_tr|``, and the step dissipates
  ``mu lambda (|t_tr| - mu lambda) / (eps_t w_a)``.

The seed's eqs. 9-10 (``F_t = -mu F_n sgn(v12)``) are this law with the
elastic stick of the penalty in place of the sign's jump at zero slip speed.
The coefficient falls from ``mu_static`` at zero slip speed to
``mu_dynamic`` at ``transition_speed`` and above, by the ADAMS STEP cubic
(:func:`coefficient`; the lumped switching model's transition,
:func:`fe_impact.switching._kernel.friction_coefficient`). A static analysis
has no slip speed: it takes ``mu_static``.

The tangential penalty equals the normal one (``eps_t = eps``): its stick
compliance ``1 / (eps w)`` per node is then the normal penetration's share
of the approach (well below 1% at the automatic penalties).

Problem
-------
An implicit solve (static or Newmark) gives the contact-free gaps ``h`` and
slip increments ``s0`` of the rows and their compliance ``D`` (the Delassus
matrix of the normal and two tangential rows of every node). The forces
``p = (lambda, t1, t2)`` solve ``p = F(y0 + D p)``, ``F`` the local law above;
:func:`solve_frictional` does it on the rows near contact only: one pass of
the alternation of the normal part (a penalty complementarity problem, solved
exactly) and the tangential part at fixed cones (a convex problem over discs, by
semismooth Newton on its scaled projection map: :func:`_tangential`) finds the
rows in contact and slipping, and a semismooth Newton on the whole problem
(:func:`_coupled_newton`) finishes; where that fails the alternation goes on.
On the Newmark run of bench_dynamic the coupled Newton took 1.5 steps where the
alternation took four passes (the frictional solves' time 0.15-0.19 -> 0.10-0.13 s
CPU, the run's energy error the same to 1e-13).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit

from fe_impact.contact.surfaces import ContactPair, tri_shape
from fe_impact.errors import ContactError
from fe_impact.fe.case import ContactSpec
from fe_impact.fe.mesh import FEMesh

logger = logging.getLogger(__name__)

#: The frictional Newton iteration stops when the residual is below this times
#: the forces' size (N); the return mapping itself is exact, so the forces'
#: error is that of the linear solves, far below the discretisation's.
NEWTON_TOL = 1e-10
#: Newton iterations before the problem is declared unsolved.
NEWTON_ITERATIONS = 60
#: The alternation of the normal and tangential parts stops when the forces change
#: by less than this times the largest normal force: far below the discretisation's
#: error (the penalty's own regularisation is of order 1e-3).
ALTERNATION_TOL = 1e-8


@dataclass(frozen=True)
class FrictionLaw:
    """Coulomb coefficients of one contact pair.

    Attributes
    ----------
    mu_static, mu_dynamic : float
        Coefficients [-] at zero slip speed and at ``transition_speed`` and above.
    transition_speed : float
        Slip speed [m/s] over which the coefficient blends from static to dynamic.
    """

    mu_static: float
    mu_dynamic: float
    transition_speed: float

    @classmethod
    def of(cls, spec: ContactSpec) -> FrictionLaw | None:
        """The law of a case's contact pair (None: frictionless)."""
        if not spec.friction:
            return None
        return cls(spec.mu_static, spec.mu_dynamic, spec.transition_speed)

    def coefficient(self, speed: np.ndarray | float) -> np.ndarray:
        """``mu`` at the slip speed ``speed`` (m/s, >= 0): ADAMS STEP from
        ``mu_static`` at 0 to ``mu_dynamic`` at :attr:`transition_speed`."""
        x = np.clip(np.asarray(speed, dtype=float) / self.transition_speed, 0.0, 1.0)
        return self.mu_static + (self.mu_dynamic - self.mu_static) * x * x * (3.0 - 2.0 * x)


def pair_laws(specs) -> list[FrictionLaw | None]:
    """The friction law of each contact spec (None where frictionless)."""
    return [FrictionLaw.of(s) for s in specs]


def tangent_frames(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents ``t1, t2`` (each (n, 3)) with ``(n, t1, t2)`` right-handed."""
    n = np.asarray(normal, dtype=float)
    helper = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, helper)
    t1 /= np.maximum(np.linalg.norm(t1, axis=1), 1e-300)[:, None]
    return t1, np.cross(n, t1)


def relative_jacobian(pair: ContactPair, mesh: FEMesh, u: np.ndarray, slave_faces: np.ndarray,
                      master_faces: np.ndarray) -> sp.csr_matrix:
    """``d r_a / d u`` of each weighted slave node, all three components in one matrix.

    Called right after :meth:`ContactPair.gap_state` of the same configuration,
    it takes that call's projection (the pair keeps it as the next one's hint).

    ``r_a = int phi_a (u_s - u_m) dA / A_a``: the relative displacement of the
    slave and its closest master point (projected in the configuration
    ``X + u``), weighted as the gap of :meth:`ContactPair.gap_state` is, so its
    rows are those of the gap state (a node with no valid projection has a
    zero row). The matrix is (n_nodes, n_dofs): the entry at DOF ``3 p + d`` is
    the weight of node ``p``'s component ``d`` in ``r_a``'s component ``d`` (the
    same for the three components; :func:`slip_jacobians` projects it on the
    tangents).
    """
    x = mesh.points + u
    lay, proj = pair.projected_layout(mesh, x, slave_faces, master_faces)
    Nm, _ = tri_shape(proj.xi, proj.eta, pair.master.nodes_per_face)
    Wv = lay.W.copy()
    Wv.data = Wv.data * proj.valid[Wv.indices]
    valid_area = np.asarray(Wv.sum(axis=1)).ravel()
    ok = valid_area > 1e-3 * lay.area
    Wn = sp.diags(np.where(ok, 1.0 / np.where(ok, valid_area, 1.0), 0.0)) @ Wv
    nodes = np.concatenate([lay.snodes, pair.master.faces[proj.face]], axis=1)   # (q, a)
    coef = np.concatenate([lay.Ns, -Nm], axis=1) * proj.valid[:, None]
    nq, na = nodes.shape
    ndof = 3 * (mesh.point_dof.max() + 1)
    cols = (3 * mesh.point_dof[nodes])[:, :, None] + np.arange(3)                # (q, a, 3)
    data = np.broadcast_to(coef[:, :, None], cols.shape)
    indptr = np.arange(0, 3 * nq * na + 1, 3 * na)
    Bq = sp.csr_matrix((data.ravel(), cols.ravel(), indptr), shape=(nq, ndof))
    return (Wn @ Bq).tocsr()


def slip_jacobians(J: sp.csr_matrix, t1: np.ndarray, t2: np.ndarray
                   ) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """The tangential rows ``t_k . J`` of each node's relative displacement (``J`` of
    :func:`relative_jacobian`: each entry scaled by its row's tangent component)."""
    J = J.tocsr()
    rows = np.repeat(np.arange(J.shape[0]), np.diff(J.indptr))
    d = J.indices % 3
    return tuple(sp.csr_matrix((J.data * t[rows, d], J.indices.copy(), J.indptr.copy()),
                               shape=J.shape) for t in (t1, t2))


def local_law(y: np.ndarray, eps_n: np.ndarray, eps_t: np.ndarray, mu: np.ndarray,
              t_old: np.ndarray, jacobian: bool = False):
    """Forces ``F(y)`` of the rows and, with ``jacobian``, ``dF/dy`` (dense).

    ``y = (g, s1, s2)`` stacked (3 r): gaps and slip increments (m);
    ``t_old``: (r, 2) tangential forces at the step's start (N).
    Returns ``p = (lambda, t1, t2)`` stacked, ``slipping`` (bool, r) and,
    with ``jacobian``, the (3 r, 3 r) derivative.
    """
    r = len(eps_n)
    g, s = y[:r], np.stack([y[r:2 * r], y[2 * r:]], axis=1)
    closed = g < 0.0
    lam = np.where(closed, -eps_n * g, 0.0)
    t_tr = t_old - eps_t[:, None] * s
    norm = np.linalg.norm(t_tr, axis=1)
    cap = mu * lam
    slipping = norm > cap
    scale = np.where(slipping, cap / np.maximum(norm, 1e-300), 1.0)
    t = t_tr * scale[:, None]
    p = np.concatenate([lam, t[:, 0], t[:, 1]])
    if not jacobian:
        return p, slipping
    A = np.zeros((3 * r, 3 * r))
    i = np.arange(r)
    dlam = np.where(closed, -eps_n, 0.0)
    A[i, i] = dlam
    e = t_tr / np.maximum(norm, 1e-300)[:, None]
    for a in range(2):
        for b in range(2):
            stick = -eps_t * (a == b)
            slip = -eps_t * scale * ((a == b) - e[:, a] * e[:, b])
            A[(a + 1) * r + i, (b + 1) * r + i] = np.where(slipping, slip, stick)
        A[(a + 1) * r + i, i] = np.where(slipping, mu * e[:, a] * dlam, 0.0)
    return p, slipping, A


@dataclass(frozen=True, eq=False)
class FrictionalSolution:
    """Forces of the rows and how they were found."""

    lam: np.ndarray         # (r,) normal forces, N
    t: np.ndarray           # (r, 2) tangential forces in the rows' (t1, t2), N
    slipping: np.ndarray    # (r,) bool: the row slips (in contact, at the cone)
    iterations: int

    @property
    def forced(self) -> np.ndarray:
        """(r,) bool: the rows with a normal or a tangential force."""
        return (self.lam > 0) | np.any(self.t != 0.0, axis=1)


def solve_frictional(D: np.ndarray, h: np.ndarray, s0: np.ndarray, eps_n: np.ndarray,
                     eps_t: np.ndarray, mu: np.ndarray, t_old: np.ndarray,
                     rows: np.ndarray | None = None,
                     warm: FrictionalSolution | None = None) -> FrictionalSolution:
    """The forces with ``p = F(y0 + D p)`` (see the module docstring).

    Parameters
    ----------
    D : callable or ndarray
        ``D(idx)``: the (3 k, 3 k) compliance of the rows ``idx`` stacked as
        (normal, t1, t2), and ``D(idx, other)`` the normal gaps' change of the
        rows ``other`` per force on ``idx``, (k', 3 k); or the whole (3 r, 3 r)
        matrix.
    h, s0 : ndarray
        Contact-free gaps (r,) and slip increments (r, 2), m.
    eps_n, eps_t : ndarray
        Normal and tangential penalties times the nodes' areas (N/m), (r,).
    mu : ndarray
        Coefficients (r,).
    t_old : ndarray
        Tangential forces at the step's start (r, 2), N.
    rows : ndarray, optional
        Rows to start from (default: those with ``h`` below a small margin
        or a force at the start); others whose gaps the forces close are added.
    warm : FrictionalSolution, optional
        A solution of a nearby problem on the same rows (the last projection's):
        its rows in contact join the start and its forces start the iteration.
    """
    r = len(h)
    if callable(D):
        block = D
    else:
        def block(idx, other=None):
            st = np.concatenate([idx, r + idx, 2 * r + idx])
            if other is None:
                return D[np.ix_(st, st)]
            return D[np.ix_(other, st)]
    lam = np.zeros(r)
    t = np.zeros((r, 2))
    slipping = np.zeros(r, dtype=bool)
    if r == 0:
        return FrictionalSolution(lam, t, slipping, 0)
    margin = 0.05 * max(-float(h.min()), 0.0)
    cand = (h < margin) | np.any(t_old != 0.0, axis=1)
    if rows is not None:
        cand[rows] = True
    p_warm = None
    if warm is not None and len(warm.lam) == r:
        cand |= warm.lam > 0
        idx = np.flatnonzero(cand)
        p_warm = np.concatenate([warm.lam[idx], warm.t[idx, 0], warm.t[idx, 1]])
    total = 0
    while True:
        idx = np.flatnonzero(cand)
        Dc = block(idx)
        y0 = np.concatenate([h[idx], s0[idx, 0], s0[idx, 1]])
        p, sl, its = _newton(Dc, y0, eps_n[idx], eps_t[idx], mu[idx], t_old[idx], p_warm)
        total += its
        k = len(idx)
        rest = np.flatnonzero(~cand)
        if len(rest):
            g = h[rest] + block(idx, rest) @ p
            missed = rest[g < 0.0]
        else:
            missed = rest
        if len(missed) == 0:
            lam[idx], t[idx, 0], t[idx, 1] = p[:k], p[k:2 * k], p[2 * k:]
            slipping[idx] = sl
            return FrictionalSolution(lam, t, slipping, total)
        # warm start: the found forces, zero on the added rows
        new = np.zeros(r * 3)
        new[idx], new[r + idx], new[2 * r + idx] = p[:k], p[k:2 * k], p[2 * k:]
        cand[missed] = True
        idx2 = np.flatnonzero(cand)
        p_warm = np.concatenate([new[idx2], new[r + idx2], new[2 * r + idx2]])


def _newton(D, y0, eps_n, eps_t, mu, t_old, p0=None):
    """The forces of ``p = F(y0 + D p)`` on a set of rows, by alternating the two
    halves of the problem (Panagiotopoulos' decomposition; Wriggers 2006, section
    10.4):

    - normal, at fixed tangential forces: the penalty complementarity problem
      on ``D_nn`` (:func:`~fe_impact.contact.lcp.solve_penalty_lcp`, exact);
    - tangential, at fixed cones ``mu lambda``: an associated return mapping,
      solved by semismooth Newton (:func:`_tangential`).

    The halves couple through ``D_nt``, the normal gap's response to a tangential
    force, small between similar materials, so a few alternations settle it.
    Returns the forces, the rows slipping and the iterations (Newton's, summed).
    """
    from fe_impact.contact.lcp import solve_penalty_lcp

    n = len(y0)
    if n == 0:
        return np.zeros(0), np.zeros(0, dtype=bool), 0
    r = n // 3
    N, T = slice(0, r), slice(r, n)
    lam = np.zeros(r) if p0 is None else p0[N].copy()
    t = np.zeros(2 * r) if p0 is None else p0[T].copy()
    total = 0
    for k in range(NEWTON_ITERATIONS):
        if k == 1:
            # one alternation found the sets near enough: the coupled semismooth
            # Newton finishes in a step or two (the alternation goes on if it fails;
            # from the warm start alone it took five)
            done = _coupled_newton(D, y0, eps_n, eps_t, mu, t_old, np.concatenate([lam, t]))
            if done is not None:
                return done[0], done[1], total + done[2]
        lam_new, its = solve_penalty_lcp(None, None, y0[N] + D[N, T] @ t, eps_n,
                                         lam > 0, C=D[N, N])
        total += its
        t_new, slipping, its = _tangential(D[T, T], y0[T] + D[T, N] @ lam_new, eps_t,
                                           mu * lam_new, t_old, t)
        total += its
        change = max(float(np.abs(lam_new - lam).max()), float(np.abs(t_new - t).max()))
        size = max(float(np.abs(lam_new).max()), 1e-300)
        lam, t = lam_new, t_new
        if change <= ALTERNATION_TOL * size:
            return np.concatenate([lam, t]), slipping, total
    raise ContactError(f"the frictional contact problem did not settle in "
                       f"{NEWTON_ITERATIONS} alternations of its normal and tangential "
                       f"parts (last change {change:.3g} of {size:.3g} N): apply the load in "
                       "smaller steps")


#: Iterations of the coupled Newton (:func:`_coupled_newton`) before it gives way to
#: the alternation.
COUPLED_ITERATIONS = 8


def _coupled_newton(D, y0, eps_n, eps_t, mu, t_old, p0):
    """The forces of ``p = F(y0 + D p)`` by semismooth Newton on the whole problem,
    from ``p0`` (the alternation's first pass); None if it does not converge in
    :data:`COUPLED_ITERATIONS` steps with a decreasing residual.

    The two halves' maps of :func:`_newton` taken together, each row scaled by its
    own compliance as :func:`_tangential` does (Alart and Curnier 1991):

    - normal: ``lambda = max(0, lambda - rho_n (y_n + D_n. p + lambda / eps_n))``,
      ``rho_n = 1 / (D_ii + 1 / eps_n)``: the penalty law ``lambda = eps_n <-g>``;
    - tangential: ``t = P_{mu lambda}(t - rho_t (y_t + D_t. p + (t - t_old) /
      eps_t))``, the return mapping of :func:`_tangential` with the cone's radius
      now an unknown.

    Its fixed point is the alternation's; converged when the residual is below
    :data:`NEWTON_TOL` times the forces' size. Returns the forces, the rows
    slipping and the iterations.
    """
    n = len(y0)
    r = n // 3
    N, T = slice(0, r), slice(r, n)
    e2 = np.concatenate([eps_t, eps_t])
    Mn = D[N].copy()
    Mn[:, :r] += np.diag(1.0 / eps_n)
    Mt = D[T].copy()
    Mt[:, r:] += np.diag(1.0 / e2)
    qt = y0[T] - np.concatenate([t_old[:, 0], t_old[:, 1]]) / e2
    rho_n = 1.0 / np.diag(Mn[:, :r])
    dt = np.diag(Mt[:, r:])
    rho = 1.0 / (0.5 * (dt[:r] + dt[r:]))
    rho_t = np.concatenate([rho, rho])
    i = np.arange(r)
    # d u / d p, u the tangential map's argument (constant)
    Gt = -rho_t[:, None] * Mt
    Gt[np.arange(2 * r), r + np.arange(2 * r)] += 1.0
    Gn = rho_n[:, None] * Mn

    def residual(p):
        lam = p[N]
        an = lam - rho_n * (y0[N] + Mn @ p)
        closed = an > 0.0
        u = (p[T] - rho_t * (Mt @ p + qt)).reshape(2, r).T
        norm = np.linalg.norm(u, axis=1)
        cap = mu * np.maximum(lam, 0.0)
        slip = norm > cap
        scale = np.where(slip, cap / np.maximum(norm, 1e-300), 1.0)
        F_t = (u * scale[:, None]).T.ravel()
        R = np.concatenate([lam - np.where(closed, an, 0.0), p[T] - F_t])
        return R, (closed, slip, scale, u / np.maximum(norm, 1e-300)[:, None], cap)

    def size(p, cap):
        return max(float(np.linalg.norm(p)), float(cap.max(initial=0.0)), 1e-300)

    p = p0.copy()
    R, state = residual(p)
    res = float(np.linalg.norm(R))
    for it in range(1, COUPLED_ITERATIONS + 1):
        closed, slip, scale, e, cap = state
        if res <= NEWTON_TOL * size(p, cap):
            return p, slip, it - 1
        J = np.zeros((n, n))
        # normal rows: closed, R = rho_n g (d/dp = rho_n Mn); open, R = lambda
        J[:r] = np.where(closed[:, None], Gn, 0.0)
        J[i, i] += np.where(closed, 0.0, 1.0)
        # tangential rows: R = t - P(u, mu lambda)
        A = [np.where(slip, scale * ((a == b) - e[:, a] * e[:, b]), float(a == b))
             for a in range(2) for b in range(2)]
        G1, G2 = Gt[:r], Gt[r:]
        J[r:2 * r] = -(A[0][:, None] * G1 + A[1][:, None] * G2)
        J[2 * r:] = -(A[2][:, None] * G1 + A[3][:, None] * G2)
        J[r + np.arange(2 * r), r + np.arange(2 * r)] += 1.0
        on = slip & (cap > 0.0)
        J[r + i, i] -= np.where(on, mu * e[:, 0], 0.0)
        J[2 * r + i, i] -= np.where(on, mu * e[:, 1], 0.0)
        try:
            d = -np.linalg.solve(J, R)
        except np.linalg.LinAlgError:
            return None
        step = 1.0
        for _ in range(10):
            R_new, state_new = residual(p + step * d)
            res_new = float(np.linalg.norm(R_new))
            if res_new < res:
                break
            step *= 0.5
        else:
            return None
        p, R, state, res = p + step * d, R_new, state_new, res_new
    closed, slip, scale, e, cap = state
    return (p, slip, COUPLED_ITERATIONS) if res <= NEWTON_TOL * size(p, cap) else None


def _tangential(D, y0, eps_t, cap, t_old, t0):
    """Tangential forces ``t = P_cap(t_old - eps_t (y0 + D t))`` at fixed cones (``P``:
    the projection on the discs of radius ``cap``).

    That is the optimality condition of the convex problem ``min 1/2 t.M t + q.t``
    over the discs, ``M = D + diag(1 / eps_t)``, ``q = y0 - t_old / eps_t``; its
    solutions are those of ``t = P_cap(t - rho (M t + q))`` for any ``rho > 0``.
    With ``eps_t`` (``rho = eps_t``) the map is badly scaled when the tangential
    penalty is much stiffer than the bodies at a node (``eps_t D_ii`` of several
    hundred at the automatic penalty: a force that overshoots reverses the trial's
    direction, and Newton's iterates flip from one side of the cone to the other);
    ``rho = 1 / M_ii`` makes each row's part of the map a contraction, and a
    semismooth Newton iteration on it converges in a few steps (the method of
    Alart and Curnier 1991 with a scaled parameter).
    """
    r = len(eps_t)
    M = D + np.diag(np.concatenate([1.0 / eps_t, 1.0 / eps_t]))
    q = y0 - np.concatenate([t_old[:, 0], t_old[:, 1]]) / np.concatenate([eps_t, eps_t])
    d = np.diag(M)
    rho = 1.0 / (0.5 * (d[:r] + d[r:]))            # one per row, both directions
    rho2 = np.concatenate([rho, rho])
    G = np.eye(2 * r) - rho2[:, None] * M          # du/dt
    G1, G2 = G[:r], G[r:]

    def law(t):
        """``F``, the rows slipping and ``dF/du``, each row's 2 x 2 block (a_11, a_12,
        a_21, a_22), the derivative being block-diagonal over the rows."""
        u = (t - rho2 * (M @ t + q)).reshape(2, r).T
        norm = np.linalg.norm(u, axis=1)
        slipping = norm > cap
        scale = np.where(slipping, cap / np.maximum(norm, 1e-300), 1.0)
        F = (u * scale[:, None]).T.ravel()
        e = u / np.maximum(norm, 1e-300)[:, None]
        A = [np.where(slipping, scale * ((a == b) - e[:, a] * e[:, b]), float(a == b))
             for a in range(2) for b in range(2)]
        return F, slipping, A

    def jacobian(A):
        """``I - dF/du du/dt`` (the block-diagonal ``dF/du`` applied row by row)."""
        AG = np.concatenate([A[0][:, None] * G1 + A[1][:, None] * G2,
                             A[2][:, None] * G1 + A[3][:, None] * G2])
        return eye - AG

    t = t0.copy()
    F, sl, A = law(t)
    R = t - F
    res = float(np.linalg.norm(R))
    eye = np.eye(2 * r)
    for it in range(1, NEWTON_ITERATIONS + 1):
        if res <= NEWTON_TOL * max(float(np.linalg.norm(F)), float(cap.max(initial=0.0)),
                                   1e-300):
            return t, sl, it - 1
        dt = -np.linalg.solve(jacobian(A), R)
        step = 1.0
        for _ in range(40):
            F_new, sl_new, A_new = law(t + step * dt)
            R_new = t + step * dt - F_new
            res_new = float(np.linalg.norm(R_new))
            if res_new < res:
                break
            step *= 0.5
        t, F, sl, A, R, res = t + step * dt, F_new, sl_new, A_new, R_new, res_new
    raise ContactError(f"the tangential contact problem did not converge in "
                       f"{NEWTON_ITERATIONS} Newton iterations (residual {res:.3g} N): apply "
                       "the load in smaller steps")


def slip_dissipation(t_trial_norm: np.ndarray, cap: np.ndarray, eps_t: np.ndarray
                     ) -> float:
    """Energy (J) the slipping rows dissipate in a step: ``cap (|t_tr| - cap) / eps_t``."""
    excess = np.maximum(t_trial_norm - cap, 0.0)
    return float(np.sum(cap * excess / np.where(eps_t > 0, eps_t, np.inf)))


def stored_energy(t: np.ndarray, eps_t: np.ndarray) -> float:
    """Elastic energy (J) of the tangential penalty springs: ``sum |t|^2 / (2 eps_t)``."""
    on = eps_t > 0
    return float(0.5 * np.sum(np.sum(t[on] ** 2, axis=1) / eps_t[on]))


class TangentialHistory:
    """The tangential force of each contact row at the last committed step, kept as a
    3-vector keyed by its pair and slave node, so that it survives re-projections
    (new tangent frames) and zone growth (new rows)."""

    def __init__(self) -> None:
        self.keys = np.zeros(0, dtype=np.int64)
        self.vectors = np.zeros((0, 3))

    def get(self, keys: np.ndarray, t1: np.ndarray, t2: np.ndarray) -> np.ndarray:
        """The rows' forces in their current tangent frames (r, 2), N (0 for new rows)."""
        vec = np.zeros((len(keys), 3))
        if len(self.keys):
            pos = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
            hit = self.keys[pos] == keys
            vec[hit] = self.vectors[pos[hit]]
        return np.stack([np.einsum("ij,ij->i", vec, t1), np.einsum("ij,ij->i", vec, t2)],
                        axis=1)

    def put(self, keys: np.ndarray, t1: np.ndarray, t2: np.ndarray, t: np.ndarray) -> None:
        """Commit the rows' forces ``t`` (r, 2) given in the frames ``t1``, ``t2``."""
        order = np.argsort(keys)
        self.keys = keys[order]
        self.vectors = (t1 * t[:, [0]] + t2 * t[:, [1]])[order]


def return_mapping(t_old: np.ndarray, ds: np.ndarray, lam: np.ndarray, eps_t: np.ndarray,
                   mu: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Tangential forces after the slip increments ``ds`` (r, 2) under the normal forces
    ``lam``: the stick trial ``t_old - eps_t ds`` returned to the cone ``mu lam``.

    Returns the forces (r, 2), the energy the step dissipates (J) and the rows
    slipping.
    """
    t_tr = t_old - eps_t[:, None] * ds
    norm = np.linalg.norm(t_tr, axis=1)
    cap = mu * lam
    slipping = norm > cap
    t = t_tr * np.where(slipping, cap / np.maximum(norm, 1e-300), 1.0)[:, None]
    return t, slip_dissipation(norm, cap, eps_t), slipping


@njit(cache=True)
def _explicit_return_mapping(t_old, ds, lam, eps_t, mu_s, mu_d, v_t, dt):
    """:func:`return_mapping` with each row's coefficient at its slip speed ``|ds| / dt``
    (:meth:`FrictionLaw.coefficient` from the rows' ``mu_s``, ``mu_d`` and transition
    speeds ``v_t``), row by row: the forces (r, 2), the energy dissipated (J), the
    tangential springs' energy (J, :func:`stored_energy`) and whether any force is
    nonzero."""
    r = len(lam)
    t = np.empty((r, 2))
    dissipated = 0.0
    stored = 0.0
    held = False
    for i in range(r):
        s0, s1 = ds[i, 0], ds[i, 1]
        x = min(max(np.sqrt(s0 * s0 + s1 * s1) / dt / v_t[i], 0.0), 1.0)
        mu = mu_s[i] + (mu_d[i] - mu_s[i]) * x * x * (3.0 - 2.0 * x)
        e = eps_t[i]
        a = t_old[i, 0] - e * s0
        b = t_old[i, 1] - e * s1
        norm = np.sqrt(a * a + b * b)
        cap = mu * lam[i]
        if norm > cap:
            scale = cap / max(norm, 1e-300)
            a *= scale
            b *= scale
            if e > 0.0:
                dissipated += cap * (norm - cap) / e
        t[i, 0] = a
        t[i, 1] = b
        if e > 0.0:
            stored += 0.5 * (a * a + b * b) / e
        if a != 0.0 or b != 0.0:
            held = True
    return t, dissipated, stored, held


class ExplicitFriction:
    """Friction of the explicit integrator: each step's return mapping from the slip
    increments of the step, committed at once.

    Attributes
    ----------
    dissipation : float
        Energy dissipated so far (J).
    stored : float
        Energy of the tangential penalty springs at the last step (J).
    """

    def __init__(self) -> None:
        self.history = TangentialHistory()
        self.dissipation = 0.0
        self.stored = 0.0
        # the last step's forces in the frames of the projection they were taken in
        self._t: np.ndarray | None = None
        self._projection = -1

    def forces(self, contact, z: np.ndarray, z_old: np.ndarray, lam: np.ndarray,
               dt: float) -> np.ndarray | None:
        """The tangential forces (r, 2) at ``z`` after a step of ``dt`` from ``z_old``
        (None while nothing touches and nothing is stored: no force).

        The forces are kept in the rows' frames while the projection stays; the
        history by pair and slave node carries them over a re-projection or the
        zone's growth.
        """
        r = len(lam)
        if self._projection != contact.n_projections:
            if self._t is not None:
                self.history.put(self._keys, self._t1, self._t2, self._t)
            else:
                self.history = TangentialHistory()     # nothing held: no force to carry
            self._keys, self._t1, self._t2 = contact.row_keys(), contact.t1, contact.t2
            self._t = self.history.get(self._keys, self._t1, self._t2) if len(
                self.history.keys) else None
            self._projection = contact.n_projections
        if self._t is None and not np.any(lam > 0.0):
            return None
        t_old = self._t if self._t is not None else np.zeros((r, 2))
        ds = contact.slips(z, z_old)
        mu_s, mu_d, v_t = self._laws(contact)
        # return_mapping with the coefficient at the step's slip speed, its dissipation
        # and the springs' energy, in one pass (the numpy calls cost 0.12 ms a step)
        t, dissipated, stored, held = _explicit_return_mapping(
            t_old, ds, lam, contact.eps_w, mu_s, mu_d, v_t, dt)
        self._t = t if held else None
        self.dissipation += dissipated
        self.stored = stored if held else 0.0
        return t

    def _laws(self, contact) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each row's ``mu_static``, ``mu_dynamic`` and transition speed (0, 0, 1 on a
        frictionless pair), kept for the projection."""
        if getattr(self, "_laws_at", None) != contact.n_projections:
            r = len(contact.row_law)
            mu_s, mu_d, v_t = np.zeros(r), np.zeros(r), np.ones(r)
            for k, law in enumerate(contact.laws):
                on = contact.row_law == k
                if law is not None:
                    mu_s[on], mu_d[on], v_t[on] = (law.mu_static, law.mu_dynamic,
                                                   law.transition_speed)
            self._law_rows = (mu_s, mu_d, v_t)
            self._laws_at = contact.n_projections
        return self._law_rows


class ImplicitFriction(ExplicitFriction):
    """Friction of an implicit (Newmark) step: the step's frictional problem is solved
    with the condensed contact (:meth:`~fe_impact.contact.condensed.CondensedContact.solve`),
    and :meth:`commit` stores its forces once the step is final.

    Attributes
    ----------
    dt : float
        The time step (s): slip speeds for the coefficient are slip increments over it.
    """

    def __init__(self, dt: float) -> None:
        super().__init__()
        self.dt = dt

    def start(self, contact) -> np.ndarray:
        """The rows' forces at the step's start, in the current frames (r, 2)."""
        return self.history.get(contact.row_keys(), contact.t1, contact.t2)

    def commit(self, contact, lam: np.ndarray, t: np.ndarray, z: np.ndarray,
               z_old: np.ndarray) -> None:
        """Store the step's forces and add the energy the friction dissipated in it.

        The dissipation is the work the friction forces did on the step's slip, by
        the integrator's own trapezoidal rule (``-(t_n + t_n+1) / 2 . ds``), less
        the change of the tangential springs' energy: the energy the step's
        mechanical balance lost to friction. (The return mapping's ``mu lambda
        |ds_p|`` agrees with it to first order in the step; on a coarse oblique
        impact of 200 steps it left 1.5e-3 of the energy unaccounted.)
        """
        r = len(lam)
        t_old = self.start(contact)
        ds = (contact.Bt @ (z - z_old)).reshape(2, r).T
        work = -0.5 * float(np.sum((t_old + t) * ds))
        eps = contact.eps_w
        stored = stored_energy(t, eps)
        self.dissipation += work - (stored - stored_energy(t_old, eps))
        self.history.put(contact.row_keys(), contact.t1, contact.t2, t)
        self.stored = stored
