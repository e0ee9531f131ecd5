"""Transient elastodynamics with penalty contact: explicit and Newmark integration.

The bodies are linear elastic (J2 plasticity near the contact if a material
has a yield strength); contact is the other nonlinearity. Unknowns are
reduced coordinates ``z``: the free DOFs plus one DOF per rigid body, with
``u = T z`` (:class:`~fe_impact.fe.kinematics.Kinematics`). The equations of
motion are

    M_r z'' + K_r z = B_r^T lambda(z),   M_r = T^T M T + diag(inertia), K_r = T^T K T,

with the penalty forces ``lambda_a = eps w_a <-g_a>`` on the weighted nodal
gaps ``g = g_ref + B_r (z - z_ref)``, linearised about the last projection of
the slave nodes on the master surface and re-projected whenever the contact
zone has moved by more than a small fraction of an element
(:class:`~fe_impact.contact.linearised.ContactModel`).

Where things are
----------------
- set-up shared with the static solver: :mod:`fe_impact.solvers.model`;
- the integrators, one step at a time: :mod:`fe_impact.solvers.integrators`
  (``explicit``: central difference with the HRZ-lumped mass, stable step
  ``2 / omega_max`` by Lanczos with every zone node in contact;
  ``newmark``: average acceleration or HHT-alpha, consistent mass, contact
  condensed onto the zone by :class:`~fe_impact.contact.condensed.CondensedContact`);
- approach, restitution, residual indentation:
  :mod:`fe_impact.solvers.measurements`.

:class:`DynamicSolver` sets a case up and :meth:`DynamicSolver.run` steps it:
each step is recorded (history, energy check, output frames) and the run
ends at the case's duration or on a :class:`Stop` condition.
"""

from __future__ import annotations

import enum
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from fe_impact.contact.condensed import CondensedContact, StepContact
from fe_impact.contact.friction import ExplicitFriction, ImplicitFriction, pair_laws
from fe_impact.contact.linearised import (
    IMPACT_PATCH_FRACTION,
    ContactModel,
    SurfaceMonitor,
    flight_patch,
    predicted_patch,
)
from fe_impact.contact.zone import (
    PENALTY_FACTOR_EXPLICIT,
    ContactZone,
    contact_pairs,
    face_size,
)
from fe_impact.errors import CaseError, SolverError
from fe_impact.fe.case import Case
from fe_impact.fe.elasticity import (
    ElasticModel,
    assemble_mass,
    build_model,
    von_mises,
)
from fe_impact.fe.kinematics import Kinematics, point_dofs, rigid_mode
from fe_impact.fe.mesh import FEMesh
from fe_impact.solvers import integrators as ti
from fe_impact.solvers.measurements import (
    ImpactMeasurements,
    ImpactProbe,
    SeparationWatch,
    impact_measurements,
)
from fe_impact.solvers.model import ContactSetup, gap_reach

__all__ = ["HISTORY_KEYS", "DynamicResult", "DynamicSolver", "Frame", "ImpactMeasurements",
           "Stop", "impact_measurements"]

logger = logging.getLogger(__name__)

#: Re-project the slave nodes when the zone has moved by this fraction of the
#: smallest contact-face size since the last projection.
REPROJECT_FRACTION = 0.05


# -- results -----------------------------------------------------------------------


@dataclass
class Frame:
    """Fields at one output time."""

    time: float
    u: np.ndarray          # (n_points, 3) m
    v: np.ndarray          # (n_points, 3) m/s
    pressure: np.ndarray   # (n_points,) Pa
    von_mises: np.ndarray  # (n_elements,) Pa
    plastic_strain: np.ndarray | None = None  # (n_elements,) max equivalent plastic strain


@dataclass
class DynamicResult:
    """A run's histories, measurements and model data.

    ``frames`` lists every output time (s), the times of ``output_history``;
    ``frame_hook`` received the fields at every ``frame_stride``-th of them
    (and the last), so with a stride above 1 there are fewer VTU frames.
    """

    history: dict[str, np.ndarray]     # every step
    output_history: dict[str, np.ndarray]  # at the output interval
    measurements: ImpactMeasurements
    info: dict
    timings: dict[str, float]
    mesh: FEMesh = field(repr=False)
    model: object = field(repr=False)
    frames: list[float] = field(default_factory=list)


