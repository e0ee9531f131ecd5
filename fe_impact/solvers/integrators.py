"""Time integrators of the reduced equations of motion, as step functions.

    M z'' + K z = B^T lambda(z) + F_p(z)

(reduced coordinates ``z``, penalty contact forces ``lambda`` of a
:class:`~fe_impact.contact.linearised.ContactModel`, plastic force ``F_p``
of a :class:`~fe_impact.fe.plasticity.PlasticZone`). A step function takes
the :class:`State` after step ``n`` and returns the one after step ``n + 1``;
the contact model re-projects its gaps and the plastic zone commits its
history on the way, and nothing is written anywhere.

- :func:`central_difference_step`: explicit central difference (velocity
  Verlet) with a lumped mass; stable below :func:`stable_time_step`.
- :func:`newmark_step`: implicit Newmark average acceleration (beta = 1/4,
  gamma = 1/2; Newmark 1959), or HHT-alpha with ``alpha < 0`` (Hilber,
  Hughes and Taylor 1977); contact by the condensed complementarity problem
  of :class:`~fe_impact.contact.condensed.CondensedContact`, plasticity by
  :func:`plastic_newmark_solve`.
- :func:`time_step`: the case's time step, or the automatic one of either.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numba import njit

from fe_impact.contact.condensed import CondensedContact, StepContact
from fe_impact.contact.linearised import ContactModel
from fe_impact.errors import CaseError, ContactError, SolverError
from fe_impact.fe.case import Case
from fe_impact.fe.linalg import SparseProduct, SPDSolver

logger = logging.getLogger(__name__)

#: The explicit step re-projects the contact and watches the zone every this many steps.
CHECK_EVERY = 10
#: Automatic Newmark step: this many steps over the duration (at least), so a
#: contact lasting a third of the run is resolved by about 70 steps.
NEWMARK_STEPS = 200
#: A Newmark step's plasticity iteration stops when its residual is below this
#: times the step's displacement increment. Its error then stays far below the
#: time integration's (about 1e-3 of the peak force at t_c / 60): against 1e-7,
#: ``validation/plastic_impact.py --quick`` moved restitution, peak force and
#: dissipation by at most 2e-7 (relative) with 13-17% fewer GMRES products, and
#: the coarse stage-1 approach corner's first 40 steps the dissipation by 1.5e-7
#: with 21% fewer (744 -> 591); 1e-5 moved the peak force by 7e-6.
PLASTIC_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class State:
    """The solution after step ``n``, in reduced coordinates.

    Attributes
    ----------
    z, v, a : ndarray, shape (n_reduced,)
        Displacement (m), velocity (m/s) and acceleration (m/s^2).
    lam : ndarray
        Penalty forces (N) on the contact model's rows.
    strain_energy : float
        ``z K z / 2`` (J), without the plastic zone's correction.
    f_contact, f_plastic : ndarray, optional
        Newmark: ``B^T lam`` and the committed plastic force (N), which the
        HHT-alpha average of the next step needs.
    active : bool ndarray, optional
        Newmark: the contact rows in compression, the next step's warm start.
    Kz : ndarray, optional
        Newmark: ``K z`` (N), formed for the strain energy and reused by the
        next step (one stiffness product a step fewer).
    """

    n: int
    z: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    strain_energy: float = 0.0
    f_contact: np.ndarray | None = None
    f_plastic: np.ndarray | None = None
    active: np.ndarray | None = None
    Kz: np.ndarray | None = None
    #: friction: the rows' tangential forces (r, 2) in the contact model's frames, N
    t: np.ndarray | None = None


def time_step(case: Case, dt_stable: float | None) -> float:
    """The case's time step, or the automatic one.

    Explicit (``dt_stable`` given): ``[analysis] safety_factor`` x the stable
    step, and a given step above it is refused. Newmark: at least
    :data:`NEWMARK_STEPS` steps over the duration and a whole number of
    steps per output interval.
    """
    a = case.analysis
    out = a.output_step
    if dt_stable is not None:
        if a.time_step is not None:
            if a.time_step > dt_stable:
                raise CaseError(
                    f"{case.path.name}: [analysis] time_step = {a.time_step:.4g} s is "
                    f"above the explicit stability limit {dt_stable:.4g} s; use at "
                    f"most that, or \"auto\" ({a.safety_factor} x the limit)")
            return a.time_step
        return a.safety_factor * dt_stable
    dt = a.time_step if a.time_step is not None else min(out, a.duration / NEWMARK_STEPS)
    if a.time_step is None:
        dt = out / math.ceil(out / dt - 1e-9)   # a whole number of steps per output
    return dt


# -- central difference ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class CentralDifference:
    """Explicit central difference with the lumped reduced mass ``m``.

    A step's one pass over ``K`` is :attr:`product` (MKL's analysed product:
    0.44 ms against scipy's 0.75 ms on the 16k-DOF benchmark stiffness).
    """

    dt: float
    K: sp.csr_matrix
    m: np.ndarray
    minv: np.ndarray = field(init=False, repr=False)
    product: SparseProduct = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "minv", 1.0 / self.m)
        object.__setattr__(self, "product", SparseProduct(self.K, copy=False))


def stable_time_step(K: sp.csr_matrix, m: np.ndarray, contact: ContactModel,
                     tangential: bool = True) -> float:
    """Critical central-difference step ``2 / omega_max``, contact penalty included.

    ``omega_max^2`` is the largest eigenvalue of ``M^-1/2 (K + K_c) M^-1/2``
    (Lanczos), with every row of the contact model in contact, sticking
    (the tangential penalty) if it has friction and ``tangential``.
    """
    Kc = (contact.B.T @ sp.diags(contact.eps_w) @ contact.B).tocsr()
    if tangential and contact.friction:   # the tangential penalty springs, as stiff
        eps = np.concatenate([contact.eps_w, contact.eps_w])
        Kc = (Kc + contact.Bt.T @ sp.diags(eps) @ contact.Bt).tocsr()
    s = 1.0 / np.sqrt(m)
    A = sp.diags(s) @ (K + Kc) @ sp.diags(s)
    if A.shape[0] < 10:
        lam = float(np.linalg.eigvalsh(A.toarray()).max())
    else:
        lam = spla.eigsh(A, k=1, which="LA", tol=1e-4, return_eigenvectors=False,
                         v0=np.ones(A.shape[0]))[0]
    if lam <= 0:
        raise SolverError("the model has no stiffness: nothing limits the time step; "
                          "give [analysis] time_step")
    return 2.0 / math.sqrt(lam)


def central_difference_start(cd: CentralDifference, v0: np.ndarray,
                             contact: ContactModel) -> State:
    """The state at rest position with velocity ``v0``."""
    z = np.zeros(len(v0))
    lam, _ = contact.forces(z)
    return State(0, z, v0.copy(), cd.minv * (contact.BT @ lam), lam)


def central_difference_step(s: State, cd: CentralDifference, contact: ContactModel,
                            plastic=None, watch: Callable[[np.ndarray], object] | None = None,
                            friction=None) -> State:
    """One velocity-Verlet step.

    Every :data:`CHECK_EVERY` steps, once the displacement is known, the
    contact is re-projected if the zone moved and ``watch(z)`` may grow the
    zone, before the forces are evaluated. ``friction``: the
    :class:`~fe_impact.contact.friction.ExplicitFriction` of a contact model
    with friction (its tangential forces from the step's slip increments).
    """
    n, dt = s.n + 1, cd.dt
    v, z = _verlet_predict(s.a, s.v, s.z, 0.5 * dt, dt)
    if n % CHECK_EVERY == 0:
        if contact.moved(z):
            contact.update(z)
        if watch is not None:
            watch(z)
    Kz = cd.product @ z
    strain_energy = 0.5 * float(z @ Kz)
    f = Kz                      # K z - F_p - B^T lam, made the acceleration in place
    if plastic is not None:
        f -= plastic.update(z)
        plastic.commit()
    lam, _ = contact.forces(z)
    contact.add_forces(-lam, f)
    t = None
    if friction is not None:
        t = friction.forces(contact, z, s.z, lam, dt)
        if t is not None:
            contact.add_tangential(t, f, -1.0)
    a = _verlet_correct(f, cd.minv, v, 0.5 * dt)
    return State(n, z, v, a, lam, strain_energy, t=t)


# The explicit step's vector work in two passes instead of nine numpy operations and
# four temporary arrays (on the 16k-DOF benchmark the step's work besides the
# stiffness product was about 100 us, half of it the Python and numpy calls), with
# the same operations in the same order: the results are those of the numpy
# expressions to the last bit (no fastmath: no fused multiply-adds).
@njit(cache=True)
def _verlet_predict(a, v_old, z_old, half_dt, dt):
    """``v = v_n + dt/2 a_n`` and ``z = z_n + dt v``, new arrays."""
    v = np.empty_like(v_old)
    z = np.empty_like(z_old)
    for i in range(len(v)):
        vi = half_dt * a[i] + v_old[i]
        v[i] = vi
        z[i] = dt * vi + z_old[i]
    return v, z


@njit(cache=True)
def _verlet_correct(f, minv, v, half_dt):
    """``a = -f / m`` in place of ``f`` (``f = K z - F_p - B^T lam``) and ``v += dt/2 a``."""
    for i in range(len(f)):
        ai = minv[i] * -f[i]
        f[i] = ai
        v[i] += half_dt * ai
    return f


# -- Newmark / HHT-alpha -----------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Newmark:
    """Newmark's average acceleration, HHT-alpha if ``alpha < 0`` (-1/3 <= alpha <= 0).

    ``beta = (1 - alpha)^2 / 4``, ``gamma = 1/2 - alpha``; the internal and
    contact forces are taken at ``(1 + alpha) t_n+1 - alpha t_n``.
    """

    dt: float
    K: sp.csr_matrix
    M: sp.csr_matrix
    alpha: float = 0.0
    #: the products of every step, MKL's analysed ones (:class:`SparseProduct`:
    #: 5.3 ms against scipy's 6.8 ms for ``K`` of a 117k-DOF tooth pair)
    K_product: SparseProduct = field(init=False, repr=False)
    M_product: SparseProduct = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "K_product", SparseProduct(self.K, copy=False))
        object.__setattr__(self, "M_product", SparseProduct(self.M, copy=False))

    @property
    def beta(self) -> float:
        return (1.0 - self.alpha) ** 2 / 4.0

    @property
    def gamma(self) -> float:
        return 0.5 - self.alpha

    @property
    def force_factor(self) -> float:
        """Weight ``1 + alpha`` of the new step's forces."""
        return 1.0 + self.alpha

    def effective_stiffness(self) -> sp.csr_matrix:
        """``(1 + alpha) K + M / (beta dt^2)``, the matrix every step solves with."""
        c0 = 1.0 / (self.beta * self.dt ** 2)
        return ((1.0 + self.alpha) * self.K + c0 * self.M).tocsr()


def newmark_start(nm: Newmark, v0: np.ndarray, contact: ContactModel) -> State:
    """The state at rest position with velocity ``v0`` (and the acceleration of any contact)."""
    z = np.zeros(len(v0))
    lam, _ = contact.forces(z)
    f_c = contact.BT @ lam
    acc = np.zeros_like(z)
    if np.any(lam > 0):
        acc = SPDSolver(nm.M).solve(f_c - nm.K @ z)
    return State(0, z, v0.copy(), acc, lam, 0.0, f_c, np.zeros_like(z), None)


def newmark_free_step(s: State, nm: Newmark, contact: ContactModel) -> State | None:
    """The next step of a rigid flight to first touch; None where the flight ends.

    ``s`` must be in rigid motion: ``z`` and ``v`` in the stiffness's null
    space (rigid bodies and the volumes they carry), no acceleration, no
    contact or plastic force. Then the step's solve returns ``z + dt v``:
    ``K (z + dt v) = 0`` makes ``K_eff (z + dt v) = c0 M (z + dt v)``, the
    step's right-hand side, and the acceleration stays zero. So while every
    gap stays open at the new position and the zone has not moved, the step
    is that sum, without the solve; it differs from the solved one only by
    rounding (the solve's, and K's on the rigid field, which the solved steps
    feel as a slight stiffness). None: a gap closes or the zone moved, take the
    full step.
    """
    z = s.z + nm.dt * s.v
    lam, _ = contact.forces(z)
    if np.any(lam > 0.0) or contact.moved(z):
        return None
    Kz = nm.K_product @ z
    return State(s.n + 1, z, s.v, s.a, lam, 0.5 * float(z @ Kz), s.f_contact, s.f_plastic,
                 s.active, Kz)


def newmark_step(s: State, nm: Newmark, contact: ContactModel,
                 solve: Callable[[np.ndarray, np.ndarray | None, np.ndarray], StepContact],
                 plastic=None, max_projections: int = 30, friction=None) -> State:
    """One Newmark step.

    ``solve(rhs, active, z_n)`` returns the step's contact forces and
    displacement for the right-hand side ``rhs`` (see
    :meth:`CondensedContact.solve` and :func:`plastic_newmark_solve`); it is
    called again after each re-projection of the contact, until the zone has
    not moved. ``friction``: the
    :class:`~fe_impact.contact.friction.ImplicitFriction` whose forces the
    final solve's tangential forces become.
    """
    n, dt, alpha, beta = s.n + 1, nm.dt, nm.alpha, nm.beta
    c0, c1, c2 = 1.0 / (beta * dt ** 2), 1.0 / (beta * dt), 1.0 / (2.0 * beta) - 1.0
    Kz = nm.K_product @ s.z if s.Kz is None else s.Kz
    rhs0 = (nm.M_product @ (c0 * s.z + c1 * s.v + c2 * s.a)
            + alpha * (Kz - s.f_plastic - s.f_contact))
    active = s.active
    for _ in range(max_projections):
        lam, z_new, active, t = solve(rhs0, active, s.z)
        if not contact.moved(z_new):
            break
        contact.update(z_new)
    else:
        raise ContactError(f"contact did not settle within {max_projections} re-projections "
                           f"at t = {n * dt:.6g} s; raise [analysis] max_iterations")
    f_p = s.f_plastic
    if plastic is not None:
        plastic.commit()
        f_p = plastic.plastic_force()
    acc = c0 * (z_new - s.z) - c1 * s.v - c2 * s.a
    v = s.v + dt * ((1.0 - nm.gamma) * s.a + nm.gamma * acc)
    Kz_new = nm.K_product @ z_new
    f_c = contact.BT @ lam
    if friction is not None:
        friction.commit(contact, lam, t, z_new, s.z)
        contact.add_tangential(t, f_c)
    return State(n, z_new, v, acc, lam, 0.5 * float(z_new @ Kz_new),
                 f_c, f_p, active, Kz_new, t)


# -- plasticity in a Newmark step --------------------------------------------------


@dataclass
class PlasticStats:
    """Counters of the Newmark plasticity over a run, and the last step's plastic
    correction (the next step's starting guess)."""

    iterations: int = 0         # solver iterations, elastic trials included
    krylov_products: int = 0    # GMRES products of the Newton corrections
    newton_fallbacks: int = 0   # steps Newton handed to Anderson
    # z - z_trial of the last step, None after a step where nothing yielded further
    correction: np.ndarray | None = field(default=None, repr=False)


class _ElasticSolve:
    """``f_p -> z``: the step's elastic solve with the plastic force ``f_p`` on the right.

    Keeps the contact solution of the last call: its forces, and its active
    set as the next call's warm start.
    """

    def __init__(self, rhs0: np.ndarray, contact: CondensedContact,
                 active: np.ndarray | None, z_n: np.ndarray | None = None) -> None:
        self.rhs0, self.contact, self.z_n = rhs0, contact, z_n
        self.last = StepContact(np.zeros(0), np.zeros(0), active)
        self._lin: Callable[[np.ndarray], np.ndarray] | None = None

    def __call__(self, f_p: np.ndarray) -> np.ndarray:
        rhs = self.rhs0 + self.contact.force_factor * f_p
        if self.contact.friction is not None:
            self.last = self.contact.solve_frictional(rhs, self.z_n)
        else:
            self.last = self.contact.solve(rhs, self.last.active)
        self._lin = None
        return self.last.z

    def derivative(self, w: np.ndarray) -> np.ndarray:
        """The last solve's response to a plastic force ``w`` at a fixed active set."""
        if self._lin is None:
            self._lin = self.contact.linearisation(self.last.lam)
        return self._lin(self.contact.force_factor * w)


def plastic_newmark_solve(rhs0: np.ndarray, active: np.ndarray | None, z_n: np.ndarray,
                          contact: CondensedContact, zone, method: str,
                          stats: PlasticStats) -> StepContact:
    """One Newmark step with plasticity: ``z = step(F_p(z))``.

    ``step`` is one elastic solve (plastic force on the right, contact
    condensed). ``method``: ``newton``
    (:func:`~fe_impact.fe.plasticity.solve_newton`) with the zone's
    consistent tangent, GMRES on the elastic factorisation for each
    correction; ``anderson``
    (:func:`~fe_impact.fe.plasticity.solve_fixed_point`) modified Newton on
    the elastic factorisation with Anderson mixing. A step Newton fails is
    redone by Anderson. ``stats`` counts the work.
    """
    from fe_impact.fe.plasticity import solve_fixed_point, solve_newton

    step = _ElasticSolve(rhs0, contact, active, z_n)
    if contact.friction is not None:
        # the condensed linearisation holds the normal rows only: with friction the
        # Newton derivative would be inexact, Anderson's fixed point needs none
        method = "anderson"
    # An elastic step with the committed plastic force: if no point yields
    # further, it is the solution (most steps of a mildly plastic impact).
    f_old = zone.plastic_force()
    z_new = step(f_old)
    f_new = zone.update(z_new)
    if np.array_equal(f_new, f_old):
        stats.iterations += 1
        stats.correction = None
        return step.last
    # The plastic part of a step's solution changes little from one step to the
    # next: start from the elastic trial plus the last step's plastic correction
    # (on the coarse 30 V_y sphere 11% fewer GMRES products, on the coarse
    # stage-2 recess corner at 180 mm/s 10%; the same steps to the tolerance).
    trial, products = z_new, 0
    z0 = z_new if stats.correction is None else z_new + stats.correction

    def anderson():
        try:
            return solve_fixed_point(step, zone, z0, tol=PLASTIC_TOL, max_iter=200, reference=z_n)
        except RuntimeError as exc:
            raise SolverError(f"plasticity did not converge in a Newmark step: {exc}; "
                              "reduce the time step or use the explicit integrator") from None

    if method == "anderson":
        z_new, its = anderson()
    else:
        try:
            z_new, its, products = solve_newton(step, step.derivative, zone, z0, tol=PLASTIC_TOL,
                                                max_iter=50, reference=z_n)
        except RuntimeError as exc:
            # e.g. the contact's active set alternating between iterations
            logger.warning("Newton's plasticity iteration failed (%s); this step "
                           "falls back to Anderson-accelerated modified Newton", exc)
            stats.newton_fallbacks += 1
            z_new, its = anderson()
    stats.iterations += its
    stats.krylov_products += products
    stats.correction = z_new - trial
    return StepContact(step.last.lam, z_new, step.last.active, step.last.t)
