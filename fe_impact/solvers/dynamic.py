"""Transient elastodynamics with penalty contact: explicit and Newmark integration.

The bodies are linear elastic; contact is the only nonlinearity. Unknowns are
reduced coordinates ``z``: the free DOFs plus one DOF per rigid body, with
``u = T z`` (supported components are zero, nodes of a rigid body's surface
follow its translation or small rotation). The equations of motion are

    M_r z'' + K_r z = B_r^T lambda(z),   M_r = T^T M T + diag(inertia), K_r = T^T K T,

with the penalty forces ``lambda_a = eps w_a <-g_a>`` on the weighted nodal
gaps ``g = g_ref + B_r (z - z_ref)``, linearised about the last projection of
the slave nodes on the master surface and re-projected whenever the contact
zone has moved by more than a small fraction of an element.

Integrators
-----------
``explicit``
    Central difference (velocity Verlet) with the HRZ-lumped mass; the
    stable step ``2 / omega_max`` is computed by Lanczos iteration on
    ``M^-1/2 (K + K_contact) M^-1/2``, with every zone node in contact.
``newmark``
    Implicit Newmark average acceleration (beta = 1/4, gamma = 1/2), or
    HHT-alpha with ``hht_alpha < 0``; consistent mass. ``K_eff`` is
    factorised once; the contact zone is condensed with a Schur complement
    onto one coordinate per zone node (its contact normal, see
    :func:`zone_frames`), so contact in each step is a small dense
    complementarity problem solved exactly (as in the static solver).

Measurements
------------
Each side of the first contact pair (the bodies owning the slave and the
master surface) is summarised by one generalised coordinate: its rigid body's
motion if it has one, otherwise a translation along the contact normal. The
side's displacement and velocity are the mass-weighted averages of that mode
(momentum / generalised mass, so a free body's value stays constant after
separation); a side whose supports block the mode is the fixed reference (0).
The approach is the closing displacement of the two sides at the initial
contact point along the initial contact normal, minus the initial gap.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_info, threadpool_limits

from fe_impact.contact.lcp import solve_penalty_lcp
from fe_impact.contact.surfaces import GapState, nodal_pressure
from fe_impact.contact.zone import (
    PENALTY_FACTOR_EXPLICIT,
    ContactZone,
    contact_pairs,
    face_size,
)
from fe_impact.errors import CaseError, ContactError, SolverError
from fe_impact.fe.case import Case
from fe_impact.fe.elasticity import assemble_mass, build_model, lumped_mass, von_mises
from fe_impact.fe.kinematics import Kinematics, rigid_mode
from fe_impact.fe.linalg import SPDSolver, condensed_compliance
from fe_impact.fe.mesh import FEMesh
from fe_impact.solvers.model import ContactSetup, gap_reach

logger = logging.getLogger(__name__)

#: Automatic Newmark step: this many steps over the duration (at least), so a
#: contact lasting a third of the run is resolved by about 70 steps.
NEWMARK_STEPS = 200
#: Re-project the slave nodes when the zone has moved by this fraction of the
#: smallest contact-face size since the last projection.
REPROJECT_FRACTION = 0.05


# -- measurement probes ------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Side:
    """One body of the measured contact pair, reduced to one coordinate."""

    name: str
    weights: np.ndarray | None   # q = weights . z (None: a fixed reference, q = 0)
    lever: float                 # normal displacement at the contact point per unit q
    rigid_body: int | None
    mass: float = math.inf       # generalised mass / lever^2: mass seen along the normal

    def normal_displacement(self, z: np.ndarray) -> float:
        return 0.0 if self.weights is None else self.lever * float(self.weights @ z)


def _side_points(mesh: FEMesh, model, surface_points: np.ndarray) -> tuple[np.ndarray, list]:
    """Points and volume names of the volume groups touching a surface."""
    touched = np.isin(mesh.cells[:, :4], surface_points).any(axis=1)
    names = [n for n, el in mesh.volumes.items() if touched[el].any()]
    cells = np.concatenate([mesh.volumes[n] for n in names])
    return np.unique(mesh.cells[cells]), names


def _make_side(label: str, mesh: FEMesh, kin: Kinematics, M_r: sp.spmatrix, surface: str,
               x_c: np.ndarray, normal: np.ndarray, model) -> Side:
    pts, names = _side_points(mesh, model, mesh.surface_points(surface))
    dof_of = 3 * mesh.point_dof
    body = None
    for k, spec in enumerate(kin.rigid):
        if np.isin(mesh.surface_points(spec.surface), pts).all():
            body = k
            break
    n_dofs = kin.T.shape[0]
    phi = np.zeros(n_dofs)
    if body is None:
        mode = np.broadcast_to(normal, (len(pts), 3))
        lever = 1.0
    else:
        spec = kin.rigid[body]
        mode = rigid_mode(spec, mesh.points[pts])
        lever = float(rigid_mode(spec, x_c[None, :])[0] @ normal)
    dofs = (dof_of[pts][:, None] + np.arange(3)).ravel()
    phi[dofs] = mode.ravel()
    name = f"{label} ({', '.join(names)})"
    if np.abs(phi[kin.fixed]).max(initial=0.0) > 1e-9 * np.abs(phi).max():
        return Side(name, None, 0.0, None)
    phi_z = np.zeros(kin.n)
    phi_z[:kin.n_free] = phi[kin.free]
    if body is not None:
        phi_z[kin.n_free + body] = 1.0
    Mphi = M_r @ phi_z
    gen = float(phi_z @ Mphi)
    return Side(name, Mphi / gen, lever, body, gen / lever ** 2 if lever else math.inf)


# -- contact -----------------------------------------------------------------------


class ContactModel:
    """Penalty forces on linearised weighted gaps, re-projected as the bodies move."""

    def __init__(self, mesh: FEMesh, model, kin: Kinematics, zone: ContactZone,
                 tolerance: float) -> None:
        self.mesh, self.model, self.kin, self.zone = mesh, model, kin, zone
        self.tolerance = tolerance
        self.n_projections = 0
        self.projector: sp.csr_matrix | None = None
        self.update(np.zeros(kin.n))

    def _point_values(self, z: np.ndarray) -> np.ndarray:
        return self.model.point_values(self.kin.T @ z)

    def update(self, z: np.ndarray) -> None:
        """Project the zone's slave nodes on the configuration ``z``."""
        self.states: list[GapState] = self.zone.gap_states(self.mesh, self._point_values(z))
        B = sp.vstack([s.B for s in self.states]).tocsr()
        self.B = (B @ self.kin.T).tocsr()
        self.g_ref = np.concatenate([s.gap for s in self.states])
        self.active_rows = np.isfinite(self.g_ref)
        self.g_ref = np.where(self.active_rows, self.g_ref, 0.0)
        self.B = sp.diags(self.active_rows.astype(float)) @ self.B
        self.B_full = self.B
        if self.projector is not None:
            self.B = (self.B @ self.projector).tocsr()
        self.BT = self.B.T.tocsr()
        self.eps_w = np.concatenate([p.penalty * s.weight for p, s in
                                     zip(self.zone.pairs, self.states, strict=True)])
        self.eps_w = np.where(self.active_rows, self.eps_w, 0.0)
        self.sizes = [len(s.gap) for s in self.states]
        pts = self.zone.points()
        dofs = (3 * self.mesh.point_dof[pts][:, None] + np.arange(3)).ravel()
        self.T_zone = self.kin.T[dofs]
        self.z_ref = z.copy()
        self.n_projections += 1

    def set_projector(self, projector: sp.csr_matrix | None) -> None:
        """Keep only the normal components of the zone nodes in the gap Jacobian.

        ``projector`` is :func:`zone_frames`' ``n n^T`` per zone node: gaps and
        contact forces then act along each node's surface normal (the
        node-to-surface convention); ``None`` restores the full Jacobian.
        """
        self.projector = projector
        self.B = self.B_full if projector is None else (self.B_full @ projector).tocsr()
        self.BT = self.B.T.tocsr()   # forces B^T lam every step: transpose once

    def moved(self, z: np.ndarray) -> bool:
        """True if the zone moved by more than the re-projection tolerance."""
        du = (self.T_zone @ (z - self.z_ref)).reshape(-1, 3)
        du -= du.mean(axis=0)
        return float(np.abs(du).max(initial=0.0)) > self.tolerance

    def gaps(self, z: np.ndarray) -> np.ndarray:
        return self.g_ref + self.B @ (z - self.z_ref)

    def forces(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nodal penalty forces ``lambda`` (N) and the gaps they come from."""
        g = self.gaps(z)
        return self.eps_w * np.maximum(-g, 0.0), g

    def energy(self, lam: np.ndarray) -> float:
        """Penalty potential sum(eps w <-g>^2 / 2) = sum(lam^2 / (2 eps w))."""
        on = lam > 0
        return float(0.5 * np.sum(lam[on] ** 2 / self.eps_w[on]))

    def pair_forces(self, lam: np.ndarray) -> list[float]:
        out, start = [], 0
        for n in self.sizes:
            out.append(float(lam[start:start + n].sum()))
            start += n
        return out

    def pressure(self, lam: np.ndarray) -> np.ndarray:
        """Nodal contact pressure (Pa) on all mesh points."""
        p = np.zeros(self.mesh.n_points)
        start = 0
        for pair, st, n in zip(self.zone.pairs, self.states, self.sizes, strict=True):
            lk = lam[start:start + n]
            start += n
            p = np.maximum(p, nodal_pressure(self.mesh, pair, st,
                                             np.where(lk > 0, lk / st.weight, 0.0)))
        return p


@dataclass(frozen=True, eq=False)
class ZoneFrames:
    """Normal/tangent frames of the contact-zone nodes in reduced coordinates.

    ``z = R z'`` rotates the three coordinates of every zone node whose
    components are all free into (normal, tangent, tangent), the normal
    taking the slot of the x coordinate; ``projector = R P R^T`` keeps the
    normal part. ``condensed`` lists the normal slots, every free coordinate
    of zone nodes that cannot be rotated (a component held by a support or
    tied to a rigid body) and the coordinates of rigid bodies that zone nodes
    follow, sorted.
    """

    R: sp.csr_matrix
    projector: sp.csr_matrix
    condensed: np.ndarray


def zone_frames(mesh: FEMesh, kin: Kinematics, contact: ContactModel) -> ZoneFrames:
    """Frames whose normal is the direction the gaps see each zone node move.

    A node's normal is the principal direction of ``sum_r b_r b_r^T`` over its
    3-vector entries ``b_r`` in the full gap Jacobian ``contact.B_full``: the
    contact normal at the points it carries (the master normal, also for
    slave nodes). A zone node no gap sees yet takes its area-weighted surface
    normal.
    """
    zone, B = contact.zone, contact.B_full
    pts = zone.points()   # the rows of contact.T_zone, three per point
    red = -np.ones(kin.T.shape[0], dtype=np.int64)
    red[kin.free] = np.arange(kin.n_free)
    j = red[(3 * mesh.point_dof[pts])[:, None] + np.arange(3)]            # (np, 3)
    free = (j >= 0).all(axis=1)
    jf = j[free]
    Bc = B.tocsc()
    C = np.empty((len(jf), 3, 3))
    cols = [Bc[:, jf[:, a]] for a in range(3)]
    for a in range(3):
        for b in range(a, 3):
            C[:, a, b] = C[:, b, a] = np.asarray(cols[a].multiply(cols[b]).sum(axis=0)).ravel()
    lam, vec = np.linalg.eigh(C)
    n = vec[:, :, -1]
    unseen = lam[:, -1] <= 1e-12 * max(float(lam[:, -1].max(initial=0.0)), 1e-300)
    if unseen.any():
        acc = np.zeros((mesh.n_points, 3))
        for pair, sf, mf in zip(zone.pairs, zone.slave_faces, zone.master_faces, strict=True):
            for faces in (pair.slave.faces[sf], pair.master.faces[mf]):
                x = mesh.points[faces[:, :3]]
                nrm = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])   # 2 x area x normal
                np.add.at(acc, faces.ravel(), np.repeat(nrm, faces.shape[1], axis=0))
        a = acc[pts[free][unseen]]
        n[unseen] = a / np.maximum(np.linalg.norm(a, axis=1), 1e-300)[:, None]
    # Tangents: any unit vector normal to n, then n x t1.
    helper = np.where(np.abs(n[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(n, t1)
    F = np.stack([n, t1, t2], axis=2)                 # (nr, xyz, slot)
    rows = np.broadcast_to(jf[:, :, None], F.shape).ravel()
    cols_ = np.broadcast_to(jf[:, None, :], F.shape).ravel()
    keep = np.ones(kin.n, dtype=bool)
    keep[jf.ravel()] = False
    ident = np.flatnonzero(keep)
    rr, cc = np.concatenate([rows, ident]), np.concatenate([cols_, ident])
    one = np.ones(len(ident))
    R = sp.csr_matrix((np.concatenate([F.ravel(), one]), (rr, cc)), shape=(kin.n, kin.n))
    nn = n[:, :, None] * n[:, None, :]               # (nr, 3, 3)
    P = sp.csr_matrix((np.concatenate([nn.ravel(), one]), (rr, cc)), shape=(kin.n, kin.n))
    # Unrotated nodes keep every coordinate they move with: their free
    # components and, if tied, their rigid body's.
    other = contact.T_zone[(3 * np.flatnonzero(~free)[:, None] + np.arange(3)).ravel()]
    condensed = np.unique(np.concatenate([jf[:, 0], other.indices]))
    return ZoneFrames(R, P, condensed)


class SurfaceMonitor:
    """Linearised gaps of every slave node, to see faces outside the zone coming close.

    The zone grows when the smallest gap outside it, extrapolated to the check
    after next at the rate it closed since the last check, falls below
    :attr:`margin` (a quarter of the zone's reach beyond the first contact,
    at most a quarter of a face): a face joins before it can touch, and a
    zone that merely has neighbours a few microns away is left alone.
    """

    def __init__(self, mesh: FEMesh, kin: Kinematics, zone: ContactZone,
                 reach: list[float], states: list) -> None:
        self.mesh, self.zone = mesh, zone
        self.pairs = []
        margins = []
        for s, st in zip(reach, states, strict=True):
            ok = np.isfinite(st.gap)
            self.pairs.append((st.nodes[ok], st.gap[ok], (st.B[ok] @ kin.T).tocsr()))
            margins.append(0.25 * max(s - float(np.min(st.gap[ok])), 0.0))
        self.margin = min(min(margins), 0.25 * min(face_size(mesh, p.slave)
                                                   for p in zone.pairs))
        self._held_cache: dict[int, tuple[int, np.ndarray]] = {}
        #: Smallest linearised gap outside the zone seen so far (m).
        self.closest = math.inf
        self.closing = 0.0    # closure of that gap since the last check (m)
        self._last = None

    def outside_gap(self, z: np.ndarray) -> float:
        """Smallest linearised gap of the slave nodes the zone does not hold (m).

        Those are the nodes outside it and the nodes on its edge, whose faces
        are not all in the zone (they carry no weighted gap there).
        """
        g_min = math.inf
        for k, (nodes, g0, B) in enumerate(self.pairs):
            inside = np.isin(nodes, self._held(k))
            if np.any(~inside):
                g_min = min(g_min, float((g0[~inside] + B[~inside] @ z).min()))
        return g_min

    def _held(self, k: int) -> np.ndarray:
        """Nodes of pair ``k`` all of whose faces are in the zone (cached: zones only grow)."""
        faces = self.zone.slave_faces[k]
        cached = self._held_cache.get(k)
        if cached is None or cached[0] != len(faces):
            cached = (len(faces), self.zone.pairs[k].slave.complete_nodes(faces))
            self._held_cache[k] = cached
        return cached[1]

    def close_outside(self, z: np.ndarray) -> bool:
        g = self.outside_gap(z)
        if not math.isfinite(g):
            return False
        self.closest = min(self.closest, g)
        self.closing = max(self._last - g, 0.0) if self._last is not None else 0.0
        self._last = g
        return g - 2.0 * self.closing < self.margin

    def grow_margin(self) -> float:
        """Gap below which faces outside join the zone once it has to grow (m)."""
        self._last = None   # the faces outside change
        return 2.0 * (self.margin + 2.0 * self.closing)


class _Separated(Exception):
    """Raised by the step recorder to end a run after the bodies separate."""


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
    history: dict[str, np.ndarray]     # every step
    output_history: dict[str, np.ndarray]  # at the output interval
    measurements: dict
    info: dict
    timings: dict[str, float]
    mesh: FEMesh = field(repr=False)
    model: object = field(repr=False)
    frames: list[float] = field(default_factory=list)


HISTORY_KEYS = ("time", "contact_force", "approach", "normal_velocity", "kinetic_energy",
                "strain_energy", "contact_energy", "plastic_dissipation", "total_energy")


# -- solver --------------------------------------------------------------------------


class DynamicSolver:
    """Set up once per case; :meth:`run` integrates to the case's duration."""

    def __init__(self, case: Case, mesh: FEMesh) -> None:
        if not case.analysis.dynamic:
            raise CaseError(f"{case.path.name}: [analysis] type = '{case.analysis.type}': the "
                            "transient solver needs type = \"dynamic\"")
        if not case.contacts:
            raise CaseError(f"{case.path.name}: an impact needs at least one [[contacts]] pair")
        self.case = case
        a = case.analysis
        self.timings: dict[str, float] = {}
        t = time.perf_counter()
        self.mesh = mesh
        case.check_groups(self.mesh)
        self.timings["mesh"] = time.perf_counter() - t
        t = time.perf_counter()
        self.model = build_model(self.mesh, case.materials)
        M = assemble_mass(self.model)
        self.kin = Kinematics.build(case, self.mesh, self.model.n_dofs)
        T = self.kin.T
        self.K = (T.T @ self.model.K @ T).tocsr()
        inertia = np.zeros(self.kin.n)
        inertia[self.kin.n_free:] = [b.inertia for b in case.rigid_bodies]
        self.explicit = a.integrator == "explicit"
        if self.explicit:
            m = lumped_mass(M)
            self.m = np.asarray(T.T.multiply(T.T) @ m).ravel() + inertia
            self.M = sp.diags(self.m).tocsr()
        else:
            self.M = (T.T @ M @ T + sp.diags(inertia)).tocsr()
        self.timings["assembly"] = time.perf_counter() - t
        self.pairs = contact_pairs(case, self.mesh, self.model, PENALTY_FACTOR_EXPLICIT
                                   if self.explicit else None)
        h_min = min(face_size(self.mesh, p.slave) for p in self.pairs)
        t = time.perf_counter()
        setup = ContactSetup.build(case, self.mesh, self.pairs, gap_reach(self.mesh))
        self.zone = setup.zone
        self.contact = ContactModel(self.mesh, self.model, self.kin, self.zone,
                                    REPROJECT_FRACTION * h_min)
        self.monitor = SurfaceMonitor(self.mesh, self.kin, self.zone, setup.reach, setup.states)
        self.timings["contact_setup"] = time.perf_counter() - t
        self._probe()
        self.plastic = self._plastic_zone()
        self.v0 = self._initial_velocity()
        t = time.perf_counter()
        self.dt_stable = self._stable_step() if self.explicit else None
        self.dt = self._time_step()
        if self.explicit:
            self.timings["stable_step"] = time.perf_counter() - t
        else:
            self._factorise()
            self.timings["factorisation"] = time.perf_counter() - t

    # -- set-up --------------------------------------------------------------------
    def _probe(self) -> None:
        """Initial contact point and normal of the first pair, and the two sides.

        The initial gap is the smallest weighted gap, where the discrete contact
        first pushes. On curved surfaces it exceeds the geometric gap by the
        surface's sag averaged over that node's support, about 0.15 h^2/R with
        the linear pressure (0.04 h^2/R split); on the tooth impacts of the
        default calibration that was 0.4-1.0% of the largest approach.
        """
        st = self.contact.states[0]
        k = int(np.argmin(np.where(np.isfinite(st.gap), st.gap, np.inf)))
        self.x_contact = st.point[k].copy()
        self.normal = st.normal[k].copy()
        self.initial_gap = float(st.gap[k])
        spec = self.case.contacts[0]
        self.slave_side = _make_side("slave", self.mesh, self.kin, self.M, spec.slave,
                                     self.x_contact, self.normal, self.model)
        self.master_side = _make_side("master", self.mesh, self.kin, self.M, spec.master,
                                      self.x_contact, self.normal, self.model)

    def _plastic_zone(self):
        """J2 plasticity on the elements near the contact, if a material has a yield strength.

        Plastic strain is only tracked within ``[analysis] plastic_zone`` (m) of
        the initial contact point; ``auto`` takes 1.5 x the extent of the
        candidate slave faces (at least four faces). The run warns if the zone's boundary yields.
        """
        if not any(m.yield_strength is not None for m in self.case.materials):
            return None
        from fe_impact.fe.plasticity import PlasticZone, elements_near

        radius = self.case.analysis.plastic_zone
        if radius is None:
            pair = self.pairs[0]
            pts = self.mesh.points[np.unique(pair.slave.faces[self.zone.slave_faces[0]])]
            radius = 1.5 * float(np.linalg.norm(pts - self.x_contact, axis=1).max(initial=0.0))
            radius = max(radius, 4.0 * face_size(self.mesh, self.pairs[0].slave))
        elements = elements_near(self.mesh, self.x_contact, radius)
        zone = PlasticZone(self.model, elements, transform=self.kin.T)
        logger.info("plastic zone: %d elements within %.3g m of the contact", zone.n_elements,
                    radius)
        self.plastic_radius = radius
        return zone if zone.n_elements else None

    def _initial_velocity(self) -> np.ndarray:
        v = np.zeros(self.model.n_dofs)
        for spec in self.case.initial_velocities:
            cells = np.concatenate([self.mesh.volume(n) for n in spec.volumes])
            pts = np.unique(self.mesh.cells[cells])
            for c in range(3):
                v[3 * self.mesh.point_dof[pts] + c] = spec.value[c]
        vz = np.zeros(self.kin.n)
        vz[:self.kin.n_free] = v[self.kin.free]
        vz[self.kin.n_free:] = [b.initial_velocity for b in self.case.rigid_bodies]
        return vz

    def _stable_step(self) -> float:
        """Critical central-difference step 2/omega_max, contact penalty included."""
        c = self.contact
        Kc = (c.B.T @ sp.diags(c.eps_w) @ c.B).tocsr()
        s = 1.0 / np.sqrt(self.m)
        A = sp.diags(s) @ (self.K + Kc) @ sp.diags(s)
        if A.shape[0] < 10:
            lam = float(np.linalg.eigvalsh(A.toarray()).max())
        else:
            lam = spla.eigsh(A, k=1, which="LA", tol=1e-4, return_eigenvectors=False,
                             v0=np.ones(A.shape[0]))[0]
        if lam <= 0:
            raise SolverError("the model has no stiffness: nothing limits the time step; "
                              "give [analysis] time_step")
        return 2.0 / math.sqrt(lam)

    def _time_step(self) -> float:
        a = self.case.analysis
        out = a.output_interval or a.duration / 100.0
        if self.explicit:
            if a.time_step is not None:
                if a.time_step > self.dt_stable:
                    raise CaseError(
                        f"{self.case.path.name}: [analysis] time_step = {a.time_step:.4g} s is "
                        f"above the explicit stability limit {self.dt_stable:.4g} s; use at "
                        f"most that, or \"auto\" ({a.safety_factor} x the limit)")
                return a.time_step
            return a.safety_factor * self.dt_stable
        dt = a.time_step if a.time_step is not None else min(out, a.duration / NEWMARK_STEPS)
        if a.time_step is None:
            dt = out / math.ceil(out / dt - 1e-9)   # a whole number of steps per output
        return dt

    def _factorise(self) -> None:
        a = self.case.analysis
        alpha = a.hht_alpha
        self.beta = (1.0 - alpha) ** 2 / 4.0
        self.gamma = 0.5 - alpha
        c0 = 1.0 / (self.beta * self.dt ** 2)
        self.K_eff = ((1.0 + alpha) * self.K + c0 * self.M).tocsr()
        self.solver = SPDSolver(self.K_eff)
        self._condense()

    def _condense(self) -> None:
        """Schur complement of ``K_eff`` on the zone nodes' normal coordinates.

        The gap Jacobian keeps only each zone node's normal component (see
        :func:`zone_frames`), so the condensed compliance has one coordinate per
        node instead of three: a third of the size, a 27th of the factorisation
        work. What is
        dropped is the tangential coupling ``(n_q - n_a) . du_a`` within a
        node's support, of relative size h / R (h the face size, R the relative
        radius of curvature), and the gaps are re-projected exactly whenever the
        zone has deformed by 5% of a face.
        """
        frames = zone_frames(self.mesh, self.kin, self.contact)
        self.contact.set_projector(frames.projector)
        self.R = frames.R
        self.cond = frames.condensed
        K_rot = (frames.R.T @ self.K_eff @ frames.R).tocsr()
        # The compliance G once per zone; after each projection B G B^T is then a
        # sparse-dense product (a triangular solve with the Schur factor per
        # projection cost 4.5 s on a 145k-DOF tooth pair, this 0.5 s).
        self.G_zone = condensed_compliance(K_rot, self.cond)
        self._delassus_at = -1   # B G B^T, rebuilt after each projection
        logger.info("contact zone: %d reduced coordinates condensed", len(self.cond))

    # -- integration ---------------------------------------------------------------
    def run(self, frame_hook: Callable[[Frame], None] | None = None,
            progress: Callable[[float], None] | None = None) -> DynamicResult:
        """Integrate over the case's duration.

        ``frame_hook(frame)`` receives the fields at every output time (and at
        t = 0); ``progress(fraction)`` is called now and then.
        """
        t0 = time.perf_counter()
        a = self.case.analysis
        n_steps = max(1, int(round(a.duration / self.dt)))
        out_dt = a.output_interval or a.duration / 100.0
        step = self._explicit_steps if self.explicit else self._newmark_steps
        hist = {k: [] for k in HISTORY_KEYS}
        out_idx: list[int] = []
        self._frames: list[float] = []
        state = {"next_out": 0.0}
        self._energy0 = None
        self._warned_boundary = False
        self.n_zone_growth = 0
        # Newmark plasticity: solver iterations (elastic trials included), GMRES
        # products of the Newton corrections, steps Newton handed to Anderson
        self.plastic_iterations = self.krylov_products = self.newton_fallbacks = 0

        mass = self.m if self.explicit else None

        zone = self.plastic

        def record(n: int, t: float, z, v, lam, strain: float) -> None:
            ke = 0.5 * float(v @ (mass * v) if mass is not None else v @ (self.M @ v))
            ce = self.contact.energy(lam)
            dis = 0.0
            if zone is not None:
                strain += zone.energy_correction(z)
                dis = zone.dissipation()
            total = ke + strain + ce + dis
            if self._energy0 is None:
                self._energy0 = total
            hist["time"].append(t)
            hist["contact_force"].append(float(lam.sum()))
            hist["approach"].append(self._approach(z))
            hist["normal_velocity"].append(self._normal_velocity(v))
            hist["kinetic_energy"].append(ke)
            hist["strain_energy"].append(strain)
            hist["contact_energy"].append(ce)
            hist["plastic_dissipation"].append(dis)
            hist["total_energy"].append(total)
            self._check(n, t, total, z)
            done = self._separated(state, t, hist["contact_force"][-1], hist["approach"][-1])
            if t >= state["next_out"] - 0.5 * self.dt or n == n_steps or done:
                out_idx.append(len(hist["time"]) - 1)
                state["next_out"] += out_dt
                self._frames.append(t)
                if frame_hook is not None:
                    frame_hook(self._frame(t, z, v, lam))
                if progress is not None:
                    progress(min(t / a.duration, 1.0))
            if done:
                raise _Separated

        try:
            # Steps are many small vector operations: OpenBLAS threads waking for each
            # dot product cost more than the product (6x slower steps measured on 2
            # cores, with MKL's threads spinning after each PARDISO call).
            with threadpool_limits(limits={i["prefix"]: 1 for i in threadpool_info()
                                           if i["internal_api"] == "openblas"}):
                step(n_steps, record)
        except _Separated:
            logger.info("stopped at t = %.6g s, %.3g contact durations after separation",
                        hist["time"][-1], a.stop_after_separation)
        finally:
            self.timings["integration"] = time.perf_counter() - t0
            self.history = {k: np.asarray(v) for k, v in hist.items()}
            self.output_index = np.asarray(out_idx, dtype=np.int64)
        return self.result()

    def _separated(self, state: dict, t: float, force: float, approach: float) -> bool:
        """True once the bodies have been apart for ``stop_after_separation`` x the contact.

        Apart means no contact force and a negative approach (they have moved
        past the position of first touch), so a node chattering at first touch
        does not count as a separation.
        """
        frac = self.case.analysis.stop_after_separation
        if frac is None:
            return False
        if force > 0.0:
            state.setdefault("first_on", t)
            state["last_on"] = t
            return False
        if "last_on" not in state or approach >= 0.0:
            return False
        return t - state["last_on"] >= frac * (state["last_on"] - state["first_on"])

    def _check(self, n: int, t: float, total: float, z: np.ndarray) -> None:
        e0 = self._energy0
        if not math.isfinite(total) or not np.isfinite(z[:1]).all():
            raise SolverError(f"the solution became NaN/inf at t = {t:.6g} s (step {n}); "
                              "reduce the time step")
        if e0 > 0 and total > (1.0 + self.case.analysis.energy_limit) * e0:
            raise SolverError(f"energy grew to {total / e0:.4g} x its initial value at "
                              f"t = {t:.6g} s (step {n}), beyond [analysis] energy_limit = "
                              f"{self.case.analysis.energy_limit:g}; reduce the time step")

    @property
    def effective_mass(self) -> float:
        """``1/(1/m_s + 1/m_m)`` of the two sides along the contact normal (kg)."""
        inv = sum(1.0 / s.mass for s in (self.slave_side, self.master_side)
                  if math.isfinite(s.mass) and s.weights is not None)
        return 1.0 / inv if inv > 0 else math.inf

    def _approach(self, z: np.ndarray) -> float:
        return -(self.slave_side.normal_displacement(z)
                 - self.master_side.normal_displacement(z)) - self.initial_gap

    def _normal_velocity(self, v: np.ndarray) -> float:
        """Relative normal velocity slave - master (negative while closing)."""
        return (self.slave_side.normal_displacement(v)
                - self.master_side.normal_displacement(v))

    def _frame(self, t, z, v, lam) -> Frame:
        u = self.kin.T @ z
        vm = von_mises(self.model, u)
        eqp = None
        if self.plastic is not None:
            vm[self.plastic.elements] = self.plastic.von_mises(z)
            eqp = self.plastic.equivalent_plastic_strain("max")
            if self.plastic.boundary_yielded() and not self._warned_boundary:
                logger.warning("the plastic zone's boundary yields at t = %.4g s: raise "
                               "[analysis] plastic_zone (now %.3g m)", t, self.plastic_radius)
                self._warned_boundary = True
        return Frame(t, self.model.point_values(u), self.model.point_values(self.kin.T @ v),
                     self.contact.pressure(lam), vm, eqp)

    def _watch_zone(self, z: np.ndarray) -> bool:
        """Grow the zone if faces outside it come close; True if it grew."""
        if not self.monitor.close_outside(z):
            return False
        up = self.model.point_values(self.kin.T @ z)
        if not self.zone.grow(self.mesh, up, margin=self.monitor.grow_margin()):
            return False
        self.n_zone_growth += 1
        self.contact.update(z)
        if not self.explicit:
            self._condense()
        return True

    def _explicit_steps(self, n_steps: int, record) -> None:
        dt, K, minv, c = self.dt, self.K, 1.0 / self.m, self.contact
        zone = self.plastic
        z = np.zeros(self.kin.n)
        v = self.v0.copy()
        f_int = np.zeros_like(z)
        lam, _ = c.forces(z)
        acc = minv * (c.BT @ lam)
        record(0, 0.0, z, v, lam, 0.0)
        check_every = 10
        for n in range(1, n_steps + 1):
            v += 0.5 * dt * acc
            z += dt * v
            if n % check_every == 0:
                if c.moved(z):
                    c.update(z)
                self._watch_zone(z)
            Kz = K @ z
            f_int = Kz
            if zone is not None:
                f_int = Kz - zone.update(z)
                zone.commit()
            lam, _ = c.forces(z)
            acc = minv * (c.BT @ lam - f_int)
            v += 0.5 * dt * acc
            record(n, n * dt, z, v, lam, 0.5 * float(z @ Kz))

    def _newmark_steps(self, n_steps: int, record) -> None:
        dt, K, M, c = self.dt, self.K, self.M, self.contact
        alpha = self.case.analysis.hht_alpha
        beta, gamma = self.beta, self.gamma
        c0, c1, c2 = 1.0 / (beta * dt ** 2), 1.0 / (beta * dt), 1.0 / (2.0 * beta) - 1.0
        z = np.zeros(self.kin.n)
        v = self.v0.copy()
        lam, _ = c.forces(z)
        f_c = c.BT @ lam
        acc = np.zeros_like(z)
        if np.any(lam > 0):
            acc = SPDSolver(M).solve(f_c - K @ z)
        record(0, 0.0, z, v, lam, 0.0)
        active = None
        max_it = self.case.analysis.max_iterations
        zone = self.plastic
        f_p = np.zeros_like(z)
        for n in range(1, n_steps + 1):
            Kz = K @ z
            rhs0 = M @ (c0 * z + c1 * v + c2 * acc) + alpha * (Kz - f_p - f_c)
            for _ in range(max_it):
                if zone is None:
                    lam, z_new, active = self._newmark_contact(self.solver.solve(rhs0), rhs0,
                                                               alpha, active)
                else:
                    lam, z_new, active = self._newmark_plastic(rhs0, alpha, active, z, v, dt)
                if not c.moved(z_new):
                    break
                c.update(z_new)
            else:
                raise ContactError(f"contact did not settle within {max_it} re-projections at "
                                   f"t = {n * dt:.6g} s; raise [analysis] max_iterations")
            f_c = c.BT @ lam
            if zone is not None:
                zone.commit()
                f_p = zone.plastic_force()
            acc_new = c0 * (z_new - z) - c1 * v - c2 * acc
            v = v + dt * ((1.0 - gamma) * acc + gamma * acc_new)
            z, acc = z_new, acc_new
            record(n, n * dt, z, v, lam, 0.5 * float(z @ (K @ z)))
            if self._watch_zone(z):   # new zone rows: forces are recomputed next step
                active = None

    def _newmark_plastic(self, rhs0, alpha, active, z, v, dt):
        """One Newmark step with plasticity.

        ``z = step(F_p(z))`` with ``step`` one elastic solve (plastic force on
        the right, contact condensed). ``[analysis] plastic_solver``:
        ``newton`` (:func:`~fe_impact.fe.plasticity.solve_newton`) with the zone's
        consistent tangent, GMRES on the elastic factorisation for each
        correction; ``anderson`` (:func:`~fe_impact.fe.plasticity.solve_fixed_point`)
        modified Newton on the elastic factorisation with Anderson mixing.
        """
        from fe_impact.fe.plasticity import solve_fixed_point, solve_newton

        state = {"active": active}

        def step(f_p):
            rhs = rhs0 + (1.0 + alpha) * f_p
            lam, z_new, act = self._newmark_contact(self.solver.solve(rhs), rhs, alpha,
                                                    state["active"])
            state.update(lam=lam, active=act, lin=None)
            return z_new

        def dstep(w):
            if state["lin"] is None:
                state["lin"] = self._contact_linearisation(state["lam"], alpha)
            return state["lin"]((1.0 + alpha) * w)

        # An elastic step with the committed plastic force: if no point yields
        # further, it is the solution (most steps of a mildly plastic impact).
        f_old = self.plastic.plastic_force()
        z_new = step(f_old)
        f_new = self.plastic.update(z_new)
        if np.array_equal(f_new, f_old):
            self.plastic_iterations += 1
            return state["lam"], z_new, state["active"]
        z0, products = z_new, 0

        def anderson():
            try:
                return solve_fixed_point(step, self.plastic, z0, tol=1e-7, max_iter=200,
                                         reference=z)
            except RuntimeError as exc:
                raise SolverError(f"plasticity did not converge in a Newmark step: {exc}; "
                                  "reduce the time step or use the explicit integrator"
                                  ) from None

        if self.case.analysis.plastic_solver == "anderson":
            z_new, its = anderson()
        else:
            try:
                z_new, its, products = solve_newton(step, dstep, self.plastic, z0, tol=1e-7,
                                                    max_iter=50, reference=z)
            except RuntimeError as exc:
                # e.g. the contact's active set alternating between iterations
                logger.warning("Newton's plasticity iteration failed (%s); this step "
                               "falls back to Anderson-accelerated modified Newton", exc)
                self.newton_fallbacks += 1
                z_new, its = anderson()
        self.plastic_iterations += its
        self.krylov_products += products
        return state["lam"], z_new, state["active"]

    def _contact_linearisation(self, lam: np.ndarray, alpha: float):
        """``w -> dz``: the Newmark solve's response to a force ``w`` at a fixed active set.

        With the active rows ``S`` (``lam > 0``) the penalty forces satisfy
        ``(diag(1/eps_S) + C_SS) lam_S = -h_S``, ``h`` the gaps of the
        contact-free solve, so ``dz = K^-1 w + (1 + a) K^-1 B_S^T dlam_S`` with
        ``dlam_S = -(diag(1/eps_S) + C_SS)^-1 B_S K^-1 w``.
        """
        from scipy.linalg import cho_factor, cho_solve

        c = self.contact
        ok = np.flatnonzero(c.active_rows)
        on = lam[ok] > 0
        if not on.any():
            return self.solver.solve
        rows = ok[on]
        B_S = c.B[rows]
        fac = cho_factor(self._delassus[np.ix_(on, on)] + np.diag(1.0 / c.eps_w[rows]))
        BT_S = B_S.T.tocsr()

        def apply(w):
            dz = self.solver.solve(w)
            dlam = -cho_solve(fac, B_S @ dz)
            return dz + (1.0 + alpha) * self.solver.solve(BT_S @ dlam)

        return apply

    def _newmark_contact(self, z_star, rhs0, alpha, active):
        """Contact forces of one Newmark step by the condensed complementarity problem."""
        c = self.contact
        h = c.gaps(z_star)
        if not np.any(h < 0) and (active is None or not active.any()):
            return np.zeros(len(h)), z_star, None
        ok = c.active_rows
        if self._delassus_at != c.n_projections:
            Bc = (c.B @ self.R)[:, self.cond][ok].tocsr()
            BG = Bc @ self.G_zone
            self._delassus = (1.0 + alpha) * np.asarray(Bc @ BG.T)
            self._delassus_at = c.n_projections
        lam = np.zeros(len(h))
        lam[ok], _ = solve_penalty_lcp(None, None, h[ok], c.eps_w[ok],
                                       None if active is None or len(active) != len(h)
                                       else active[ok], C=self._delassus)
        if not np.any(lam > 0):
            return lam, z_star, lam > 0
        z_new = self.solver.solve(rhs0 + (1.0 + alpha) * (c.BT @ lam))
        return lam, z_new, lam > 0

    # -- measurements ----------------------------------------------------------------
    def result(self) -> DynamicResult:
        """Measurements and history of the steps done so far."""
        h = self.history
        plastic_points = (0 if self.plastic is None
                          else int(np.count_nonzero(self.plastic.alpha > 0.0)))
        meas = impact_measurements(h, self.initial_gap, plastic=plastic_points > 0)
        info = {
            "integrator": self.case.analysis.integrator,
            "hht_alpha": self.case.analysis.hht_alpha,
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
            "penalty": [p.penalty for p in self.pairs],
            "contact_zone_nodes": int(len(self.contact.g_ref)),
            "projections": int(self.contact.n_projections),
            "zone_growths": int(self.n_zone_growth),
            "zone_clearance": (self.monitor.closest if math.isfinite(self.monitor.closest)
                               else None),
            "contact_point": self.x_contact.tolist(),
            "contact_normal": self.normal.tolist(),
            "initial_gap": self.initial_gap,
            "sides": {"slave": self.slave_side.name, "master": self.master_side.name},
            "effective_mass": self.effective_mass,
            "plasticity": None if self.plastic is None else {
                "zone_elements": int(self.plastic.n_elements),
                "zone_radius": self.plastic_radius,
                "plastic_points": plastic_points,
                "boundary_yielded": bool(self.plastic.boundary_yielded()),
                "dissipation": float(self.plastic.dissipation()),
                "plastic_iterations": self.plastic_iterations,
                "krylov_products": self.krylov_products,
                "newton_fallbacks": self.newton_fallbacks,
                "max_equivalent_plastic_strain": float(
                    self.plastic.equivalent_plastic_strain("max").max(initial=0.0))},
        }
        out = {k: v[self.output_index] for k, v in h.items()} if len(h["time"]) else h
        return DynamicResult(h, out, meas, info, dict(self.timings), self.mesh, self.model,
                             list(self._frames))


def impact_measurements(history: dict[str, np.ndarray], initial_gap: float,
                        plastic: bool = True) -> dict:
    """Peak force, approach, contact duration, restitution and energy error of a history.

    The contact starts at the first step with a force and ends at the first
    step after the peak force where the force is zero again (single nodes may
    chatter on and off at first touch); both ends are interpolated linearly
    in the approach, which is zero at first touch and at an elastic
    separation (the residual indentation after a dent). The
    restitution compares the relative normal velocity at the end of the run
    (or just before the bodies touch again) with that before first touch.
    The residual indentation is the approach at which the force reaches zero
    on unloading (``F^(2/3)`` extrapolated from the last two loaded steps,
    within the step where it vanishes): the permanent dent of both bodies
    together. When nothing yielded (``plastic=False``) it is 0: the bodies'
    vibration moves the point where an elastic pair parts by 1-3% of the
    largest approach either way, which is not a dent.
    """
    t, F = history["time"], history["contact_force"]
    E = history["total_energy"]
    e0 = E[0] if len(E) else 0.0
    out = {"peak_force": float(F.max(initial=0.0)),
           "time_of_peak_force": float(t[int(np.argmax(F))]) if len(F) else None,
           "max_approach": float(history["approach"].max(initial=-np.inf)) if len(F) else None,
           "energy_error": float(np.abs(E - e0).max() / e0) if e0 > 0 else None,
           "contact_duration": None, "first_touch": None, "separation": None,
           "restitution": None, "impact_velocity": None, "rebound_velocity": None,
           "residual_indentation": None, "contacts": 0}
    on = F > 0
    if not on.any():
        return out
    i0 = int(np.argmax(on))
    ipk = int(np.argmax(F))
    rest = ~on[ipk:]
    i1 = ipk + int(np.argmax(rest)) if rest.any() else None
    d = history["approach"]

    def cross(i: int) -> float:
        # the approach crosses zero between steps i-1 and i
        a, b = d[i - 1], d[i]
        s = 0.0 if b == a else min(max(-a / (b - a), 0.0), 1.0)
        return float(t[i - 1] + s * (t[i] - t[i - 1]))

    out["first_touch"] = cross(i0) if i0 > 0 else float(t[0])
    starts = np.flatnonzero(on[1:] & ~on[:-1]) + 1
    out["contacts"] = int(len(starts) + (1 if on[0] else 0))
    vn = history["normal_velocity"]
    v_before = float(vn[max(i0 - 1, 0)])
    out["impact_velocity"] = -v_before
    if i1 is not None:
        # first step with zero force: separation lies in (i1-1, i1], where the
        # approach passes zero (elastic) or, if it stays positive, the residual
        # indentation (a dent)
        res = _unloaded_approach(F, d, i1)
        end = 0.0 if d[i1] <= 0.0 else res
        a, b = d[i1 - 1] - end, d[i1] - end
        s = 0.0 if b == a else min(max(a / (a - b), 0.0), 1.0)
        out["separation"] = float(t[i1 - 1] + s * (t[i1] - t[i1 - 1]))
        out["contact_duration"] = out["separation"] - out["first_touch"]
        # an elastic pair can part a little before the first-touch position (the
        # sides' vibration): no dent, not a negative one
        out["residual_indentation"] = max(res, 0.0) if plastic else 0.0
        later = starts[starts > i1]
        j = int(later[0] - 1) if len(later) else len(t) - 1
        v_after = float(vn[j])
        out["rebound_velocity"] = v_after
        if v_before < 0:
            out["restitution"] = -v_after / v_before
    return out


def _unloaded_approach(F: np.ndarray, d: np.ndarray, i1: int) -> float:
    """Approach where the force falls to zero between steps ``i1 - 1`` and ``i1``.

    Unloading ends along a Hertz curve ``F ~ (d - d_p)^1.5`` (elastic or
    from a dent, as in Thornton's model), so ``F^(2/3)`` is extrapolated
    linearly from the last two loaded steps: exact for that curve, kept
    within the step.
    """
    lo, hi = sorted((float(d[i1]), float(d[i1 - 1])))
    if i1 >= 2 and F[i1 - 2] > F[i1 - 1] > 0 and d[i1 - 2] != d[i1 - 1]:
        y1, y2 = F[i1 - 1] ** (2.0 / 3.0), F[i1 - 2] ** (2.0 / 3.0)
        slope = (y2 - y1) / (d[i1 - 2] - d[i1 - 1])
        if slope > 0:
            return float(min(max(d[i1 - 1] - y1 / slope, lo), hi))
    return float(d[i1 - 1])