#: A start is a rigid motion when ``|K v0|`` is at most this fraction of
#: ``| |K| |v0| |``: on a rigid field only the rounding of K's rows is left
#: (7e-17 measured on a tooth pair whose sectors turn with their rotors; 1 for
#: sectors at rest behind turning hubs).
RIGID_START = 1e-10

HISTORY_KEYS = ("time", "contact_force", "approach", "normal_velocity", "kinetic_energy",
                "strain_energy", "contact_energy", "plastic_dissipation", "friction_dissipation",
                "total_energy")


class Stop(enum.Enum):
    """Why a run ended before the case's duration."""

    SEPARATED = "separated"   # apart for [analysis] stop_after_separation x the contact
    HOOK = "hook"             # the step hook asked for it


@dataclass
class _RunLog:
    """What a run records: every step's history row, the output steps, the counters."""

    separation: SeparationWatch
    frame_stride: int = 1           # fields at every frame_stride-th output time
    rows: dict[str, list[float]] = field(
        default_factory=lambda: {k: [] for k in HISTORY_KEYS})
    output_index: list[int] = field(default_factory=list)
    frames: list[float] = field(default_factory=list)   # output times (s)
    next_output: float = 0.0
    energy0: float | None = None
    zone_growths: int = 0
    free_steps: int = 0             # Newmark steps of the rigid flight, without a solve
    warned_boundary: bool = False
    plastic: ti.PlasticStats = field(default_factory=ti.PlasticStats)

    def history(self) -> dict[str, np.ndarray]:
        """The rows as arrays, cut to the steps every quantity has.

        A stop signal (Ctrl-C, SIGTERM) can arrive while a step's row is being
        appended, leaving some lists one entry longer; that step is dropped.
        """
        n = min(len(v) for v in self.rows.values())
        return {k: np.asarray(v[:n]) for k, v in self.rows.items()}


# -- solver --------------------------------------------------------------------------


class _Clock:
    """Wall and CPU time of consecutive phases, into two dicts."""

    def __init__(self, wall: dict[str, float], cpu: dict[str, float]) -> None:
        self.wall, self.cpu = wall, cpu
        self._w, self._c = time.perf_counter(), time.process_time()

    def lap(self, name: str) -> None:
        w, c = time.perf_counter(), time.process_time()
        self.wall[name] = w - self._w
        self.cpu[name] = c - self._c
        self._w, self._c = w, c


