"""Displacement-controlled static contact between linear elastic bodies.

The bodies are linear, only contact is nonlinear, and only a small patch of
surface can touch. The solver therefore

1. factorises the free-free stiffness once;
2. condenses the stiffness onto the DOFs of the contact zone (the
   candidate faces within the search distance) with a Schur complement,
   giving the compliance ``G`` of those DOFs;
3. per load step, solves the no-contact displacement ``u0``, then iterates
   contact forces ``lambda`` on the small dense problem: gaps on the
   deformed configuration, ``u_c = u0_c + G B^T lambda``, penalty law
   ``lambda = eps w <-g>``, until the active set and the displacement
   converge;
4. recovers the full field with one more back-substitution, and checks the
   whole slave surface: penetration outside the candidate zone enlarges the
   zone and repeats the step.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fe_impact.contact.lcp import solve_penalty_lcp
from fe_impact.contact.surfaces import nodal_areas, nodal_pressure
from fe_impact.contact.zone import contact_pairs
from fe_impact.errors import ContactError
from fe_impact.fe.case import Case
from fe_impact.fe.elasticity import ElasticModel, build_model, von_mises
from fe_impact.fe.kinematics import point_dofs
from fe_impact.fe.linalg import SPDSolver, condensed_compliance
from fe_impact.fe.mesh import FEMesh
from fe_impact.solvers.model import ContactSetup, Prescribed, displacement_reach

logger = logging.getLogger(__name__)

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
    von_mises: np.ndarray = field(repr=False)  # (n_elements,)


@dataclass
class StaticResult:
    steps: list[StepResult]
    mesh: FEMesh
    model: ElasticModel
    penalties: list[float]
    timings: dict[str, float]
    info: dict


class StaticSolver:
    """Set up once per case; :meth:`run` solves the load steps."""

    def __init__(self, case: Case, mesh: FEMesh) -> None:
        self.case = case
        self.timings: dict[str, float] = {}
        t = time.perf_counter()
        self.mesh = mesh
        case.check_groups(self.mesh)
        self.timings["mesh"] = time.perf_counter() - t
        t = time.perf_counter()
        self.model = build_model(self.mesh, case.materials)
        self.timings["assembly"] = time.perf_counter() - t
        self.dofs = Prescribed.build(case, self.mesh, self.model.n_dofs)
        free, fixed = self.dofs.free, self.dofs.fixed
        t = time.perf_counter()
        K = self.model.K
        self.K_ff = K[free][:, free].tocsr()
        self.K_fd = K[free][:, fixed].tocsr()
        self.solver = SPDSolver(self.K_ff)
        self.timings["factorisation"] = time.perf_counter() - t
        self.pairs = contact_pairs(case, self.mesh, self.model)
        self.node_areas = [nodal_areas(self.mesh, p.slave) for p in self.pairs]
        t = time.perf_counter()
        self.zone = ContactSetup.build(case, self.mesh, self.pairs,
                                       displacement_reach(case)).zone
        self.zone_dofs, self.G = self._condense()
        self.timings["condensation"] = time.perf_counter() - t

    def _condense(self) -> tuple[np.ndarray, np.ndarray]:
        """The free DOFs of the contact zone and their compliance (Schur complement)."""
        free = self.dofs.free_index[point_dofs(self.mesh, self.zone.points())]
        zone_dofs = np.unique(free[free >= 0])
        logger.info("contact zone: %d DOFs condensed", len(zone_dofs))
        return zone_dofs, condensed_compliance(self.K_ff, zone_dofs)

    # -- load steps -----------------------------------------------------------
    def run(self, step_hook: Callable[[int, StepResult], None] | None = None) -> StaticResult:
        """Solve every load step; ``step_hook(i, step)`` is called after each."""
        steps = []
        t_contact = 0.0
        for i in range(self.case.n_steps):
            t = time.perf_counter()
            step = self.solve_step(i)
            t_contact += time.perf_counter() - t
            steps.append(step)
            if step_hook is not None:
                step_hook(i, step)
        self.timings["steps"] = t_contact
        info = {"n_dofs": int(self.model.n_dofs), "n_free_dofs": int(len(self.dofs.free)),
                "n_contact_dofs": int(len(self.zone_dofs)), "element_order": self.mesh.order,
                "n_elements": int(len(self.mesh.cells)), "n_points": int(self.mesh.n_points),
                "factor_nonzeros": self.solver.factor_nnz}
        return StaticResult(steps, self.mesh, self.model, [p.penalty for p in self.pairs],
                            dict(self.timings), info)

    def _dirichlet(self, i: int) -> np.ndarray:
        return self.dofs.values[:, i]

    def solve_step(self, i: int) -> StepResult:
        u_d = self._dirichlet(i)
        rhs0 = -(self.K_fd @ u_d)
        u = np.zeros(self.model.n_dofs)
        u[self.dofs.fixed] = u_d
        u[self.dofs.free] = self.solver.solve(rhs0)
        for _ in range(5):  # enlargements of the contact zone
            u_c, lam, states, its, ai = self._contact_iterations(u)
            u_full = self._recover(u_d, rhs0, states, lam)
            if not self._grow_zone(u_full):
                return self._step_result(i, u_full, states, lam, its, ai)
        raise ContactError("the contact zone kept growing: set a larger "
                           "[[contacts]] search_distance")

    def _contact_iterations(self, u0: np.ndarray):
        tol = self.case.analysis.tolerance
        cdofs = self.dofs.free[self.zone_dofs]
        u = u0.copy()
        lam, active, total = None, None, 0
        for it in range(1, self.case.analysis.max_iterations + 1):
            states = self._gap_states(u)
            B = sp.vstack([s.B for s in states]).tocsr()[:, cdofs]
            gap = np.concatenate([s.gap for s in states])
            eps_w = np.concatenate([p.penalty * s.weight for p, s in zip(self.pairs, states,
                                                                         strict=True)])
            ok = np.isfinite(gap)
            h = np.where(ok, gap - B @ (u[cdofs] - u0[cdofs]), 0.0)
            lam = np.zeros(len(gap))
            lam[ok], n_as = solve_penalty_lcp(B[ok], self.G, h[ok], eps_w[ok],
                                              None if active is None else active[ok])
            total += n_as
            u_new = u0[cdofs] + self.G @ (B.T @ lam)
            change = np.abs(u_new - u[cdofs]).max(initial=0.0)
            scale = np.abs(u_new - u0[cdofs]).max(initial=0.0)
            new_active = lam > 0
            u[cdofs] = u_new
            if active is not None and np.array_equal(new_active, active) and \
                    change <= tol * max(scale, 1e-30):
                return u, lam, states, it, total
            active = new_active
        raise ContactError(f"contact did not converge in {self.case.analysis.max_iterations} "
                           f"iterations (last displacement change {change:.3g} m); raise "
                           "[analysis] max_iterations or check the penalty")

    def _gap_states(self, u: np.ndarray):
        return self.zone.gap_states(self.mesh, self.model.point_values(u))

    def _recover(self, u_d, rhs0, states, lam) -> np.ndarray:
        B = sp.vstack([s.B for s in states]).tocsr() if states else None
        rhs = rhs0.copy()
        if B is not None and B.shape[0]:
            rhs += (B.T @ lam)[self.dofs.free]
        u = np.zeros(self.model.n_dofs)
        u[self.dofs.fixed] = u_d
        u[self.dofs.free] = self.solver.solve(rhs)
        return u

    def _grow_zone(self, u: np.ndarray) -> bool:
        """Enlarge the zone if faces outside it penetrate; True if it grew."""
        if self.zone.grow(self.mesh, self.model.point_values(u)):
            self.zone_dofs, self.G = self._condense()
            return True
        return False

    def _step_result(self, i, u, states, lam, its, ai) -> StepResult:
        forces, areas, pmax, pen = [], [], 0.0, 0.0
        pressure = np.zeros(self.mesh.n_points)
        start = 0
        for pair, st, area in zip(self.pairs, states, self.node_areas, strict=True):
            lk = lam[start:start + len(st.gap)]
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
        value = self.case.displacements[0].values[i] if self.case.displacements else 0.0
        return StepResult(value, forces, areas, pmax, pen, its, ai, reactions,
                          self.model.point_values(u), pressure, von_mises(self.model, u))

