"""Static contact between linear elastic bodies, by displacement or by load.

The bodies are linear, only contact is nonlinear, and only a small patch of
surface can touch. The solver therefore

1. factorises the stiffness of the free DOFs once (supports, prescribed
   displacements and the surfaces of rigid bodies are the prescribed DOFs);
2. gives each node of the contact zone (the candidate faces within a
   search distance) a normal/tangent frame and condenses the stiffness onto
   the normal coordinates with a Schur complement: the compliance ``G`` of
   one coordinate per zone node (:func:`~fe_impact.contact.linearised.zone_frames`,
   as in the implicit transient step);
3. per load step, solves the no-contact displacement ``u0``, then iterates:
   project the zone's slave nodes on the deformed master (linearised gaps
   ``h = g + B (u0 - u)``), solve the penalty contact forces ``lambda`` of
   the small dense problem ``lambda = eps w <-(h + B G B^T lambda)>`` exactly
   (:func:`~fe_impact.contact.lcp.solve_penalty_lcp`), and recover the
   displacement ``u = u0 + K^-1 B^T lambda`` by one back-substitution, until
   the active set and the displacement converge;
4. checks the whole slave surface: faces outside the zone that come close
   enlarge it (the condensation is redone) and the step continues.

A zone of more than :data:`ROW_SPACE_COORDINATES` coordinates (a tip edge's
corner contact: the patch runs along the edge, and the flank beside it
separates slowly) is not condensed: its dense compliance would cost the cube
of its size. The stiffness is factorised plainly, and the dense problem is
formed in the space of the zone's gap rows (:class:`_RowSpace`: their
compliances from one Schur complement of the stiffness bordered by their
Jacobian, kept over the projections and the load steps); because a kept
row's Jacobian is that of the projection it was formed at, each projection
corrects the gaps by the exact response to the last forces (one more
solve), so the iteration converges to the same solution (to 1e-12 of the
coordinate-space one in the tests). With friction the rows' space keeps the
normal and both tangential rows of every gap row (:class:`_FrictionalRowSpace`),
corrected the same way (the gaps and the slips), so a zone too large to condense
keeps its friction (to 1e-10 of the condensed solution at a tight tolerance in the
tests).

A rigid body whose ``loads`` are given (a torque on a hub) is solved for its
coordinate ``q`` inside each projection: the contact-free displacement is
``u0 + q w`` (``w`` the response to a unit coordinate), the reaction along
the body is ``R0 + r q - (B w) . lambda``, and ``q`` is found on the small
dense problem by a safeguarded secant (regula falsi) search: no extra
back-substitution per trial.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.linalg import cho_solve, solve_triangular
from scipy.sparse.linalg import LinearOperator

from fe_impact.contact.condensed import (
    ROW_SPACE_COORDINATES,
    ZoneSolver,
    frictional_frames,
    row_compliance,
)
from fe_impact.contact.friction import (
    FrictionalSolution,
    pair_laws,
    slip_dissipation,
    solve_frictional,
)
from fe_impact.contact.lcp import solve_penalty_lcp
from fe_impact.contact.linearised import (
    ContactModel,
    patch_growth,
    predicted_patch,
    zone_frames,
)
from fe_impact.contact.surfaces import nodal_areas, nodal_pressure
from fe_impact.contact.zone import ContactZone, contact_pairs, face_size
from fe_impact.errors import CaseError, ContactError
from fe_impact.fe.case import Case
from fe_impact.fe.elasticity import ElasticModel, build_model, von_mises
from fe_impact.fe.kinematics import Kinematics
from fe_impact.fe.linalg import inverse_from_cholesky, schur_cholesky
from fe_impact.fe.mesh import FEMesh
from fe_impact.solvers.model import ContactSetup, Prescribed, displacement_reach, gap_reach

logger = logging.getLogger(__name__)

#: Enlargements of the contact zone allowed in one load step.
MAX_ZONE_GROWTH = 8
#: The projection iteration is a contraction: each change of the zone's
#: displacement is the last one times a rate (about 1e-3 on a tooth pair:
#: 2.8e-6, 1.4e-8, 1.2e-11 m). Below this rate the error left after a change
#: ``c`` is bounded by ``c rate / (1 - rate)``, and that bound, not ``c``
#: itself, is held to the tolerance: about one iteration fewer per load step
#: (22 -> 16 on a coarse tooth pair at six loads), the answer within the same
#: tolerance of the fully converged one.
TRUSTED_RATE = 0.1
#: Iterations of the load-controlled coordinate per projection; the reaction
#: is piecewise linear in it, so a safeguarded secant needs a handful.
MAX_LOAD_ITERATIONS = 60
#: With friction, a zone of more condensed coordinates than this (its nodes' normal
#: ones and the tangent ones of the predicted patch) is solved in the rows' space
#: (:class:`_FrictionalRowSpace`): the condensed zone's dense factor and the growths
#: of its patch (a factorisation each) cost more there than the rows' compliances
#: and a solve a projection. Measured on one thread against the frictionless solve:
#: bench_static's sphere (31k DOFs, 1,751 coordinates) 1.24 x condensed, 1.71 x in
#: the rows' space; coarse tooth pairs of the mesh cycle (stage 1, six loads to
#: 1 kN) at 2.07 deg (38k DOFs, 3,513) 2.7 x condensed (a growth to 5,203), 1.09 x
#: in the rows' space, and at 14.47 deg (55k DOFs, 5,581) 5.0 x condensed (a growth
#: to 8,339), 1.30 x in the rows' space (2.9 x switching to it at the growth).
FRICTION_ROW_SPACE_COORDINATES = 3000
#: The most normal and tangential rows (three per gap row) the rows' space keeps with
#: friction: their dense compliance (and PARDISO's Schur complement it comes from)
#: takes 8 bytes squared each, 0.29 GB at this size, about 1 GB at the peak of its
#: forming. A tip edge's corner zone of 49,297 coordinates took 6 GB before this
#: limit; such a zone is refused (a ContactError, which the calibration answers by
#: solving it frictionless).
FRICTION_ROW_SPACE_ROWS = 6000
#: Right-hand sides per block of :class:`_RowSpace`'s solves (memory: one
#: block of the free DOFs' size).
ROW_BLOCK = 128


@dataclass(frozen=True, eq=False)
class FrictionRows:
    """The contact rows (weighted slave nodes) of a step with friction, all pairs.

    Attributes
    ----------
    pair : ndarray of int
        The row's contact pair.
    point : ndarray, shape (r, 3)
        The slave node, deformed (m).
    weight : ndarray
        Its tributary area (m^2).
    normal_force : ndarray
        ``lambda`` (N).
    tangential_force : ndarray, shape (r, 3)
        The friction force on the slave node (N).
    mu : ndarray
        The coefficient it was limited by.
    slipping : ndarray of bool
        In contact and on the friction cone.
    """

    pair: np.ndarray
    point: np.ndarray
    weight: np.ndarray
    normal_force: np.ndarray
    tangential_force: np.ndarray
    mu: np.ndarray
    slipping: np.ndarray


@dataclass(frozen=True)
class StepResult:
    """Outcome of one load step (SI units)."""

    value: float
    contact_force: list[float]
    contact_area: list[float]
    max_pressure: float
    max_penetration: float
    iterations: int
    active_set_iterations: int
    reaction_force: list[float]
    u: np.ndarray = field(repr=False)          # (n_points, 3)
    pressure: np.ndarray = field(repr=False)   # (n_points,)
    von_mises: np.ndarray | None = field(repr=False)  # (n_elements,); None: not asked
    #: Each rigid body's coordinate (m or rad) and the force or torque along
    #: it (N or N m), in the case's order.
    rigid_values: list[float] = field(default_factory=list)
    rigid_reactions: list[float] = field(default_factory=list)
    #: Friction (pairs with a coefficient): each pair's tangential contact force on
    #: its slave surface (N, a 3-vector), the area of its slave nodes in contact and
    #: sticking (m^2, from the rows' tributary areas, as ``stick_area``'s partner
    #: ``friction_contact_area``), and the energy friction has dissipated since the
    #: first step (J).
    friction_force: list[list[float]] = field(default_factory=list)
    stick_area: list[float] = field(default_factory=list)
    friction_contact_area: list[float] = field(default_factory=list)
    friction_dissipation: float = 0.0
    #: friction: the rows of every pair at the step (positions, forces, stick or slip)
    friction_rows: FrictionRows | None = field(default=None, repr=False)


@dataclass
class StaticResult:
    steps: list[StepResult]
    mesh: FEMesh
    model: ElasticModel
    penalties: list[float]
    timings: dict[str, float]
    info: dict


class _StaticContact(ContactModel):
    """Linearised gaps of the free DOFs, on the configuration that includes the
    prescribed displacement ``offset`` (all DOFs)."""

    offset: np.ndarray | None = None

    def point_values(self, z: np.ndarray) -> np.ndarray:
        u = self.kin.T @ z
        if self.offset is not None:
            u = u + self.offset
        return self.model.point_values(u)


@dataclass
class _Equilibrium:
    """A converged contact state of one load step."""

    z: np.ndarray          # free DOFs
    lam: np.ndarray        # penalty forces on the contact model's rows
    q: float               # the load-controlled coordinate (0 if none)
    iterations: int
    active_set_iterations: int
    t: np.ndarray | None = None          # friction: tangential forces (r, 2) in the rows'
    slipping: np.ndarray | None = None   # frames; the rows slipping


class StaticSolver:
    """Set up once per case; :meth:`run` solves the load steps.

    ``stress=False`` leaves each step's von Mises field out (None): a caller
    that reads only forces, displacements and pressures saves its evaluation
    (56 ms a step on a 40k-DOF coarse tooth pair).
    """

    def __init__(self, case: Case, mesh: FEMesh, stress: bool = True) -> None:
        self.case = case
        self.stress = stress
        self.timings: dict[str, float] = {"condensation": 0.0}
        t = time.perf_counter()
        self.mesh = mesh
        case.check_groups(self.mesh)
        self.timings["mesh"] = time.perf_counter() - t
        t = time.perf_counter()
        self.model = build_model(self.mesh, case.materials)
        self.timings["assembly"] = time.perf_counter() - t
        self.dofs = Prescribed.build(case, self.mesh, self.model.n_dofs)
        _check_held(case, self.mesh, self.dofs.fixed)
        free, fixed = self.dofs.free, self.dofs.fixed
        K = self.model.K
        self.K_ff = K[free][:, free].tocsr()
        self.K_fd = K[free][:, fixed].tocsr()
        self.K_d = K[fixed].tocsr()            # rows of the prescribed DOFs: reactions
        # One factorisation of the free stiffness (in the zone frames) serves the
        # solves and the condensation onto the zone (:class:`ZoneSolver`).
        self.solver = ZoneSolver(self.K_ff)
        n = self.model.n_dofs
        T = sp.csr_matrix((np.ones(len(free)), (free, np.arange(len(free)))),
                          shape=(n, len(free)))
        self.kin = Kinematics(T, free, fixed, ())
        controlled = [k for k, b in enumerate(case.rigid_bodies) if b.load_controlled]
        self.load_body = controlled[0] if controlled else None
        self.pairs = contact_pairs(case, self.mesh, self.model)
        self.laws = pair_laws(case.contacts)
        self.friction = any(law is not None for law in self.laws)
        self.node_areas = [nodal_areas(self.mesh, p.slave) for p in self.pairs]
        setup = ContactSetup.build(case, self.mesh, self.pairs, self._reach_rule())
        self.zone, self.reference = setup.zone, setup.states
        self.contact = _StaticContact(self.mesh, self.model, self.kin, self.zone, 0.0,
                                      self.laws)
        # friction history: the last step's tangential force of each row (a 3-vector,
        # keyed by :meth:`_row_keys`), the displacement it was reached at, the
        # energy dissipated so far
        self._t_keys = np.zeros(0, dtype=np.int64)
        self._t_vec = np.zeros((0, 3))
        self._u_prev = np.zeros(self.model.n_dofs)
        self._dissipation = 0.0
        self.rows: _RowSpace | None = None    # set when the zone is solved in row space
        # friction: the nodes (mesh.point_dof numbers) whose tangent coordinates are
        # condensed, grown as the contact patch grows (_grow_tangential)
        self.tangential = predicted_patch(self.mesh, self.contact, setup.reach) \
            if self.friction else np.zeros(0, dtype=np.int64)
        self.tangential_growths = 0
        self._condense()
        # The load-controlled body (at most one) and its unit response.
        self.w = None if self.load_body is None else self.solver.solve(
            -(self.K_fd @ self.dofs.modes[self.load_body]))

    def _reach_rule(self):
        """Search distance: the largest prescribed displacement; under a load, the
        first touch (a hundredth of the smallest face beyond the smallest gap),
        enlarged after the first load step to the patch of the largest load
        (:meth:`_zone_for_largest_load`). On gear flanks the gap grows slowly
        along the contact line, so a face's worth of gap would take in the
        whole face width."""
        if self.load_body is not None or not self.dofs.values.size:
            def first_touch(pair, state):
                return gap_reach(self.mesh)(pair, state) - face_size(self.mesh, pair.slave) \
                    + 0.01 * face_size(self.mesh, pair.slave, np.min)
            return first_touch
        return displacement_reach(float(np.abs(self.dofs.values).max()))

    def _condense(self) -> None:
        """Normal frames of the zone nodes and the compliance of those coordinates
        (or, for a large zone, of the gap rows: :data:`ROW_SPACE_COORDINATES`)."""
        t = time.perf_counter()
        factor = self.solver.factor_seconds
        frames = frictional_frames(self.mesh, self.kin, self.contact, self.tangential) \
            if self.friction else zone_frames(self.mesh, self.kin, self.contact)
        self.n_condensed = len(frames.condensed)
        limit = FRICTION_ROW_SPACE_COORDINATES if self.friction else ROW_SPACE_COORDINATES
        # in the rows' space nothing is condensed: the rows keep every component
        self.contact.set_projector(None if self.friction and (
            self.rows is not None or self.n_condensed > limit) else frames.projector)
        if self.rows is None and self.n_condensed > limit:
            self.solver.release()
            self.solver = ZoneSolver(self.K_ff, schur_solves=0)   # a plain factorisation
            factor = 0.0
            self.rows = _RowSpace(self.K_ff, self.solver.solve)
            logger.info("contact zone of %d coordinates: solved in the space of its gap "
                        "rows", self.n_condensed)
        if self.rows is not None:
            ok = self.contact.active_rows
            self.R_open = None    # nothing condensed: no tangent coordinate to grow
            if self.friction:     # the normal and both tangential rows of every row
                n_rows = 3 * int(ok.sum())
                if n_rows > FRICTION_ROW_SPACE_ROWS:
                    raise ContactError(
                        f"the contact zone holds {n_rows // 3} gap rows, {n_rows} with their "
                        f"tangential rows, above the {FRICTION_ROW_SPACE_ROWS} whose "
                        "compliances friction can keep: set a smaller [[contacts]] "
                        "search_distance or coarsen the contact faces")
                logger.info("friction in the rows' space: %d normal and tangential rows",
                            n_rows)
                keys, B_all = self._frictional_rows()
                ok3 = np.tile(ok, 3)
                self.rows.prime(keys[ok3], B_all[ok3])
            else:
                self.rows.prime(self._row_keys()[ok], self.contact.B[ok])
        else:
            S = self.solver.condense(frames.R, frames.condensed)
            if self.friction:
                # the frictional rows' compliances come from the factor, a few hundred
                # triangular solves a projection: the inverse of a zone condensed on
                # three coordinates a node costs 27 times that of its normal ones
                self.L = schur_cholesky(S)
                self.G = None
            else:
                self.G = inverse_from_cholesky(schur_cholesky(S))
            self.R_c = frames.R[:, frames.condensed].tocsc()
            held = np.zeros(frames.R.shape[1], dtype=bool)
            held[frames.condensed] = True
            # None: all three coordinates of every node condensed, nothing to grow
            self.R_open = None if frames.projector is None else frames.R[:, ~held].tocsc()
            logger.info("contact zone: %d coordinates condensed", self.n_condensed)
        factorised = self.solver.factor_seconds - factor
        self.timings["factorisation"] = self.timings.get("factorisation", 0.0) + factorised
        self.timings["condensation"] += time.perf_counter() - t - factorised

    def _frictional_rows(self) -> tuple[np.ndarray, sp.csr_matrix]:
        """Keys and Jacobians of the normal rows, then the t1 and the t2 rows, of the
        current projection (on the free DOFs): the rows' space with friction keeps
        them by these keys (``3 k``, ``3 k + 1``, ``3 k + 2`` of a row's key ``k``)."""
        c = self.contact
        keys = 3 * self._row_keys()
        return (np.concatenate([keys, keys + 1, keys + 2]),
                sp.vstack([c.B, c.Bt]).tocsr())

    def _row_keys(self) -> np.ndarray:
        """A key per gap row of the contact model that names its slave node and pair
        over projections and zone growth."""
        n = self.mesh.n_points
        return np.concatenate([st.nodes + k * n for k, st in enumerate(self.contact.states)])

    # -- load steps -----------------------------------------------------------
    def run(self, step_hook: Callable[[int, StepResult], None] | None = None) -> StaticResult:
        """Solve every load step; ``step_hook(i, step)`` is called after each."""
        steps = []
        t_steps = 0.0
        for i in range(self.case.n_steps):
            t = time.perf_counter()
            cond0 = self.timings["condensation"]
            step = self.solve_step(i)
            t_steps += time.perf_counter() - t - (self.timings["condensation"] - cond0)
            steps.append(step)
            if step_hook is not None:
                step_hook(i, step)
        if self.rows is not None:    # the rows' compliances are the condensation here
            self.timings["condensation"] += self.rows.seconds
            t_steps -= self.rows.seconds
        self.timings["steps"] = t_steps
        info = {"n_dofs": int(self.model.n_dofs), "n_free_dofs": int(len(self.dofs.free)),
                "n_contact_dofs": int(self.n_condensed), "element_order": self.mesh.order,
                "n_elements": int(len(self.mesh.cells)), "n_points": int(self.mesh.n_points)}
        return StaticResult(steps, self.mesh, self.model, [p.penalty for p in self.pairs],
                            dict(self.timings), info)

    def solve_step(self, i: int) -> StepResult:
        u_d = self.dofs.field(i)
        self.contact.offset = self._full(np.zeros(len(self.dofs.free)), u_d)
        rhs = -(self.K_fd @ u_d)
        # held supports only (a load-controlled hub): no back-substitution for zero
        u0 = self.solver.solve(rhs) if rhs.any() else np.zeros(len(self.dofs.free))
        load = None
        if self.load_body is not None:
            load = self.case.rigid_bodies[self.load_body].loads[i]
        warm = getattr(self, "_last", None)
        for _ in range(MAX_ZONE_GROWTH + 1):
            if self.friction:
                eq = self._frictional_equilibrium(u0, u_d, load, warm)
            else:
                eq = self._equilibrium(u0, u_d, load, warm)
            u_full = self._full(eq.z, self._prescribed(u_d, eq.q))
            if not (self._grow_zone(u_full, eq.z) or self._zone_for_largest_load(i, eq)):
                self._last = eq
                result = self._step_result(i, u_full, eq)
                if self.friction:
                    result = self._commit_friction(result, u_full, eq)
                return result
            warm = eq
        raise ContactError(f"the contact zone grew {MAX_ZONE_GROWTH} times in load step "
                           f"{i + 1}: set a [[contacts]] search_distance that covers the "
                           "contact patch")

    def _prescribed(self, u_d: np.ndarray, q: float) -> np.ndarray:
        if self.load_body is None:
            return u_d
        return u_d + q * self.dofs.modes[self.load_body]

    def _full(self, z: np.ndarray, u_d: np.ndarray) -> np.ndarray:
        u = np.zeros(self.model.n_dofs)
        u[self.dofs.free] = z
        u[self.dofs.fixed] = u_d
        return u

    def _equilibrium(self, u0: np.ndarray, u_d: np.ndarray, load: float | None,
                     warm: _Equilibrium | None) -> _Equilibrium:
        """Iterate projections and contact forces to a converged contact state."""
        a = self.case.analysis
        c = self.contact
        q = warm.q if warm is not None else 0.0
        z = warm.z if warm is not None and len(warm.z) == len(u0) else u0
        if load is not None:
            reaction = self._reaction_model(u0, u_d)
        active, total, change, scale = None, 0, math.inf, 0.0
        # the row space's defect correction starts from the last step's forces
        lam_prev = warm.lam if warm is not None and self.rows is not None else None
        history: list[float] = []
        cycle: list[tuple[np.ndarray, np.ndarray, float]] = []   # the last two states
        for it in range(1, a.max_iterations + 1):
            self.contact.offset = self._full(np.zeros(len(u0)), self._prescribed(u_d, q))
            c.update(z)
            h = c.gaps(u0)
            hw = None if load is None else c.B @ self.w
            h_q = h if hw is None else h + q * hw
            seed = h_q < 0
            if active is not None and len(active) == len(h):
                seed |= active
            if self.rows is None:
                rows = _RowCompliance((c.B @ self.R_c).tocsr(), self.G)
            else:
                rows = _RowSpaceCompliance(c.B, self._row_keys(), self.rows,
                                           self.solver.solve)
                if lam_prev is not None and len(lam_prev) == len(h) and (lam_prev > 0).any():
                    rows.correct(lam_prev, c.B @ self.solver.solve(c.BT @ lam_prev))
                    # Start from the rows in contact and let :meth:`_forces` add
                    # those the forces close: the rows penetrating under the rigid
                    # motion alone are several times the patch (on a tip-edge
                    # corner, load steps 21.4 s against 24.4 s).
                    seed = lam_prev > 0
            if hw is not None and not seed[c.active_rows].any():
                # Nothing touches yet: start from the row nearest to touching.
                seed[np.flatnonzero(c.active_rows)[np.argmin(h_q[c.active_rows])]] = True
            lam, q, n_as = self._forces(rows, h, hw, c.eps_w, c.active_rows, seed, load,
                                        reaction if load is not None else None, q)
            total += n_as
            base = u0 if load is None else u0 + q * self.w
            z_new = base + self._contact_response(rows.B, lam)
            lam_prev = lam
            zone = c.T_zone
            change = float(np.abs(zone @ (z_new - z)).max(initial=0.0))
            scale = float(np.abs(zone @ (z_new - base)).max(initial=0.0))
            new_active = lam > 0
            if _alternates(cycle, z_new, lam, zone, a.tolerance * max(scale, 1e-30)):
                # No single state is consistent, the equilibrium lies between the
                # two: their mean is taken, and the two states' contact forces bound it.
                f0, f1 = sum(c.pair_forces(cycle[1][1])), sum(c.pair_forces(lam))
                flips = int(((cycle[1][1] > 0) != new_active).sum())
                logger.warning("the contact projection alternates between two states (contact "
                            "force %.6g and %.6g N, %.1e apart; %d rows in contact in one "
                            "only): their mean is taken", f0, f1,
                            abs(f1 - f0) / max(abs(f0), abs(f1), 1e-300), flips)
                return _Equilibrium(0.5 * (z_new + cycle[1][0]), 0.5 * (lam + cycle[1][1]),
                                    0.5 * (q + cycle[1][2]), it, total)
            cycle = [*cycle[-1:], (z_new, lam, q)]
            z = z_new
            rate = change / history[-1] if history and history[-1] > 0.0 else math.inf
            error = change * rate / (1.0 - rate) if rate < TRUSTED_RATE else change
            history.append(change)
            logger.debug("projection %d: change %.3g of %.3g, force %.12g, %d active, "
                         "%d flipped", it, change, scale, sum(c.pair_forces(lam)),
                         int(new_active.sum()), -1 if active is None or
                         len(active) != len(new_active) else int((active != new_active).sum()))
            if active is not None and np.array_equal(new_active, active) and \
                    error <= a.tolerance * max(scale, 1e-30):
                return _Equilibrium(z, lam, q, it, total)
            active = new_active
        raise ContactError(
            f"contact did not converge in {a.max_iterations} iterations (last change of the "
            f"zone's displacement {change:.3g} m, {change / max(scale, 1e-30):.2g} of the "
            f"contact displacement {scale:.3g} m; tolerance {a.tolerance:g}): "
            f"{_diagnosis(history, scale, face_size(self.mesh, self.pairs[0].slave))}")

    # -- friction -------------------------------------------------------------------
    def _friction_history(self) -> np.ndarray:
        """The last step's tangential force of each row, in the rows' current frames
        (r, 2): the stored 3-vector projected on the current tangents (N)."""
        c = self.contact
        keys = self._row_keys()
        t_vec = np.zeros((len(keys), 3))
        if len(self._t_keys):
            pos = np.minimum(np.searchsorted(self._t_keys, keys), len(self._t_keys) - 1)
            hit = self._t_keys[pos] == keys
            t_vec[hit] = self._t_vec[pos[hit]]
        return np.stack([np.einsum("ij,ij->i", t_vec, c.t1),
                         np.einsum("ij,ij->i", t_vec, c.t2)], axis=1)

    def _frictional_equilibrium(self, u0: np.ndarray, u_d: np.ndarray, load: float | None,
                                warm: _Equilibrium | None) -> _Equilibrium:
        """Projections and frictional contact forces to a converged state of a load step.

        Each projection solves the frictional problem of the zone's rows
        (:func:`~fe_impact.contact.friction.solve_frictional`) on their
        compliance ``[B; B_t] G [B; B_t]^T`` (``G`` of the zone's condensed
        normal and tangent coordinates), from the last step's tangential forces
        and with the slip measured from the last step's displacement, in the
        current projection's frames. Converged when the rows in contact and
        those slipping repeat and the zone's displacement has settled to the
        tolerance.

        Under a load-controlled rigid body its coordinate ``q`` is found in each
        projection as in :meth:`_equilibrium`, the reaction along it now holding
        the friction forces' part too (:meth:`_frictional_load_root`).
        """
        a = self.case.analysis
        c = self.contact
        z = warm.z if warm is not None and len(warm.z) == len(u0) else u0
        q = warm.q if warm is not None else 0.0
        if load is not None:
            reaction = self._reaction_model(u0, u_d)
        state, total, change, scale = None, 0, math.inf, 0.0
        history: list[float] = []
        sol_prev = None
        repeats = refreshes = 0    # projections with the same rows in contact; refreshes
        for it in range(1, a.max_iterations + 1):
            c.offset = self._full(np.zeros(len(u0)), self._prescribed(u_d, q))
            c.update(z)
            r = len(c.active_rows)
            h = np.where(c.active_rows, c.gaps(u0), np.inf)
            # slips from the last step's displacement (prescribed DOFs included)
            s0 = (c.Bt_full @ (self._full(u0, u_d) - self._u_prev)).reshape(2, r).T
            if self.rows is None:
                B_all = (sp.vstack([c.B, c.Bt]) @ self.R_c).tocsr()
                block = _compliance_blocks(B_all, self.L, r)
            else:
                keys, B_all = self._frictional_rows()
                rows = _FrictionalRowSpace(keys, B_all, c.active_rows, self.rows,
                                           self.solver.solve)
                if sol_prev is not None and len(sol_prev.lam) == r:
                    # the kept compliances' Jacobians are those of the projections the
                    # rows entered at: the gaps and slips corrected by the exact
                    # response to the last forces (as _RowSpaceCompliance)
                    offset = rows.offset(np.concatenate([sol_prev.lam, sol_prev.t[:, 0],
                                                         sol_prev.t[:, 1]]))
                    h = h + offset[:r]
                    s0 = s0 + offset[r:].reshape(2, r).T
                block = rows.block
            t_old, mu = self._friction_history(), c.row_coefficients()
            if load is None:
                sol = solve_frictional(block, h, s0, c.eps_w, c.eps_w, mu, t_old, warm=sol_prev)
                base = u0
            else:
                hw = np.where(c.active_rows, c.B @ self.w, 0.0)
                mode = self.dofs.modes[self.load_body]
                hwt = (c.Bt_full @ self._full(self.w, mode)).reshape(2, r).T
                q, sol = self._frictional_load_root(reaction, h, hw, s0, hwt, block, mu, t_old,
                                                    load, q, sol_prev)
                base = u0 + q * self.w
            total += sol.iterations
            if self._grow_tangential(sol, h if load is None else h + q * hw):
                continue          # the projection again, on the grown condensation
            sol_prev = sol
            p = np.concatenate([sol.lam, sol.t[:, 0], sol.t[:, 1]])
            z_new = base + self._frictional_response(B_all, p) if p.any() else base.copy()
            zone = c.T_zone
            change = float(np.abs(zone @ (z_new - z)).max(initial=0.0))
            scale = float(np.abs(zone @ (z_new - base)).max(initial=0.0))
            z = z_new
            new_state = (sol.lam > 0, sol.slipping)
            logger.debug("frictional projection %d: change %.3g of %.3g, %d in contact, "
                         "%d slipping", it, change, scale, int(new_state[0].sum()),
                         int(new_state[1].sum()))
            # Converged when the displacement has settled (the error bound of a
            # contraction, as in :meth:`_equilibrium`) and the rows in contact repeat,
            # but for rows whose force is within the tolerance of the total: a row at
            # the patch's edge may touch and part with a force of round-off size, and
            # a row exactly at the cone flip between stick and slip, moving nothing.
            rate = change / history[-1] if history and history[-1] > 0.0 else math.inf
            error = change * rate / (1.0 - rate) if rate < TRUSTED_RATE else change
            history.append(change)
            if state is not None and error <= a.tolerance * max(scale, 1e-30) and \
                    len(state[0]) == r:
                flipped = state[0] != new_state[0]
                if float(np.maximum(state[1], sol.lam)[flipped].sum()) <= \
                        a.tolerance * float(sol.lam.sum()):
                    return _Equilibrium(z, sol.lam, q, it, total, sol.t, sol.slipping)
            same = state is not None and np.array_equal(state[0], new_state[0])
            repeats = repeats + 1 if same else 0
            if self.rows is not None and refreshes < MAX_REFRESHES and \
                    repeats >= REFRESH_AFTER and _stalls(history, REFRESH_AFTER):
                self._refresh_rows(keys, B_all, sol)
                refreshes += 1
                history.clear()
            state = (new_state[0], sol.lam)
        raise ContactError(
            f"frictional contact did not converge in {a.max_iterations} iterations (last "
            f"change of the zone's displacement {change:.3g} m, "
            f"{change / max(scale, 1e-30):.2g} of the contact displacement {scale:.3g} m): "
            "apply the load in smaller steps (more [[displacements]] values), or raise "
            "[analysis] max_iterations")

    def _refresh_rows(self, keys: np.ndarray, B_all: sp.csr_matrix,
                      sol: FrictionalSolution) -> None:
        """Re-form the kept compliances of the rows with a force (normal or tangential,
        all three of each) in the current projection (:meth:`_RowSpace.refresh`).

        Parameters
        ----------
        keys, B_all
            Keys and Jacobian rows of the current projection's normal, t1 and t2 rows
            (:meth:`_frictional_rows`).
        sol
            The projection's frictional solution: its rows with a force are refreshed.
        """
        r = len(sol.lam)
        idx = np.flatnonzero(sol.forced)
        rows3 = np.concatenate([idx, r + idx, 2 * r + idx])
        logger.info("friction: the compliances of %d rows in contact formed again in the "
                    "current projection (the kept ones had stopped the iteration settling)",
                    len(idx))
        self.rows.refresh(keys[rows3], B_all[rows3])

    def _grow_tangential(self, sol, h: np.ndarray) -> bool:
        """Condense the tangent coordinates of the nodes the rows in contact reach, if a
        row with a force reaches one that is not condensed (a new factorisation); True
        if they grew.

        The rows with a force, and as a margin those whose contact-free gap ``h`` is
        below twice the deepest penetration or a tenth of the spread of the
        projection's gaps, join. A row with no force carries no tangential force, so
        its tangent coordinates need not be condensed."""
        if self.R_open is None:
            return False
        c = self.contact
        r = len(c.active_rows)
        forced = sol.forced
        reach = np.diff((c.Bt @ self.R_open).tocsr().indptr)
        if not np.any(forced & ((reach[:r] > 0) | (reach[r:] > 0))):
            return False
        _, new = patch_growth(self.mesh, c, forced, h, self.tangential)
        if len(new) == 0:
            return False
        self.tangential = np.union1d(self.tangential, new)
        self.tangential_growths += 1
        logger.info("friction: the tangent coordinates of %d more nodes condensed (%d in all)",
                    len(new), len(self.tangential))
        self._condense()
        return True

    def _frictional_load_root(self, reaction, h, hw, s0, hwt, block, mu, t_old, load, q0,
                              warm):
        """The load-controlled coordinate ``q`` whose contact forces carry ``load``, and
        those forces, with friction: the reaction ``R0 + r q - hw . lambda - hw_t . t``
        (``hw``, ``hw_t``: the rows' gap and slip change per unit ``q``), by the
        bracketing and regula falsi of :meth:`_load_root` (a step from the
        reaction's secant slope, doubled until the load is bracketed)."""
        r0, r = reaction
        c = self.contact
        last = {"sol": warm}

        def residual(q):
            sol = solve_frictional(block, h + q * hw, s0 + q * hwt, c.eps_w, c.eps_w, mu,
                                   t_old, warm=last["sol"])
            last["sol"] = sol
            f = r0 + r * q - float(hw @ sol.lam) - float(np.sum(hwt * sol.t)) - load
            return f, sol

        tol = 1e-9 * max(abs(load), 1e-12)
        f0, sol0 = residual(q0)
        if abs(f0) <= tol:
            return q0, sol0
        s = 1.0 if f0 < 0 else -1.0
        if np.any(sol0.lam > 0):      # the secant slope of a small step
            dq = 1e-6 * max(abs(q0), 1e-12)
            f1, _ = residual(q0 + s * dq)
            slope = (f1 - f0) / (s * dq)
            d = -f0 / slope if slope > 0.0 else s * dq
        else:                          # nothing touches: to the first touch
            closing = s * hw < 0
            if not closing.any():
                raise ContactError("the load-controlled rigid body does not move toward the "
                                   "contact: check its direction and the sign of its loads")
            fin = closing & np.isfinite(h)
            d = s * 1.01 * float(np.min((h + q0 * hw)[fin] / (-s * hw[fin])))
            d = d if d != 0.0 else s * 1e-12
        return load_root(residual, q0, f0, d, tol, load)

    def _frictional_response(self, B_all: sp.csr_matrix, p: np.ndarray) -> np.ndarray:
        """``K^-1 (B^T lambda + B_t^T t)``: the forces act on the condensed coordinates
        alone, so while the kept Schur factorisation serves, their solution ``G B_c^T
        p`` and one backward substitution make it (as :meth:`_contact_response`)."""
        if not self.solver.partial or self.L.size == 0:
            c = self.contact
            r = len(c.active_rows)
            return self.solver.solve(c.BT @ p[:r] + c.Bt.T @ p[r:])
        # (no finiteness check: it scanned the whole factor, 36 of the 40 ms of the
        # solve at 2,650 condensed coordinates)
        return self.solver.condensed_response(cho_solve((self.L, True), B_all.T @ p,
                                                        check_finite=False))

    def _commit_friction(self, step: StepResult, u_full: np.ndarray,
                         eq: _Equilibrium) -> StepResult:
        """Store the step's tangential forces as the next step's history, add its
        dissipation, and put the friction's figures into the step's result."""
        from dataclasses import replace

        c = self.contact
        r = len(c.active_rows)
        t_old = self._friction_history()
        s = (c.Bt_full @ (u_full - self._u_prev)).reshape(2, r).T
        t_tr = t_old - c.eps_w[:, None] * s
        cap = c.row_coefficients() * eq.lam
        self._dissipation += slip_dissipation(np.linalg.norm(t_tr, axis=1), cap, c.eps_w)
        t_vec = c.t1 * eq.t[:, [0]] + c.t2 * eq.t[:, [1]]
        keys = self._row_keys()
        order = np.argsort(keys)
        self._t_keys, self._t_vec = keys[order], t_vec[order]
        self._u_prev = u_full.copy()
        forces, stick, touching = [], [], []
        start = 0
        for st in c.states:
            sl = slice(start, start + len(st.gap))
            start += len(st.gap)
            on = eq.lam[sl] > 0
            forces.append([float(v) for v in t_vec[sl].sum(axis=0)])
            touching.append(float(st.weight[on].sum()))
            stick.append(float(st.weight[on & ~eq.slipping[sl]].sum()))
        rows = FrictionRows(c.row_law.copy(), np.concatenate([st.point for st in c.states]),
                            np.concatenate([st.weight for st in c.states]),
                            eq.lam.copy(), t_vec, c.row_coefficients(), eq.slipping.copy())
        return replace(step, friction_force=forces, stick_area=stick,
                       friction_contact_area=touching, friction_dissipation=self._dissipation,
                       friction_rows=rows)

    def _contact_response(self, Bc: sp.csr_matrix, lam: np.ndarray) -> np.ndarray:
        """``K^-1 B^T lambda``, the displacement of the contact forces ``lambda``.

        The forces act on the zone's condensed coordinates alone (``B^T lambda
        = R_c B_c^T lambda``), where the solution is ``G B_c^T lambda``: while
        the kept Schur factorisation serves, one backward substitution makes
        the rest (0.072 -> 0.04 s a projection on a 40k-DOF coarse pair).
        """
        if self.rows is not None or not self.solver.partial or self.G.size == 0:
            return self.solver.solve(self.contact.BT @ lam)
        return self.solver.condensed_response(self.G @ (Bc.T @ lam))

    def _forces(self, rows: _RowCompliance, h, hw, eps_w, valid, seed, load, reaction, q):
        """Contact forces (and the load-controlled coordinate) of one projection.

        Solved on a set of candidate rows, starting from ``seed`` (the rows
        penetrating without contact forces, and the last active set); rows
        outside it whose gap the forces would close are added and the solve
        repeated, so only the rows near the patch enter the dense problem.
        """
        lam = np.zeros(len(h))
        total = 0
        cand = np.flatnonzero(seed & valid)
        while True:
            rows.include(cand)
            R = rows.rows
            C = rows.C
            h_R = h[R] + rows.offset()
            if load is None:
                sub, n = solve_penalty_lcp(None, None, h_R, eps_w[R], None, C=C)
            else:
                q, sub, n = self._load_root(reaction, h_R, hw[R], C, eps_w[R], None, load, q)
            total += n
            lam[:] = 0.0
            lam[R] = sub
            w = h + (0.0 if hw is None else q * hw) + rows.gap_change(sub)
            missed = np.flatnonzero(valid & (w < 0) & ~np.isin(np.arange(len(h)), R))
            if len(missed) == 0:
                return lam, q, total
            cand = missed

    def _reaction_model(self, u0: np.ndarray, u_d: np.ndarray) -> tuple[float, float]:
        """``(R0, r)``: the load-controlled body's reaction without contact at ``q = 0``,
        and its growth per unit coordinate (zero for a body free but for its hub)."""
        k = self.load_body
        mode = self.dofs.modes[k]
        r0 = float(mode @ (self.K_d @ self._full(u0, u_d)))
        unit = self._full(self.w, mode)
        r = float(mode @ (self.K_d @ unit))
        # A body free but for its hub has r = 0 up to the round-off of the
        # stiffness of its tied surface alone (mode . K_dd . mode).
        tied = float(mode @ (self.K_d @ self._full(np.zeros_like(self.w), mode)))
        return r0, (r if r > 1e-9 * abs(tied) else 0.0)

    def _load_root(self, reaction, h, hw, C, eps_w, active, load, q0):
        """The coordinate ``q`` whose contact forces carry ``load``, and those forces.

        The reaction ``R(q) = R0 + r q - hw . lambda(q)`` (``hw``: the gaps'
        change per unit ``q``) never decreases with ``q``: it is the derivative
        of a convex energy. From ``q0`` a first step from the stiffness there
        (or to the first touch if nothing touches), doubled until the load is
        bracketed; then regula falsi (Illinois variant) on the bracket.
        """
        r0, r = reaction
        total = 0

        def residual(q):
            nonlocal total, active
            lam, n = solve_penalty_lcp(None, None, h + q * hw, eps_w, active, C=C)
            active = lam > 0
            total += n
            return r0 + r * q - float(hw @ lam) - load, lam

        tol = 1e-9 * max(abs(load), 1e-12)
        f0, lam0 = residual(q0)
        if abs(f0) <= tol:
            return q0, lam0, total
        s = 1.0 if f0 < 0 else -1.0          # the way q must go
        on = lam0 > 0
        slope = r + (float(hw[on] @ np.linalg.solve(
            C[np.ix_(on, on)] + np.diag(1.0 / eps_w[on]), hw[on])) if on.any() else 0.0)
        if slope > 0.0:
            d = -f0 / slope
        else:   # nothing touches and the body is free: go to the first touch
            closing = s * hw < 0
            if not closing.any():
                raise ContactError("the load-controlled rigid body does not move toward the "
                                   "contact: check its direction and the sign of its loads")
            d = s * 1.01 * float(np.min((h + q0 * hw)[closing] / (-s * hw[closing])))
            d = d if d != 0.0 else s * 1e-12
        q, lam = load_root(residual, q0, f0, d, tol, load)
        return q, lam, total

    def _grow_zone(self, u: np.ndarray, z: np.ndarray) -> bool:
        """Enlarge the zone if faces outside it penetrate; True if it grew (the zone
        is then projected on the current configuration and condensed anew)."""
        if self.zone.grow(self.mesh, self.model.point_values(u)):
            self.contact.update(z)
            self._condense()
            return True
        return False

    def _zone_for_largest_load(self, i: int, eq: _Equilibrium) -> bool:
        """Enlarge the zone once to the patch of the largest load; True if it grew.

        Under a load-controlled body the zone starts at the first touch and
        would grow face by face, each time condensed anew. After the first
        step the patch is known: its edge lies where the undeformed gap is
        ``s``, and a Hertzian patch's edge separation grows as ``F^(2/3)``
        (semi-axes as ``F^(1/3)``), so the largest load ``F_max`` reaches
        ``g_min + 1.5 (s - g_min) (F_max / F)^(2/3)``: the zone takes every
        face below that, with half again as margin.
        """
        if self.load_body is None or i != 0 or getattr(self, "_sized", False) or \
                any(c.search_distance is not None for c in self.case.contacts):
            return False
        self._sized = True
        loads = np.abs(self.case.rigid_bodies[self.load_body].loads)
        if loads[0] <= 0.0 or not np.any(eq.lam > 0):
            return False
        scale = (loads.max() / loads[0]) ** (2.0 / 3.0)
        distances, start = [], 0
        for st, ref in zip(self.contact.states, self.reference, strict=True):
            lam = eq.lam[start:start + len(st.gap)]
            start += len(st.gap)
            g0 = ref.gap[np.searchsorted(ref.nodes, st.nodes)]
            on = lam > 0
            g_min = float(np.min(ref.gap[np.isfinite(ref.gap)]))
            edge = float(g0[on].max()) if on.any() else g_min
            distances.append(g_min + 1.5 * max(edge - g_min, 0.0) * scale)
        wanted = ContactZone.initial(self.mesh, self.pairs, distances, self.reference)
        grew = False
        for k in range(len(self.pairs)):
            for faces, new in ((self.zone.slave_faces, wanted.slave_faces[k]),
                               (self.zone.master_faces, wanted.master_faces[k])):
                union = np.union1d(faces[k], new)
                grew |= len(union) > len(faces[k])
                faces[k] = union
        if grew:
            logger.info("contact zone sized for the largest load (%.3g)", loads.max())
            self.contact.update(eq.z)
            if self.friction:     # the largest load's patch: its edge at 2/3 of the
                # sized distance beyond the first touch, and a margin
                self.tangential = np.union1d(self.tangential, predicted_patch(
                    self.mesh, self.contact, distances, fraction=0.75))
            self._condense()
        return grew

    def _step_result(self, i: int, u: np.ndarray, eq: _Equilibrium) -> StepResult:
        c = self.contact
        forces, areas, pmax, pen = [], [], 0.0, 0.0
        pressure = np.zeros(self.mesh.n_points)
        start = 0
        for pair, st, area in zip(self.pairs, c.states, self.node_areas, strict=True):
            lk = eq.lam[start:start + len(st.gap)]
            start += len(st.gap)
            p = np.where(lk > 0, lk / st.weight, 0.0)
            forces.append(float(lk.sum()))
            p_nodes = nodal_pressure(self.mesh, pair, st, p)
            # The area of the surface nodes with a positive pressure (mid-side
            # nodes included, with the linear pressure too: it is positive
            # between a loaded corner and the next).
            areas.append(float(area[p_nodes > 0].sum()))
            pmax = max(pmax, float(p.max(initial=0.0)))
            pen = max(pen, float((p / pair.penalty).max(initial=0.0)))
            pressure = np.maximum(pressure, p_nodes)
        Ku = self.model.K @ u
        reactions = [float(Ku[d].sum()) for d in self.dofs.loaded]
        f_d = Ku[self.dofs.fixed]
        rigid_reactions = [float(m @ f_d) for m in self.dofs.modes]
        coords = self.dofs.coordinates[:, i].copy()
        if self.load_body is not None:
            coords[self.load_body] = eq.q
        if self.case.displacements:
            value = self.case.displacements[0].values[i]
        else:
            value = float(coords[0]) if len(coords) else 0.0
        return StepResult(value, forces, areas, pmax, pen, eq.iterations,
                          eq.active_set_iterations, reactions,
                          self.model.point_values(u), pressure,
                          von_mises(self.model, u) if self.stress else None,
                          [float(v) for v in coords], rigid_reactions)


def _compliance_blocks(B: sp.csr_matrix, L: np.ndarray, r: int):
    """``D(idx)``: the compliance ``B_i S^-1 B_i^T`` of the rows ``idx`` stacked as
    (normal, t1, t2) (``B``: (3 r, m), the normal rows then the two tangential
    ones, in the condensed coordinates; ``L``: the Cholesky factor of the zone's
    Schur complement ``S``), and ``D(idx, other)`` the normal rows ``other``'s
    part, as an operator (its one use is a product with the forces: one
    triangular solve of a vector, not of every column). ``W = L^-1 B_i^T``
    gives ``D = W^T W``; the columns of the rows met are kept for the
    projection, so a grown set of rows solves only for the rows it adds."""
    index = -np.ones(B.shape[0], dtype=np.int64)
    kept = {"W": np.empty((L.shape[0], 0)), "used": 0}

    def columns(rows: np.ndarray) -> np.ndarray:
        new = np.unique(rows[index[rows] < 0])
        if len(new):
            used = kept["used"]
            W_new = solve_triangular(L, B[new].T.toarray(), lower=True, check_finite=False)
            if used + len(new) > kept["W"].shape[1]:      # grow by doubling
                grown = np.empty((L.shape[0], max(2 * kept["W"].shape[1], used + len(new))))
                grown[:, :used] = kept["W"][:, :used]
                kept["W"] = grown
            kept["W"][:, used:used + len(new)] = W_new.reshape(L.shape[0], len(new))
            index[new] = np.arange(used, used + len(new))
            kept["used"] = used + len(new)
        return kept["W"][:, index[rows]]

    def block(idx: np.ndarray, other: np.ndarray | None = None):
        W = columns(np.concatenate([idx, r + idx, 2 * r + idx]))
        if other is None:
            return W.T @ W
        B_other = B[other]

        def matvec(p: np.ndarray) -> np.ndarray:
            x = solve_triangular(L, W @ np.ravel(p), lower=True, trans="T", check_finite=False)
            return B_other @ x

        return LinearOperator((len(other), W.shape[1]), matvec=matvec, dtype=float)
    return block


class _FrictionalRowSpace:
    """The frictional problem's compliances ``D`` on a :class:`_RowSpace` that keeps the
    normal and tangential rows by key (:meth:`StaticSolver._frictional_rows`).

    :meth:`block` gives ``D(idx)`` and ``D(idx, other)`` of
    :func:`~fe_impact.contact.friction.solve_frictional` from the kept compliances;
    :meth:`offset` the gaps' and slips' correction that makes the problem on them the
    current projection's where the last forces stand: a defect correction whose
    fixed point is the exact solution, as :class:`_RowSpaceCompliance`'s.
    """

    def __init__(self, keys: np.ndarray, B: sp.csr_matrix, ok: np.ndarray, space: _RowSpace,
                 solve: Callable[[np.ndarray], np.ndarray]) -> None:
        self.keys, self.B, self.space, self.solve = keys, B, space, solve
        self.r = len(ok)
        self._ok3 = np.tile(ok, 3)

    def _positions(self, rows3: np.ndarray) -> np.ndarray:
        return self.space.positions(self.keys[rows3], self.B[rows3])

    def block(self, idx: np.ndarray, other: np.ndarray | None = None) -> np.ndarray:
        r = self.r
        rows3 = np.concatenate([idx, r + idx, 2 * r + idx])
        pos = self._positions(rows3)
        if other is None:
            return self.space.C[np.ix_(pos, pos)]
        out = np.zeros((len(other), len(rows3)))
        ok = self._ok3[other]        # rows with no gap (no Jacobian) close nothing
        if ok.any():
            out[ok] = self.space.C[np.ix_(self._positions(other[ok]), pos)]
        return out

    def offset(self, p: np.ndarray) -> np.ndarray:
        """``[B; B_t] K^-1 [B; B_t]^T p - D p`` on every row (3 r; 0 where no gap) for the
        forces ``p`` (stacked normal, t1, t2), by one solve."""
        out = np.zeros(3 * self.r)
        on = np.flatnonzero(p)
        if len(on) == 0:
            return out
        ok = np.flatnonzero(self._ok3)
        exact = self.B[ok] @ self.solve(self.B[on].T @ p[on])
        kept = self.space.C[np.ix_(self._positions(ok), self._positions(on))] @ p[on]
        out[ok] = exact - kept
        return out


#: Projections running, with the rows in contact unchanged, whose change of the zone's
#: displacement falls by less than :data:`STALL_RATE` before the frictional iteration in
#: the rows' space forms the compliances of its rows in contact again (:func:`_stalls`),
#: at most :data:`MAX_REFRESHES` times in a load step.
REFRESH_AFTER = 2
#: A settling projection cuts the change by about a hundred times; a drifting one by
#: less than this (or not at all).
STALL_RATE = 0.5
MAX_REFRESHES = 2


def _stalls(history: list[float], n: int) -> bool:
    """True if each of the last ``n`` changes is at least :data:`STALL_RATE` of the one
    before. A defect correction whose kept compliances are too far from the current
    ones stops settling: on the 25 deg drive's coarse end positions, with the rows in
    contact unchanged, the change fell to 7e-4 of the contact displacement and then
    grew by about 1.2 a projection (8.1 deg roll), or stayed between 2.7e-2 and
    3.4e-2 of it (10.6 deg), where settling projections cut it a hundredfold."""
    return len(history) > n and all(history[-k] >= STALL_RATE * history[-k - 1]
                                    for k in range(1, n + 1))


def _alternates(cycle: list[tuple[np.ndarray, np.ndarray, float]], z: np.ndarray,
                lam: np.ndarray, zone: sp.spmatrix, bound: float) -> bool:
    """True if the projection iteration alternates between two states.

    ``cycle``: the last two states ``(z, lambda, q)``, oldest first; ``z``,
    ``lam``: the state just found. It alternates when that state is the one two
    projections back (its rows in contact the same, the zone's displacement
    ``zone @ z`` within ``bound``) while the last one lies further from it:
    each state is then the other's successor. Seen as a quadrature point on
    either side of a master face's edge or of the master's boundary (the
    same rows in contact), and as a row at the patch's edge that each
    state's projection puts on the other side (the rows in contact alternate
    by that row: a tip edge's rounding at 850 N, 220 and 221 rows).
    """
    if len(cycle) != 2 or cycle[0][1].shape != lam.shape or cycle[1][1].shape != lam.shape:
        return False
    back = float(np.abs(zone @ (z - cycle[0][0])).max(initial=0.0))
    change = float(np.abs(zone @ (z - cycle[1][0])).max(initial=0.0))
    return bool(np.array_equal(cycle[0][1] > 0, lam > 0) and back <= bound < change)


class _RowCompliance:
    """The contact compliance ``C = B G B^T`` on a growing set of gap rows.

    ``B``: the gap Jacobian in the condensed coordinates; only the rows
    that can touch are formed (a dense row of ``B G`` costs a pass over ``G``).
    """

    def __init__(self, B: sp.csr_matrix, G: np.ndarray) -> None:
        self.B, self.G = B, G
        self.rows = np.zeros(0, dtype=np.int64)
        self.BG = np.zeros((0, G.shape[0]))
        self.C = np.zeros((0, 0))

    def include(self, new: np.ndarray) -> None:
        new = np.setdiff1d(new, self.rows)
        if len(new) == 0:
            return
        BG_new = np.asarray(self.B[new] @ self.G)
        cross = BG_new @ self.B[self.rows].T.toarray() if len(self.rows) else \
            np.zeros((len(new), 0))
        corner = BG_new @ self.B[new].T.toarray()
        self.C = np.block([[self.C, cross.T], [cross, corner]])
        self.rows = np.concatenate([self.rows, new])
        self.BG = np.vstack([self.BG, BG_new])

    def gap_change(self, lam: np.ndarray) -> np.ndarray:
        """Change of every row's gap under forces ``lam`` on :attr:`rows`."""
        return self.B @ (self.BG.T @ lam)

    def offset(self) -> float:
        """Correction of :attr:`rows`' gaps for an inexact :attr:`C` (none: it is exact)."""
        return 0.0


class _RowSpace:
    """Compliances of gap rows, ``C = B K^-1 B^T``, kept by row.

    :meth:`prime` forms them for every row of the zone at once
    (:func:`~fe_impact.contact.condensed.row_compliance`). A row met later
    (its gap finite only after the deformation) enters by a solve ``K^-1
    b^T`` (in blocks of :data:`ROW_BLOCK`). Each row keeps the Jacobian ``b`` of the projection
    it entered at; those move a little as the projection follows the
    deformation, so the kept ``C`` is close to, not equal to, the current
    one: :class:`_RowSpaceCompliance` corrects the gaps by the difference
    at the last forces (a defect correction whose fixed point is the exact
    solution).
    """

    def __init__(self, K: sp.csr_matrix, solve: Callable[[np.ndarray], np.ndarray]) -> None:
        self.K, self.solve = K, solve
        self.seconds = 0.0     # spent forming the compliances of rows met later
        self.index: dict[int, int] = {}
        self.B0 = sp.csr_matrix((0, K.shape[0]))
        self.C = np.zeros((0, 0))

    def prime(self, keys: np.ndarray, B: sp.csr_matrix) -> None:
        """Form the compliances of the rows ``keys`` (Jacobian rows ``B``, every one
        nonzero) at once, in place of those kept (its time is the caller's)."""
        self.C = row_compliance(self.K, B)
        self.B0 = B.tocsr()
        self.index = {k: i for i, k in enumerate(keys.tolist())}

    def positions(self, keys: np.ndarray, B: sp.csr_matrix) -> np.ndarray:
        """Positions in :attr:`C` of the rows ``keys`` (Jacobian rows ``B``), the
        rows not met before solved for and added."""
        new = [i for i, k in enumerate(keys.tolist()) if k not in self.index]
        if new:
            t = time.perf_counter()
            Bn = B[new].tocsr()
            m0, m = self.C.shape[0], len(new)
            C = np.zeros((m0 + m, m0 + m))
            C[:m0, :m0] = self.C
            for a in range(0, m, ROW_BLOCK):
                X = self.solve(Bn[a:a + ROW_BLOCK].T.toarray())   # (n, k) for (n, k)
                b = slice(m0 + a, m0 + a + X.shape[1])
                C[:m0, b] = self.B0 @ X
                C[m0:, b] = Bn @ X
            # the new rows' block solved column by column: symmetric up to round-off
            C[m0:, :m0] = C[:m0, m0:].T
            C[m0:, m0:] = 0.5 * (C[m0:, m0:] + C[m0:, m0:].T)
            self.C = C
            self.B0 = sp.vstack([self.B0, Bn]).tocsr()
            for i, k in enumerate(keys[new].tolist()):
                self.index[k] = m0 + i
            self.seconds += time.perf_counter() - t
        return np.array([self.index[k] for k in keys.tolist()], dtype=np.int64)

    def refresh(self, keys: np.ndarray, B: sp.csr_matrix) -> None:
        """Re-form the compliances of the rows ``keys`` with their current Jacobian rows
        ``B`` (each kept row's ``b`` is that of the projection it entered at).

        Their columns ``B0 K^-1 b^T`` are solved for again with the other rows'
        kept Jacobians, and their rows follow by symmetry: the kept ``C`` is then
        the current projection's on these rows and between them and the others.
        """
        t = time.perf_counter()
        pos = self.positions(keys, B)
        m = self.C.shape[0]
        keep = np.ones(m)
        keep[pos] = 0.0
        put = sp.csr_matrix((np.ones(len(pos)), (pos, np.arange(len(pos)))),
                            shape=(m, len(pos)))
        self.B0 = (sp.diags(keep) @ self.B0 + put @ B).tocsr()
        Bn = B.tocsr()
        for a in range(0, len(pos), ROW_BLOCK):
            X = self.solve(Bn[a:a + ROW_BLOCK].T.toarray())
            cols = pos[a:a + X.shape[1]]
            col = self.B0 @ X
            self.C[:, cols] = col
            self.C[cols, :] = col.T
        block = self.C[np.ix_(pos, pos)]
        self.C[np.ix_(pos, pos)] = 0.5 * (block + block.T)
        self.seconds += time.perf_counter() - t


class _RowSpaceCompliance:
    """:class:`_RowCompliance` of one projection on a :class:`_RowSpace`.

    ``C`` is the kept compliance of :attr:`rows`; the gaps' change under
    forces is exact (one solve with the current Jacobian ``B``). With
    :meth:`correct`, :meth:`offset` holds ``B K^-1 B^T lam - C lam`` of the
    last forces ``lam`` on the rows, so the contact problem on ``C`` is the
    current one where it last stood.
    """

    def __init__(self, B: sp.csr_matrix, keys: np.ndarray, space: _RowSpace,
                 solve: Callable[[np.ndarray], np.ndarray]) -> None:
        self.B, self.keys, self.space, self.solve = B, keys, space, solve
        self.rows = np.zeros(0, dtype=np.int64)
        self.C = np.zeros((0, 0))
        self._lam: np.ndarray | None = None
        self._exact: np.ndarray | None = None

    def correct(self, lam: np.ndarray, exact: np.ndarray) -> None:
        """Correct by the last forces ``lam`` (every row) and their exact gap
        change ``exact`` (every row)."""
        self._lam, self._exact = lam, exact

    def include(self, new: np.ndarray) -> None:
        if self._lam is not None:
            new = np.union1d(new, np.flatnonzero(self._lam > 0))
        new = np.setdiff1d(new, self.rows)
        if len(new) == 0:
            return
        self.rows = np.concatenate([self.rows, new])
        pos = self.space.positions(self.keys[self.rows], self.B[self.rows])
        self.C = self.space.C[np.ix_(pos, pos)]

    def offset(self) -> np.ndarray | float:
        if self._lam is None:
            return 0.0
        on = np.flatnonzero(self._lam > 0)     # all among rows (include adds them)
        sorter = np.argsort(self.rows)
        order = sorter[np.searchsorted(self.rows, on, sorter=sorter)]
        return self._exact[self.rows] - self.C[:, order] @ self._lam[on]

    def gap_change(self, lam: np.ndarray) -> np.ndarray:
        """Change of every row's gap under forces ``lam`` on :attr:`rows` (exact)."""
        return self.B @ self.solve(self.B[self.rows].T @ lam)


def _diagnosis(history: list[float], scale: float, face: float) -> str:
    """What helps when the projection iteration does not converge.

    ``history``: the zone's displacement change per iteration (m); ``scale``:
    the contact displacement (m); ``face``: the contact faces' size (m).
    """
    tail = history[-4:]
    if len(tail) == 4 and max(tail) < 0.02 * face and min(tail) > 0.3 * max(tail):
        return (f"the change stalls far below a face size ({face:.3g} m) while the contact "
                f"state cycles at the patch edge: loosen [analysis] tolerance to about "
                f"{2 * max(tail) / max(scale, 1e-30):.0e} or refine the contact faces")
    return ("raise [analysis] max_iterations, or apply the load in smaller steps "
            "(more [[displacements]] values or loads)")


def _check_held(case: Case, mesh: FEMesh, fixed: np.ndarray) -> None:
    """Refuse a body (a set of connected elements) without a prescribed DOF: no support,
    prescribed displacement or rigid body holds it, so its stiffness is singular and
    a static case cannot place it (contact alone does not hold a body before it
    touches)."""
    from scipy.sparse.csgraph import connected_components

    cells = mesh.cells
    n = len(mesh.points)
    rows = np.repeat(np.arange(len(cells)), cells.shape[1])
    graph = sp.csr_matrix((np.ones(rows.size), (rows, cells.ravel())),
                          shape=(len(cells), n))
    _, label = connected_components(graph @ graph.T, directed=False)
    held = np.zeros(3 * (int(mesh.point_dof.max()) + 1), dtype=bool)
    held[fixed] = True
    used = mesh.point_dof >= 0
    held_nodes = np.zeros(n, dtype=bool)
    held_nodes[used] = held.reshape(-1, 3)[mesh.point_dof[used]].any(axis=1)
    element_held = np.zeros(label.max() + 1, dtype=bool)
    element_held[np.unique(label[np.flatnonzero(graph @ held_nodes)])] = True
    loose = np.flatnonzero(~element_held)
    if not loose.size:
        return
    names = sorted({name for name, elements in mesh.volumes.items()
                    if np.isin(label[elements], loose).any()})
    raise CaseError(f"{case.path.name}: volume {', '.join(map(repr, names))} is held by no "
                    "[[supports]], [[displacements]] or [[rigid_bodies]] surface: a static "
                    "case needs every body held (contact alone does not hold it before it "
                    "touches)")


def load_root(residual: Callable, q0: float, f0: float, d: float, tol: float,
              load: float) -> tuple[float, object]:
    """The root of a load residual that never decreases with the coordinate ``q``.

    From ``q0`` (residual ``f0``) steps of ``d``, doubled until the sign of the
    residual changes, bracket the root; regula falsi (Illinois variant: the
    end kept twice in a row has its residual halved) then closes the bracket.
    ``residual(q)`` returns ``(f, payload)``; the root's ``(q, payload)`` is
    returned once ``|f| <= tol`` or the bracket is 1e-13 of ``q`` wide.
    ``load`` [N or N m] only names the load in the errors.
    """
    a, fa = q0, f0
    for _ in range(MAX_LOAD_ITERATIONS):
        b = a + d
        fb, payload = residual(b)
        if abs(fb) <= tol:
            return b, payload
        if (fb < 0) != (f0 < 0):
            break
        a, fa, d = b, fb, 2.0 * d
    else:
        raise ContactError(f"no motion of the load-controlled rigid body carries a load "
                           f"of {load:g}")
    lo, f_lo, hi, f_hi = (a, fa, b, fb) if a < b else (b, fb, a, fa)
    side = 0
    for _ in range(MAX_LOAD_ITERATIONS):
        q = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        f, payload = residual(q)
        if abs(f) <= tol or hi - lo <= 1e-13 * max(abs(hi), abs(lo)):
            return q, payload
        if f < 0:
            lo, f_lo = q, f
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = q, f
            if side == 1:
                f_lo *= 0.5
            side = 1
    raise ContactError(f"the load-controlled rigid body's coordinate did not converge to "
                       f"a load of {load:g} in {MAX_LOAD_ITERATIONS} iterations")