class DynamicSolver:
    """Set up once per case; :meth:`run` integrates to the case's duration.

    ``free_flight`` (default True): Newmark steps the flight to first touch
    without solves when the start is a rigid motion (:meth:`_rigid_start`).
    """

    free_flight: bool = True

    def __init__(self, case: Case, mesh: FEMesh) -> None:
        _check_case(case)
        self.case = case
        a = case.analysis
        self.timings: dict[str, float] = {}       # wall time of each set-up phase (s)
        self.cpu_timings: dict[str, float] = {}   # and the process's CPU time (s)
        clock = _Clock(self.timings, self.cpu_timings)
        self.mesh = mesh
        case.check_groups(self.mesh)
        clock.lap("mesh")
        self.model = build_model(self.mesh, case.materials)
        self.kin = Kinematics.build(case, self.mesh, self.model.n_dofs)
        self.explicit = a.integrator == "explicit"
        self.K = self.kin.reduce(self.model.K)
        self.M, self.m = self.kin.mass(assemble_mass(self.model), lumped=self.explicit)
        clock.lap("assembly")
        self.pairs = contact_pairs(case, self.mesh, self.model, PENALTY_FACTOR_EXPLICIT
                                   if self.explicit else None)
        clock.lap("contact_pairs")
        setup = ContactSetup.build(case, self.mesh, self.pairs, gap_reach(self.mesh))
        self.zone = setup.zone
        self.reach = setup.reach
        laws = pair_laws(case.contacts)
        h_min = min(face_size(self.mesh, p.slave) for p in self.pairs)
        slip_tolerance = None
        if any(law is not None for law in laws):
            # Friction slides the faces along each other: the linearised slips and
            # tangent frames hold while a slave point stays near its master point, so
            # a slide of a fraction of the zone's smallest slave face re-projects too
            # (against the whole surface's median face, a sphere's coarse far side: 75
            # um against 0.3 mm contact faces, a re-projection after 75 um of slide
            # jumped the energy by 3%). The zone's deformation keeps the frictionless
            # tolerance: held to the smallest face as well, a normal impact
            # re-projected 21 times instead of 4, which made its steps 2.5 times dearer.
            slip_tolerance = REPROJECT_FRACTION * min(
                (face_size(self.mesh, p.slave, np.min, f) for p, f in
                zip(self.pairs, self.zone.slave_faces, strict=True) if len(f)), default=h_min)
        self.contact = ContactModel(self.mesh, self.model, self.kin, self.zone,
                                    REPROJECT_FRACTION * h_min, laws, slip_tolerance)
        #: the integrator's friction (None: frictionless); Newmark's is made with its step
        self.friction = ExplicitFriction() if self.contact.friction and self.explicit else None
        self.monitor = SurfaceMonitor(self.mesh, self.kin, self.zone, setup.reach, setup.states)
        clock.lap("contact_setup")
        self.probe = ImpactProbe.build(case, self.mesh, self.kin, self.M, self.contact.states[0])
        self.plastic, self.plastic_radius = plastic_zone(case, self.mesh, self.model, self.kin,
                                                         self.zone, self.probe.x_contact)
        self.v0 = initial_velocity(case, self.mesh, self.kin, self.model.n_dofs)
        clock.lap("probe_and_plastic_zone")
        self.dt_stable = (ti.stable_time_step(self.K, self.m, self.contact) if self.explicit
                          else None)
        _check_stick_resolved(case, self.dt_stable, self.friction is not None)
        self.dt = ti.time_step(case, self.dt_stable)
        self.scheme, self.condensed = self._scheme()
        clock.lap("stable_step" if self.explicit else "factorisation")
        if self.condensed is not None:
            self.timings["condensation"] = self.condensed.seconds
            self.timings["factorisation"] -= self.condensed.seconds
            self.cpu_timings["condensation"] = self.condensed.cpu_seconds
            self.cpu_timings["factorisation"] -= self.condensed.cpu_seconds
        self.log = _RunLog(SeparationWatch(a.stop_after_separation))
        self._flying = False    # in the rigid flight to first touch (set by each run)

    def _scheme(self) -> tuple[ti.CentralDifference | ti.Newmark, CondensedContact | None]:
        """The integrator and, for Newmark, the factorised and condensed contact problem."""
        if self.explicit:
            return ti.CentralDifference(self.dt, self.K, self.m), None
        nm = ti.Newmark(self.dt, self.K, self.M, self.case.analysis.hht_alpha)
        if self.contact.friction:
            self.friction = ImplicitFriction(self.dt)
        # One factorisation serves the solves and the condensation (see ZoneSolver).
        tangential = self._predicted_tangential() if self.contact.friction else None
        return nm, CondensedContact(self.mesh, self.kin, self.contact,
                                    nm.effective_stiffness(), nm.force_factor,
                                    friction=self.friction, tangential=tangential)

    def _predicted_tangential(self) -> np.ndarray:
        """The nodes whose tangent coordinates the friction's condensation starts with
        (the patch grows from them as contact spreads; see
        :attr:`CondensedContact.tangential`): the rows within
        :data:`~fe_impact.contact.linearised.IMPACT_PATCH_FRACTION` of a pair's
        given search distance (which a tooth impact sets beyond its Hertz approach)
        and, from a rigid start, those the first touch's growth would take. Without
        them the first contact made a second factorisation."""
        c = self.contact
        reach = [r if spec.search_distance is not None else None
                 for r, spec in zip(self.reach, self.case.contacts, strict=True)]
        nodes = predicted_patch(self.mesh, c, reach, fraction=IMPACT_PATCH_FRACTION)
        if self.free_flight and self.v0 is not None and np.any(self.v0):
            K = self.K
            size = float(np.linalg.norm(abs(K) @ np.abs(self.v0)))
            if size > 0.0 and float(np.linalg.norm(K @ self.v0)) <= RIGID_START * size:
                nodes = np.union1d(nodes, flight_patch(self.mesh, c, c.B_full @ self.v0,
                                                       self.dt))
        return nodes

    @property
    def initial_gap(self) -> float:
        """Smallest weighted gap of the first pair at the start (m); see :class:`ImpactProbe`."""
        return self.probe.initial_gap

    @property
    def effective_mass(self) -> float:
        """``1/(1/m_s + 1/m_m)`` of the two sides along the contact normal (kg)."""
        return self.probe.effective_mass

    @property
    def n_steps(self) -> int:
        return max(1, int(round(self.case.analysis.duration / self.dt)))

    # -- integration ---------------------------------------------------------------
    def run(self, frame_hook: Callable[[Frame], None] | None = None,
            progress: Callable[[float], None] | None = None,
            step_hook: Callable[[ti.State, dict[str, float]], object] | None = None,
            frame_stride: int = 1) -> DynamicResult:
        """Integrate over the case's duration.

        ``frame_hook(frame)`` receives the fields at every ``frame_stride``-th
        output time (and at t = 0 and the last step); the output history keeps
        every output time. ``progress(fraction)`` is called now and then;
        ``step_hook(state, row)`` sees every step (the integrator's
        :class:`~fe_impact.solvers.integrators.State` and its history row)
        and ends the run by returning a true value.
        """
        if frame_stride < 1:
            raise ValueError(f"frame_stride = {frame_stride}: must be at least 1")
        t0 = time.perf_counter()
        self.log = _RunLog(SeparationWatch(self.case.analysis.stop_after_separation),
                           frame_stride)
        try:
            # Steps are many small vector operations: OpenBLAS threads waking for each
            # dot product cost more than the product (6x slower steps measured on 2
            # cores, with MKL's threads spinning after each PARDISO call).
            with threadpool_limits(limits={i["prefix"]: 1 for i in threadpool_info()
                                           if i["internal_api"] == "openblas"}):
                stop = self._integrate(frame_hook, progress, step_hook)
        finally:
            self.timings["integration"] = time.perf_counter() - t0
        if stop is Stop.SEPARATED:
            logger.info("stopped at t = %.6g s, %.3g contact durations after separation",
                        self.log.rows["time"][-1], self.case.analysis.stop_after_separation)
        elif stop is Stop.HOOK:
            logger.info("stopped by the step hook at t = %.6g s", self.log.rows["time"][-1])
        return self.result()

    def _integrate(self, frame_hook, progress, step_hook) -> Stop | None:
        """Step from the initial state until the duration or a stop condition."""
        state = self._start()
        self._flying = self.free_flight and self._rigid_start(state)
        for n in range(self.n_steps + 1):
            if n > 0:
                state = self._advance(state)
            stop = self._record(state, frame_hook, progress, step_hook)
            if stop is not None:
                return stop
            if n > 0 and not self.explicit and self._watch_zone(state.z):
                state = replace(state, active=None)   # new zone rows: no warm start
        return None

    def _start(self) -> ti.State:
        if self.explicit:
            return ti.central_difference_start(self.scheme, self.v0, self.contact)
        return ti.newmark_start(self.scheme, self.v0, self.contact)

    def _rigid_start(self, s: ti.State) -> bool:
        """True if ``s`` is a rigid motion with open gaps (Newmark): see
        :func:`~fe_impact.solvers.integrators.newmark_free_step`."""
        if self.explicit or np.any(s.z) or np.any(s.a) or np.any(s.lam > 0.0):
            return False
        K = self.scheme.K
        size = float(np.linalg.norm(abs(K) @ np.abs(s.v)))
        return size > 0.0 and float(np.linalg.norm(K @ s.v)) <= RIGID_START * size

    def _advance(self, s: ti.State) -> ti.State:
        if self._flying:
            free = ti.newmark_free_step(s, self.scheme, self.contact)
            if free is not None:
                self.log.free_steps += 1
                return free
            self._flying = False
        if self.explicit:
            return ti.central_difference_step(s, self.scheme, self.contact, self.plastic,
                                              self._watch_zone, self.friction)
        return ti.newmark_step(s, self.scheme, self.contact, self._newmark_solve, self.plastic,
                               self.case.analysis.max_iterations, self.friction)

    def _newmark_solve(self, rhs: np.ndarray, active: np.ndarray | None,
                       z_n: np.ndarray) -> StepContact:
        if self.plastic is None:
            if self.friction is not None:
                return self.condensed.solve_frictional(rhs, z_n)
            return self.condensed.solve(rhs, active)
        return ti.plastic_newmark_solve(rhs, active, z_n, self.condensed, self.plastic,
                                        self.case.analysis.plastic_solver, self.log.plastic)

    def _watch_zone(self, z: np.ndarray) -> bool:
        """Grow the zone if faces outside it come close; True if it grew."""
        if not self.monitor.close_outside(z):
            return False
        up = self.contact.point_values(z)
        if not self.zone.grow(self.mesh, up, margin=self.monitor.grow_margin()):
            return False
        self.log.zone_growths += 1
        self.contact.update(z)
        if self.condensed is not None:
            self.condensed.condense()
        return True

    # -- recording -------------------------------------------------------------------
    def _record(self, s: ti.State, frame_hook, progress, step_hook) -> Stop | None:
        """Append the step to the history, check it, write a frame when due; why to stop."""
        log, a = self.log, self.case.analysis
        row = self._history_row(s)
        for k, v in row.items():
            log.rows[k].append(v)
        if log.energy0 is None:
            log.energy0 = row["total_energy"]
        self._check(s, row["total_energy"])
        t = row["time"]
        stop = None
        if log.separation.apart(t, row["contact_force"], row["approach"]):
            stop = Stop.SEPARATED
        if step_hook is not None and step_hook(s, row) and stop is None:
            stop = Stop.HOOK
        if t >= log.next_output - 0.5 * self.dt or s.n == self.n_steps or stop is not None:
            log.output_index.append(len(log.rows["time"]) - 1)
            log.next_output += a.output_step
            log.frames.append(t)
            last = s.n == self.n_steps or stop is not None
            if frame_hook is not None and ((len(log.frames) - 1) % log.frame_stride == 0
                                           or last):
                frame_hook(self._frame(t, s))
            if progress is not None:
                progress(min(t / a.duration, 1.0))
        return stop

    def _history_row(self, s: ti.State) -> dict[str, float]:
        """Time, contact force, approach, normal velocity and energies of one step."""
        v = s.v
        ke = 0.5 * float(v @ (self.m * v) if self.explicit else v @ (self.scheme.M_product @ v))
        ce = self.contact.energy(s.lam)
        strain, dis, fr = s.strain_energy, 0.0, 0.0
        if self.plastic is not None:
            strain += self.plastic.energy_correction(s.z)
            dis = self.plastic.dissipation()
        total = ke + strain + ce + dis
        friction = self._friction_energies()
        if friction is not None:   # the tangential springs' energy counts as contact energy
            ce += friction[0]
            fr = friction[1]
            total += friction[0] + fr
        return {"time": s.n * self.dt, "contact_force": float(s.lam.sum()),
                "approach": self.probe.approach(s.z),
                "normal_velocity": self.probe.normal_velocity(v), "kinetic_energy": ke,
                "strain_energy": strain, "contact_energy": ce, "plastic_dissipation": dis,
                "friction_dissipation": fr, "total_energy": total}

    def _friction_energies(self) -> tuple[float, float] | None:
        """The tangential springs' stored energy and the friction's dissipation so far
        (J), None without friction."""
        f = self.friction
        return None if f is None else (f.stored, f.dissipation)

    def _check(self, s: ti.State, total: float) -> None:
        # The total energy is finite exactly when z and v are: it holds v M v
        # (M positive definite, a positive diagonal when lumped) and z K z, and a
        # sum with an infinite or NaN term is infinite or NaN.
        e0, t = self.log.energy0, s.n * self.dt
        if not math.isfinite(total):
            raise SolverError(f"the solution became NaN/inf at t = {t:.6g} s (step {s.n}): "
                              "reduce the time step, or check the case's values for one far "
                              "out of scale (penalty, modulus, inertia, speed)")
        if e0 > 0 and total > (1.0 + self.case.analysis.energy_limit) * e0:
            raise SolverError(f"energy grew to {total / e0:.4g} x its initial value at "
                              f"t = {t:.6g} s (step {s.n}), beyond [analysis] energy_limit = "
                              f"{self.case.analysis.energy_limit:g}; reduce the time step")

    def _frame(self, t: float, s: ti.State) -> Frame:
        u = self.kin.T @ s.z
        vm = von_mises(self.model, u)
        eqp = None
        if self.plastic is not None:
            vm[self.plastic.elements] = self.plastic.von_mises(s.z)
            eqp = self.plastic.equivalent_plastic_strain("max")
            if self.plastic.boundary_yielded() and not self.log.warned_boundary:
                logger.warning("the plastic zone's boundary yields at t = %.4g s: raise "
                               "[analysis] plastic_zone (now %.3g m)", t, self.plastic_radius)
                self.log.warned_boundary = True
        return Frame(t, self.model.point_values(u), self.model.point_values(self.kin.T @ s.v),
                     self.contact.pressure(s.lam), vm, eqp)

    # -- result ----------------------------------------------------------------------
    def result(self) -> DynamicResult:
        """Measurements and history of the steps done so far."""
        h = self.log.history()
        plastic_points = (0 if self.plastic is None
                          else int(np.count_nonzero(self.plastic.alpha > 0.0)))
        meas = impact_measurements(h, self.initial_gap, plastic=plastic_points > 0)
        index = np.asarray(self.log.output_index, dtype=np.int64)
        out = {k: v[index] for k, v in h.items()} if len(h["time"]) else h
        return DynamicResult(h, out, meas, self._info(h, plastic_points), dict(self.timings),
                             self.mesh, self.model, list(self.log.frames))

    def _info(self, h: dict[str, np.ndarray], plastic_points: int) -> dict:
        a, p = self.case.analysis, self.probe
        return {
            "integrator": a.integrator,
            "hht_alpha": a.hht_alpha,
            "time_step": self.dt,
            "stable_time_step": self.dt_stable,
            "steps": int(len(h["time"]) - 1),
            "end_time": float(h["time"][-1]) if len(h["time"]) else 0.0,
            "mass": "HRZ lumped" if self.explicit else "consistent",
            "n_dofs": int(self.model.n_dofs),
            "n_reduced_dofs": int(self.kin.n),
            "n_elements": int(len(self.mesh.cells)),
            "n_points": int(self.mesh.n_points),
            "element_order": self.mesh.order,
            "penalty": [pair.penalty for pair in self.pairs],
            "contact_zone_nodes": int(len(self.contact.g_ref)),
            "projections": int(self.contact.n_projections),
            "zone_growths": int(self.log.zone_growths),
            "free_steps": int(self.log.free_steps),
            "zone_clearance": (self.monitor.closest if math.isfinite(self.monitor.closest)
                               else None),
            "contact_point": p.x_contact.tolist(),
            "contact_normal": p.normal.tolist(),
            "initial_gap": p.initial_gap,
            "sides": {"slave": p.slave.name, "master": p.master.name},
            "effective_mass": p.effective_mass,
            "plasticity": None if self.plastic is None else self._plastic_info(plastic_points),
        }

    def _plastic_info(self, plastic_points: int) -> dict:
        z, stats = self.plastic, self.log.plastic
        return {"zone_elements": int(z.n_elements),
                "zone_radius": self.plastic_radius,
                "plastic_points": plastic_points,
                "boundary_yielded": bool(z.boundary_yielded()),
                "dissipation": float(z.dissipation()),
                "plastic_iterations": stats.iterations,
                "krylov_products": stats.krylov_products,
                "newton_fallbacks": stats.newton_fallbacks,
                "max_equivalent_plastic_strain": float(
                    z.equivalent_plastic_strain("max").max(initial=0.0))}


# -- set-up --------------------------------------------------------------------------


def _check_stick_resolved(case: Case, dt_stable: float | None, friction: bool) -> None:
    """Refuse an explicit time step above the stable limit of the sticking contact.

    Stick is the tangential penalty spring; a step above its stable limit cannot
    resolve it (the stick-slip oscillation grows without bound).
    """
    dt = case.analysis.time_step
    if not friction or dt_stable is None or dt is None or dt <= dt_stable:
        return
    k, spec = next((k, c) for k, c in enumerate(case.contacts) if c.friction)
    raise CaseError(f"{case.path.name}: [contacts[{k}]] friction (mu_static = "
                    f"{spec.mu_static:g}) on an explicit case with [analysis] time_step = "
                    f"{dt:.4g} s: that step cannot resolve stick, whose stable limit (the "
                    f"tangential penalty) is {dt_stable:.4g} s; use at most that, or "
                    "time_step = \"auto\"")


def _check_case(case: Case) -> None:
    if not case.analysis.dynamic:
        raise CaseError(f"{case.path.name}: [analysis] type = '{case.analysis.type}': the "
                        "transient solver needs type = \"dynamic\"")
    if not case.contacts:
        raise CaseError(f"{case.path.name}: an impact needs at least one [[contacts]] pair")


def plastic_zone(case: Case, mesh: FEMesh, model: ElasticModel, kin: Kinematics,
                 zone: ContactZone, x_contact: np.ndarray):
    """J2 plasticity on the elements near the contact, if a material has a yield strength.

    Plastic strain is only tracked within ``[analysis] plastic_zone`` (m) of
    the initial contact point; ``auto`` takes 1.5 x the extent of the
    candidate slave faces (at least four faces). The run warns if the zone's
    boundary yields. Returns the :class:`~fe_impact.fe.plasticity.PlasticZone`
    (None if elastic or empty) and its radius (m).
    """
    if not any(m.yield_strength is not None for m in case.materials):
        return None, None
    from fe_impact.fe.plasticity import PlasticZone, elements_near

    radius = case.analysis.plastic_zone
    if radius is None:
        pair = zone.pairs[0]
        pts = mesh.points[np.unique(pair.slave.faces[zone.slave_faces[0]])]
        radius = 1.5 * float(np.linalg.norm(pts - x_contact, axis=1).max(initial=0.0))
        radius = max(radius, 4.0 * face_size(mesh, pair.slave))
    elements = elements_near(mesh, x_contact, radius)
    plastic = PlasticZone(model, elements, transform=kin.T)
    logger.info("plastic zone: %d elements within %.3g m of the contact", plastic.n_elements,
                radius)
    return (plastic if plastic.n_elements else None), radius


def initial_velocity(case: Case, mesh: FEMesh, kin: Kinematics, n_dofs: int) -> np.ndarray:
    """``[[initial_velocities]]`` and the rigid bodies' initial velocities, reduced.

    The volumes a rigid body ``carries`` start in its rigid motion: a gear
    and its rotor turn as one, so the flight to first touch is a rigid
    motion (:func:`~fe_impact.solvers.integrators.newmark_free_step`).
    """
    v = np.zeros(n_dofs)
    for spec in case.initial_velocities:
        cells = np.concatenate([mesh.volume(n) for n in spec.volumes])
        pts = np.unique(mesh.cells[cells])
        for c in range(3):
            v[3 * mesh.point_dof[pts] + c] = spec.value[c]
    for body in case.rigid_bodies:
        if body.carries:
            cells = np.concatenate([mesh.volume(n) for n in body.carries])
            pts = np.unique(mesh.cells[cells])
            v[point_dofs(mesh, pts)] = (body.initial_velocity
                                        * rigid_mode(body, mesh.points[pts])).ravel()
    vz = np.zeros(kin.n)
    vz[:kin.n_free] = v[kin.free]
    vz[kin.n_free:] = [b.initial_velocity for b in case.rigid_bodies]
    return vz

