"""The rolling mesh: tooth sectors turning through mesh, integrated in time.

Floating frame of reference (Shabana, *Dynamics of Multibody Systems*, ch. 5;
the turning frames of Calyx, Parker, Vijayakar and Imajo 2000). Each gear's
coordinates are ``q = (u, theta)``: ``theta`` its rotor's rotation from the
mesh's placement (positive in the drive sense), ``u`` the small elastic
displacement of its sector in a frame turning with the rotor, zero on the hub
(tied to the rotor). A material point is at ``c + R(theta) (X + u - c)``,
exactly for any ``theta``. Linearised in ``u`` and its rates, the kinetic
energy gives the constant mass matrix ``[[M, M psi], [psi^T M, J]]``
(``psi`` = the rigid rotation mode of the sector, ``J`` = the gear set's
inertia of the gear; the sector's own share ``psi^T M psi`` is part of it)
and the stiffness ``[[K, 0], [0, 0]]``; both are constant for the whole
path, so one factorisation of the Newmark matrix ``M + beta dt^2 K`` serves
every step. The centrifugal load ``omega^2 M r`` (``r`` the points' distance
vector from the axis; constant at constant speed) is applied to each sector;
the Coriolis force ``2 omega M (e x u_dot)`` and the spin softening
``-omega^2 M`` on ``u`` are left out (:func:`inertial_terms` states their size).

Contact. Pair ``k`` is pinion tooth ``k`` with face-gear tooth ``k`` on the
drive flanks, and pinion tooth ``k`` with the face-gear tooth it faces on
the coast flanks (backlash ``b``). Where the turned flanks touch comes from
the exact flanks: the gear pair's tooth contact analysis
(:class:`~fe_impact.gears.tca.GearPair`) gives the contact point and normal
at each roll angle, and the line-of-action geometry
(:func:`~fe_impact.gears.kinematics.mesh_geometry`: path ends and the gaps of
the rounded tip edges beyond them) the rigid gap, in the torsional model's
coordinate ``x = r_bp theta_p - r_b2 theta_f + b/2``: drive gap
``g(s) + b/2 - x``, coast gap ``g(s_c) + b/2 + x``. A pair's force enters each sector spread
along the major axis of the Hertz ellipse (the Hertz line load at
:data:`SPREAD_POINTS` points). The mesh does not resolve the contact, so the
sectors' displacement is not read at the contact point, where it holds the
mesh's own indentation under that load, but at depth ``d`` below it along
each flank's inward normal (interpolated in the tetrahedron that holds the
point, :meth:`Body.probe`), projected on the contact normal; the layer above
is the half-spaces' compression ``0..d`` under the Hertz pressure of the
pair's force (:class:`LayerLaw`, the far-field matching of
:mod:`fe_impact.contact.nearfield_fe` and ``validation/hertz_static.py``).
The pair's local approach is thus the sum over both bodies of the layer's
compression and the FE displacement at ``d``; ``d`` is two flank element
sizes, at most half the thinner tooth's thickness along the normal
(:data:`CHORD_FRACTION`). Rigid rotors take the Hertz approach ``P = K_H
delta^1.5`` (:class:`HertzLaw`). The force follows from the complementarity
of gap and force at each step (:func:`solve_contact`).

Integration: Newmark's average acceleration (``beta = 1/4``, ``gamma =
1/2``): no numerical damping, and for the linear part an exact discrete
energy balance, so the energy check measures the contact's share.
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from fe_impact.errors import CaseError

logger = logging.getLogger(__name__)

__all__ = ["Body", "ContactGeometry", "RollSettings", "Roller", "inertial_terms",
           "static_pair_approach"]

BETA, GAMMA = 0.25, 0.5
#: Points along the Hertz ellipse's major axis a pair's force is spread over.
SPREAD_POINTS = 9


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


_MIRROR = np.diag([-1.0, 1.0, 1.0])


# -- the exact flanks: contact points along the path -------------------------------------------
@dataclass(frozen=True)
class ContactGeometry:
    """The stage's contact path, in the tooth-0 frames of the two gears.

    Attributes
    ----------
    s : ndarray (n,)
        Positions on the line of action [m] (from the base tangency) of the table.
    pinion_points, face_points : ndarray (n, 3)
        The contact point in the pinion's and the face gear's own frame
        (tooth 0; :meth:`~fe_impact.gears.tca.GearPair.pinion_to_mesh`).
    pinion_normals, face_normals : ndarray (n, 3)
        The face gear's outward flank normal at the point, in the same frames.
    hertz_k : ndarray (n,)
        ``K_H`` of ``P = K_H delta^1.5`` [N/m^1.5] of the flanks' curvatures.
    pinion_majors, face_majors : ndarray (n, 3)
        The Hertz ellipse's major axis in the two frames.
    major_unit, minor_unit, pressure_unit : ndarray (n,)
        Its semi-axes [m] and peak pressure [Pa] at 1 N (each ``~ P^(1/3)``).
    youngs_modulus, poisson_ratio : float
        The flanks' material (Young's modulus times ``stiffen``) [Pa], [-].
    """

    pair: object = field(repr=False)
    mesh: object = field(repr=False)       # MeshGeometry
    backlash: float
    s: np.ndarray
    pinion_points: np.ndarray
    face_points: np.ndarray
    pinion_normals: np.ndarray
    face_normals: np.ndarray
    hertz_k: np.ndarray
    pinion_majors: np.ndarray = None
    face_majors: np.ndarray = None
    major_unit: np.ndarray = None
    minor_unit: np.ndarray = None
    pressure_unit: np.ndarray = None
    youngs_modulus: float = 0.0
    poisson_ratio: float = 0.0

    @property
    def base_radii(self) -> tuple[float, float]:
        """``r_bp``, ``r_b2`` [m]: the torques of a unit normal force."""
        p = self.pair
        cos_a = math.cos(p.pinion.pressure_angle)
        return p.pinion.pitch_radius * cos_a, p.face.pitch_radius * cos_a

    @classmethod
    def build(cls, gearset, stage: int, backlash: float | None = None, n: int = 61,
              corners: str = "3d", stiffen: float = 1.0) -> ContactGeometry:
        """TCA over the path of contact of ``stage`` (``n`` roll angles); ``stiffen``
        multiplies Young's modulus (the kinematic check's stiffened material)."""
        from fe_impact.gears.kinematics import default_backlash, mesh_geometry
        from fe_impact.gears.tca import GearPair, contact_ellipse, equivalent_radius
        from fe_impact.physics import hertz

        pair = GearPair.from_gearset(gearset, stage)
        geo = mesh_geometry(gearset, stage, corners)
        if backlash is None:
            backlash = default_backlash(gearset.module, pair.pinion.pitch_radius,
                                        pair.face.pitch_radius)
        # a hair inside the ends: the TCA's flanks end there
        s = np.linspace(geo.s_start, geo.s_end, n)
        rolls = geo.roll_at(s)
        path = pair.path(rolls)
        mat = gearset.material
        e_star = hertz.effective_modulus(mat.youngs_modulus * stiffen, mat.poisson_ratio)
        pp, fp, pn, fn, kh, pm, fm, au, bu, pu = [], [], [], [], [], [], [], [], [], []
        t_p = np.array([0.0, pair.pinion.pitch_radius, pair.z0])
        for c in path.points:
            rp, rf = pair.pinion_rotation(c.roll_angle), pair.face_rotation(c.face_angle)
            pp.append(rp.T @ (c.point - t_p))
            pn.append(rp.T @ c.normal)
            fp.append(rf.T @ c.point)
            fn.append(rf.T @ c.normal)
            radius = equivalent_radius(c.relative, e_star)
            kh.append(4.0 / 3.0 * e_star * math.sqrt(radius))
            ell = contact_ellipse(c.relative, 1.0, e_star)
            pm.append(rp.T @ ell.major)
            fm.append(rf.T @ ell.major)
            au.append(ell.a)
            bu.append(ell.b)
            pu.append(ell.p0)
        return cls(pair, geo, float(backlash), s, np.array(pp), np.array(fp), np.array(pn),
                   np.array(fn), np.array(kh), np.array(pm), np.array(fm), np.array(au),
                   np.array(bu), np.array(pu), float(mat.youngs_modulus * stiffen),
                   float(mat.poisson_ratio))

    def at(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """Points, normals (pinion, face frames of tooth 0) and ``K_H`` at ``s``
        (clamped to the path: beyond it, a tip edge touches at the path's end)."""
        s = float(np.clip(s, self.s[0], self.s[-1]))
        i = int(np.clip(np.searchsorted(self.s, s) - 1, 0, len(self.s) - 2))
        w = (s - self.s[i]) / (self.s[i + 1] - self.s[i])

        def lerp(a):
            return (1.0 - w) * a[i] + w * a[i + 1]

        return (lerp(self.pinion_points), lerp(self.face_points), lerp(self.pinion_normals),
                lerp(self.face_normals), float(lerp(self.hertz_k)))

    def ellipse_at(self, s: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Major axes (pinion, face frames of tooth 0) and the semi-major axis at 1 N."""
        s = float(np.clip(s, self.s[0], self.s[-1]))
        i = int(np.clip(np.searchsorted(self.s, s) - 1, 0, len(self.s) - 2))
        w = (s - self.s[i]) / (self.s[i + 1] - self.s[i])
        pm = (1 - w) * self.pinion_majors[i] + w * self.pinion_majors[i + 1]
        fm = (1 - w) * self.face_majors[i] + w * self.face_majors[i + 1]
        return (pm / np.linalg.norm(pm), fm / np.linalg.norm(fm),
                float((1 - w) * self.major_unit[i] + w * self.major_unit[i + 1]))

    def unit_ellipse_at(self, s: float) -> tuple[float, float, float]:
        """Semi-axes ``a``, ``b`` [m] and peak pressure ``p0`` [Pa] of the Hertz ellipse of
        1 N at ``s`` (clamped to the path); each scales as ``P^(1/3)``."""
        s = float(np.clip(s, self.s[0], self.s[-1]))
        i = int(np.clip(np.searchsorted(self.s, s) - 1, 0, len(self.s) - 2))
        w = (s - self.s[i]) / (self.s[i + 1] - self.s[i])
        return tuple(float((1 - w) * v[i] + w * v[i + 1])
                     for v in (self.major_unit, self.minor_unit, self.pressure_unit))

    def gap(self, s: float) -> tuple[float, float]:
        """Rigid gap of a pair at ``s`` [m] and its slope ``dg/ds``."""
        g, dg = self.mesh.gap(np.array([s]))
        return float(g[0]), float(dg[0])

    def reach(self) -> tuple[float, float]:
        """Line-of-action range [m] where a pair can touch (its gap below the corner cap)."""
        return (self.mesh.s_start - self.mesh.approach.delta_max,
                self.mesh.s_end + self.mesh.recess.delta_max)


# -- one gear: its sector and its rotor ---------------------------------------------------------
@dataclass(eq=False)
class Body:
    """A gear's coordinates ``(u, theta)`` and their constant matrices.

    ``u`` may be empty (a rigid gear). ``psi`` is the rigid rotation mode of
    the sector's free DOFs; the mesh frame ``to_ref`` rotation maps the gear's
    own frame (tooth 0 at its TCA position) to the mesh's placement.
    """

    name: str
    M: sp.csr_matrix            # (n, n), rotor last
    K: sp.csr_matrix
    axis_point: np.ndarray
    axis: np.ndarray            # unit, drive-sense rotation = -axis (right hand)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))   # flank nodes, ref
    triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), int))
    tri_dofs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3), int))
    solver: object = None
    tree: object = None
    #: centrifugal load per unit squared speed in the turning frame [N s^2] (n,)
    centrifugal: np.ndarray | None = None
    n_dofs_mesh: int = 0
    free_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    #: the sector's tetrahedra (e, 4 or 10 node numbers), for the probes at depth
    cells: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), int))
    #: free-DOF index of each mesh point's three components (-1: on the hub or not in
    #: the sector: no elastic displacement)
    node_dofs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), int))
    cell_tree: object = None
    #: the flank elements' size [m] (median corner-to-corner edge of the flank triangles)
    flank_size: float = 0.0

    @property
    def n(self) -> int:
        return self.M.shape[0]

    @property
    def elastic(self) -> bool:
        return self.n > 1

    def factorise(self, dt: float, prescribed: bool) -> None:
        """Factorise ``M + beta dt^2 K`` (without the rotor row if ``prescribed``)."""
        S = (self.M + BETA * dt * dt * self.K).tocsc()
        if prescribed:
            S = S[:-1, :-1]
        if S.shape[0] == 0:
            self.solver = None
            return
        if S.shape[0] == 1:
            value = float(S[0, 0])
            self.solver = lambda b: b / value
            return
        try:
            from fe_impact.fe.linalg import SPDSolver
            self.solver = SPDSolver(S.tocsr()).solve
        except Exception:   # noqa: BLE001 - no MKL: SuperLU
            from scipy.sparse.linalg import splu
            lu = splu(S)
            self.solver = lu.solve

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Free-DOF indices (3, 3) and weights (3,) of the flank triangle holding
        reference point ``x`` (linear shape functions of its corners), and the
        point's distance from that triangle [m]."""
        _, near = self.tree.query(x, k=min(12, len(self.triangles)))
        near = np.atleast_1d(near)
        a, b, c = (self.points[self.triangles[near, i]] for i in range(3))
        e1, e2, d = b - a, c - a, x - a
        nrm = np.cross(e1, e2)
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        h = np.einsum("ij,ij->i", d, nrm)
        p = d - h[:, None] * nrm
        m11, m12 = np.einsum("ij,ij->i", e1, e1), np.einsum("ij,ij->i", e1, e2)
        m22 = np.einsum("ij,ij->i", e2, e2)
        r1, r2 = np.einsum("ij,ij->i", p, e1), np.einsum("ij,ij->i", p, e2)
        det = m11 * m22 - m12 * m12
        l1, l2 = (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det
        w = np.stack([1.0 - l1 - l2, l1, l2], axis=1)
        outside = -np.minimum(w.min(axis=1), 0.0)
        score = np.abs(h) + outside * np.sqrt(m11)
        best = int(np.argmin(score))
        wb = np.clip(w[best], 0.0, None)
        return self.tri_dofs[near[best]], wb / wb.sum(), float(abs(h[best]))


    def probe(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Free-DOF indices (m, 3) and weights (m,) interpolating the displacement at the
        reference point ``x`` inside the sector (the shape functions of the tetrahedron
        holding it: the one with the largest smallest barycentric coordinate among the
        16 with the nearest centroids, as
        :func:`~fe_impact.contact.nearfield_fe.probe_matrix` does), and how far
        outside that tetrahedron the point is, as its smallest barycentric coordinate
        (0 inside, < 0 outside). Nodes on the hub are left out (they do not move in
        the turning frame)."""
        from fe_impact.contact.nearfield_fe import TET10_EDGES

        if self.cell_tree is None:
            self.cell_tree = cKDTree(self.points[self.cells[:, :4]].mean(axis=1))
        for n_cand in (16, 96):     # stretched elements: the nearest centroids may miss
            _, cand = self.cell_tree.query(x, k=min(n_cand, len(self.cells)))
            cand = np.atleast_1d(cand)
            vert = self.points[self.cells[cand, :4]]                    # (k, 4, 3)
            T = np.stack([vert[:, i] - vert[:, 3] for i in range(3)], axis=-1)
            lam3 = np.linalg.solve(T, (x - vert[:, 3])[..., None])[..., 0]
            L = np.column_stack([lam3, 1.0 - lam3.sum(axis=1)])
            best = int(np.argmax(L.min(axis=1)))
            if L[best].min() >= -1e-9:
                break
        inside = float(L[best].min())
        lb = np.clip(L[best], 0.0, None)
        lb /= lb.sum()
        nodes = self.cells[cand[best]]
        if len(nodes) == 10:
            shape = np.concatenate([lb * (2 * lb - 1),
                                    [4 * lb[i] * lb[j] for i, j in TET10_EDGES]])
        else:
            shape = lb
        dofs = self.node_dofs[nodes]
        keep = dofs[:, 0] >= 0
        return dofs[keep], shape[keep], inside


def rigid_body(name: str, inertia: float, axis_point, axis) -> Body:
    """A gear without elastic DOFs (its rotor only)."""
    return Body(name, sp.csr_matrix(np.array([[inertia]])), sp.csr_matrix((1, 1)),
                np.asarray(axis_point, float), np.asarray(axis, float))


# -- settings and records ------------------------------------------------------------------------
@dataclass(frozen=True)
class RollSettings:
    """Operating point and time stepping.

    Attributes
    ----------
    speed : float
        Pinion speed [rad/s] (positive: driving the drive flanks).
    torque : float
        Load torque on the face gear [N m] (opposes its drive-sense rotation).
    cycles : float
        Mesh cycles to simulate.
    steps_per_cycle : int
    ramp_cycles : float
        The load torque rises as ``sin^2`` over these cycles (0: at once).
    start_cycles : float or None
        Where pair 0 starts, in base pitches after the path's start; None: at the
        start of the longest stretch the sectors hold (:meth:`Roller.held_window`).
    te_amplitude : float
        A kinematic transmission error [m] (a pinion profile error, the torsional
        model's ``e = A sin(2 pi u / p_b)``, ``u`` the pinion's roll on the line of
        action since the start): it opens the drive gaps and closes the coast gaps
        by ``e``, as the torsional model's kernel does, so that the unloaded drive
        flank's TE is ``+e`` in the TE's sign (positive when the pinion leads:
        the pinion must lead by ``e`` more to touch). 0: exact flanks.
    spread_force : float or None
        A pair's force enters the sectors spread along the major axis of the Hertz
        ellipse of this force [N] (the line load of the Hertz pressure, ``~ 1 -
        xi^2``, at :data:`SPREAD_POINTS` points); None: the load torque's mesh force,
        at least 100 N. 0: at the contact point alone.
    probe_depth : float or None
        Depth ``d`` [m] below the contact point (along each flank's inward normal)
        where the elastic sectors' displacement is read; the layer above it is the
        half-spaces' (:class:`LayerLaw`). None: :data:`PROBE_ELEMENTS` flank element
        sizes. 0: read on the surface and add the Hertz approach (:class:`HertzLaw`;
        the FE's own indentation under the spread load is then counted on top of
        Hertz's). Rigid rotors always take the Hertz approach.
    layer_scale : tuple of (float, float)
        A diagnostic, not part of the model: points ``(s [m], factor)`` by which the
        layers' compression of a pair at ``s`` is multiplied (linear between them,
        the end values beyond); ``validation/rolling.py``'s sensitivity of the
        quasi-static TE to the pinion tip's compliance. Empty: none.
    """

    speed: float
    torque: float = 0.0
    cycles: float = 1.0
    steps_per_cycle: int = 400
    ramp_cycles: float = 0.0
    speed_ramp_cycles: float = 0.0
    start_cycles: float | None = None
    te_amplitude: float = 0.0
    spread_force: float | None = None
    probe_depth: float | None = None
    layer_scale: tuple = ()


def inertial_terms(sector_mass: float, radius: float, speed: float, mesh_force: float,
                   elastic_speed: float) -> dict[str, float]:
    """Size of the centrifugal and Coriolis forces left out, against the mesh force.

    ``m omega^2 r`` of the sector's mass at its radius and ``2 m omega v`` for
    elastic speeds ``v`` [m/s], each divided by ``mesh_force`` [N].
    """
    centrifugal = sector_mass * speed**2 * radius
    coriolis = 2.0 * sector_mass * speed * elastic_speed
    return {"centrifugal_n": centrifugal, "coriolis_n": coriolis,
            "centrifugal_fraction": centrifugal / mesh_force if mesh_force else math.inf,
            "coriolis_fraction": coriolis / mesh_force if mesh_force else math.inf}


# -- the time integration -----------------------------------------------------------------------
class Roller:
    """Newmark integration of the two gears in contact (see the module text).

    Parameters
    ----------
    geometry : ContactGeometry
    pinion, face : Body
        Their reference configuration is the mesh's placement, pinion tooth 0 at
        TCA roll ``roll_placed``, face-gear tooth 0 at ``face_placed``.
    teeth : range
        Tooth numbers present in both sectors.
    """

    def __init__(self, geometry: ContactGeometry, pinion: Body, face: Body, teeth: range,
                 roll_placed: float, face_placed: float, settings: RollSettings) -> None:
        self.geo, self.p, self.f, self.teeth = geometry, pinion, face, teeth
        self.roll_placed, self.face_placed = roll_placed, face_placed
        self.set = settings
        pair = geometry.pair
        self.r_bp, self.r_b2 = geometry.base_radii
        self.ratio = pair.ratio
        self.pitch_p = 2 * math.pi / pair.pinion.teeth
        self.pitch_f = 2 * math.pi / pair.face.teeth
        self.p_b = geometry.mesh.base_pitch
        self.period = self.pitch_p / settings.speed
        self.dt = self.period / settings.steps_per_cycle
        self.n_steps = int(round(settings.cycles * settings.steps_per_cycle))
        self.t_p = np.array([0.0, pair.pinion.pitch_radius, pair.z0])
        self._coast_tooth: dict[int, int] = {}
        self.spread_force = (settings.spread_force if settings.spread_force is not None
                             else max(settings.torque / self.r_b2, 100.0))
        if self.spread_force > 0.0:
            self._xi = (np.arange(SPREAD_POINTS) + 0.5) / SPREAD_POINTS * 2.0 - 1.0
            q = 1.0 - self._xi**2
            self._q = q / q.sum()
        else:
            self._xi, self._q = np.zeros(1), np.ones(1)
        self.depth = 0.0
        if pinion.elastic and face.elastic:
            size = max(pinion.flank_size, face.flank_size)
            self.depth = (settings.probe_depth if settings.probe_depth is not None
                          else PROBE_ELEMENTS * size)
        if self.depth > 0.0:
            kappa = geometry.minor_unit / geometry.major_unit
            self._tables = LayerLaw.tabulate((float(kappa.min()), float(kappa.max())),
                                             geometry.poisson_ratio)
        lo, hi = self.held_window()
        margin = 0.01 * self.pitch_p
        #: mesh cycles the sectors hold
        self.capacity = max((hi - lo - 2 * margin) / self.pitch_p, 0.0)
        if settings.start_cycles is None:
            #: pinion rotor angle at t = 0 [rad, drive sense, from the placement]
            self.theta0 = lo + margin
        else:   # pair 0 at the path's start plus start_cycles pitches
            s0 = geometry.mesh.s_start + settings.start_cycles * self.p_b
            self.theta0 = roll_placed - (geometry.mesh.s_pitch - s0) / self.r_bp
        end = self.pinion_motion(self.n_steps * self.dt)[0]
        if not (lo <= self.theta0 and end <= hi):
            raise CaseError(self._window_refusal(settings, len(teeth), lo, hi, end))
        pinion.factorise(self.dt, prescribed=True)
        face.factorise(self.dt, prescribed=False)

    def _window_refusal(self, settings, n_teeth: int, lo: float, hi: float, end: float
                        ) -> str:
        """Why the run leaves the sectors' window, with the start and length that fit."""
        msg = (f"cycles = {settings.cycles:g}: the sectors ({n_teeth} teeth each) hold "
               f"{self.capacity:.2f} mesh cycles from the start of their window")
        from fe_impact.rolling.sectors import TEETH_RANGE

        top = TEETH_RANGE[1]
        more = ("ask for fewer cycles" + (f" or more --teeth (up to {top})"
                                          if n_teeth < top else ""))
        if settings.start_cycles is None:
            return f"{msg}; {more}"
        # start_cycles moves theta0 by the pinion angle of one base pitch per unit
        per = self.p_b / self.r_bp
        first = settings.start_cycles + (lo - self.theta0) / per
        if self.theta0 < lo:      # the start is before the window: nothing fits from it
            return (msg + f"; start_cycles {settings.start_cycles:g} is before the window, "
                    f"which begins at start_cycles {first:.2f}: {more}, or move the start "
                    "there or later")
        fits = settings.cycles * (hi - self.theta0) / (end - self.theta0)
        return (msg + f"; from start_cycles {settings.start_cycles:g} about "
                f"{max(fits, 0.0):.2f} fit; start_cycles {first:.2f} or more uses the "
                f"window from its start: {more}, or move the start")

    # -- kinematics of the pinion (prescribed) --------------------------------------------------
    def pinion_motion(self, t: float) -> tuple[float, float, float]:
        """Drive-sense angle [rad], speed, acceleration of the pinion rotor at ``t``.

        With ``speed_ramp_cycles`` the speed rises from 0 as ``sin^2`` (the
        acceleration continuous at both ends, so that no step of it rings the
        contact); then it is constant.
        """
        w, tr = self.set.speed, self.set.speed_ramp_cycles * self.period
        if tr <= 0.0 or t >= tr:
            return self.theta0 + w * (t - 0.5 * max(tr, 0.0)), w, 0.0
        c = math.pi / tr
        return (self.theta0 + w * (0.5 * t - math.sin(c * t) / (2.0 * c)),
                w * math.sin(0.5 * c * t) ** 2, 0.5 * w * c * math.sin(c * t))

    def load(self, t: float) -> float:
        tr = self.set.ramp_cycles * self.period
        if tr <= 0.0 or t >= tr:
            return self.set.torque
        return self.set.torque * math.sin(0.5 * math.pi * t / tr) ** 2

    # -- pair positions ---------------------------------------------------------------------------
    def _pairs(self, theta_p: float, teeth) -> list[tuple[int, int, float, bool]]:
        """``(flank, tooth, s, held)`` of every pair in reach whose pinion tooth is in
        ``teeth`` (flank 0 drive, 1 coast); ``held``: both its teeth are in the sectors."""
        lo, hi = self.geo.reach()
        out = []
        for k in teeth:
            phi = self.roll_placed - theta_p - k * self.pitch_p   # roll of pinion tooth k
            s_d = self.geo.mesh.s_pitch - self.r_bp * phi
            s_c = 2 * self.geo.mesh.s_pitch + 0.5 * self.p_b - s_d
            if lo < s_d < hi:
                out.append((0, k, s_d, k in self.teeth))
            if lo < s_c < hi:
                held = k in self.teeth and self._coast_face_tooth(k, theta_p) in self.teeth
                out.append((1, k, s_c, held))
        return out

    def positions(self, theta_p: float) -> list[tuple[int, int, float]]:
        """``(flank, tooth, s)`` of every pair in reach that the sectors hold."""
        return [(fl, k, s) for fl, k, s, held in self._pairs(theta_p, self.teeth) if held]

    def held(self, theta_p: float) -> bool:
        """Whether every pair in reach at ``theta_p`` is in the sectors, and a drive pair
        is (beyond the sectors no pair is in reach: not a window that meshes)."""
        wide = range(min(self.teeth) - 3, max(self.teeth) + 4)
        pairs = self._pairs(theta_p, wide)
        return all(h for *_, h in pairs) and any(fl == 0 for fl, *_ in pairs)

    def held_window(self) -> tuple[float, float]:
        """The longest range of pinion angles [rad, drive sense] the sectors hold."""
        grid = self.roll_placed + np.linspace(-8, 8, 3201) * self.pitch_p
        ok = np.array([self.held(t) for t in grid])
        best, start = (0, 0), None
        for i, v in enumerate(np.append(ok, False)):
            if v and start is None:
                start = i
            elif not v and start is not None:
                if i - 1 - start > best[1] - best[0]:
                    best = (start, i - 1)
                start = None
        return float(grid[best[0]]), float(grid[best[1]])

    def _ref_points(self, fl: int, k: int, s: float, theta_p: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """Contact point and face-outward normal in each body's reference frame.

        A coast contact is the drive contact of the mirror image (``x -> -x``;
        both teeth are symmetric about their centre planes): pinion tooth ``k``
        at roll ``phi`` is, mirrored, at ``-pi/N_p - phi``, and it meets the
        face-gear tooth whose mirrored angle is the conjugate one there.
        """
        xp, xf, np_, nf, kh = self.geo.at(s)
        mp, mf, a1 = self.geo.ellipse_at(s)
        n = k
        if fl == 1:
            xp, xf, np_, nf, mp, mf = (_MIRROR @ v for v in (xp, xf, np_, nf, mp, mf))
            n = self._coast_face_tooth(k, theta_p)
        pair = self.geo.pair
        rp = pair.pinion_rotation(self.roll_placed - k * self.pitch_p)
        rf = pair.face_rotation(self.face_placed - n * self.pitch_f)
        self._majors = (rp @ mp, rf @ mf, a1)
        return rp @ xp + self.t_p, rf @ xf, rp @ np_, rf @ nf, kh

    def _coast_face_tooth(self, k: int, theta_p: float) -> int:
        """The face-gear tooth that pinion tooth ``k``'s coast flank faces."""
        if k not in self._coast_tooth:
            pair = self.geo.pair
            phi = self.roll_placed - theta_p - k * self.pitch_p
            face0 = self.face_placed - self.ratio * theta_p
            mirrored = pair.nominal_face_angle(-math.pi / pair.pinion.teeth - phi)
            val = (mirrored + face0) / self.pitch_f
            n_face = pair.face.teeth
            base = round(val)
            self._coast_tooth[k] = min((base + j * n_face for j in (-1, 0, 1)),
                                       key=lambda n: abs(n - k))
        return self._coast_tooth[k]

    def excitation(self, theta_p: float) -> tuple[float, float]:
        """Kinematic transmission error ``e`` [m] and ``de/dtheta_p`` [m/rad]."""
        a = self.set.te_amplitude
        if a == 0.0:
            return 0.0, 0.0
        phase = 2.0 * math.pi / self.p_b
        u = self.r_bp * (theta_p - self.theta0)
        return a * math.sin(phase * u), a * phase * self.r_bp * math.cos(phase * u)

    def world(self, x_ref: np.ndarray, theta: float, body: str) -> np.ndarray:
        """Mesh-frame position of reference point ``x_ref`` of ``body`` (``"pinion"`` or
        ``"face_gear"``) when its rotor is at ``theta`` (drive sense, from the placement)."""
        pair = self.geo.pair
        if body == "pinion":
            rot = (pair.pinion_rotation(self.roll_placed - theta)
                   @ pair.pinion_rotation(self.roll_placed).T)
            return rot @ (x_ref - self.t_p) + self.t_p
        rot = pair.face_rotation(self.face_placed - theta) @ pair.face_rotation(
            self.face_placed).T
        return rot @ x_ref

    # -- contact rows ----------------------------------------------------------------------
    def _rows(self, theta_p: float, theta_f: float) -> list[dict]:
        """Every pair in reach: rigid gap, its slopes and each body's row."""
        out = []
        m = self.geo
        for fl, k, s in self.positions(theta_p):
            g, dg = m.gap(s)
            xp, xf, np_, nf, kh = self._ref_points(fl, k, s, theta_p)
            sign = 1.0 if fl == 0 else -1.0
            e, de = self.excitation(theta_p)
            row = {"flank": fl, "tooth": k, "s": s, "g": g + 0.5 * m.backlash + sign * e,
                   "kh": kh, "dtheta_p": -sign * self.r_bp * (1.0 - dg) + sign * de,
                   "dtheta_f": sign * self.r_b2,
                   "sign": sign, "xp": xp, "xf": xf, "np": np_, "nf": nf}
            mp, mf, a1 = self._majors
            half = a1 * self.spread_force ** (1.0 / 3.0)
            if self.depth > 0.0:
                depth = self.pair_depth(fl, k, s, theta_p)
                row["law"] = self._layer_parameters(s, depth)
                row["depth"] = depth
            # the face gear's outward normal points into the pinion: each body's inward
            # normal is sg * nrm
            for body, x, nrm, major, sg, key in ((self.p, xp, np_, mp, 1.0, "p"),
                                                 (self.f, xf, nf, mf, -1.0, "f")):
                if not body.elastic:
                    row[key] = row[key + "_read"] = None
                    continue
                if self.depth > 0.0:
                    dofs, w, inside = body.probe(x + sg * depth * nrm)
                    if inside < -1e-3:
                        raise CaseError(
                            f"probe depth {depth * 1e3:.3g} mm: below pair {k}'s contact "
                            f"point (s = {s * 1e3:.3g} mm) it leaves the {body.name} tooth; "
                            "ask for a smaller depth")
                    row[key + "_read"] = (dofs.ravel(),
                                          (sg * w[:, None] * nrm[None, :]).ravel())
                dofs_all, coef_all = [], []
                for xi, q in zip(self._xi, self._q, strict=True):
                    dofs, w, dist = body.locate(x + xi * half * major)
                    if dist > 0.5 * self.p_b:
                        raise CaseError(f"pair {k} ({'drive' if fl == 0 else 'coast'}): the "
                                        f"contact point lies {dist * 1e3:.3g} mm off the "
                                        f"{body.name} sector's flanks")
                    dofs_all.append(dofs.ravel())
                    coef_all.append((q * sg * w[:, None] * nrm[None, :]).ravel())
                row[key] = (np.concatenate(dofs_all), np.concatenate(coef_all))
                if self.depth <= 0.0:
                    row[key + "_read"] = row[key]
            out.append(row)
        return out

    def _layer_parameters(self, s: float, depth: float) -> tuple[float, float, float]:
        """``(k, zeta_d, kappa)`` of :class:`LayerLaw` at ``s``, read at ``depth``."""
        a1, b1, p01 = self.geo.unit_ellipse_at(s)
        k = 2.0 * p01 * b1 / self.geo.youngs_modulus
        if self.set.layer_scale:
            at, factor = zip(*self.set.layer_scale, strict=True)
            k *= float(np.interp(s, at, factor))
        return k, depth / a1, b1 / a1

    def pair_depth(self, fl: int, k: int, s: float, theta_p: float) -> float:
        """Depth [m] of the reading of pair ``(fl, k)`` at ``s``: the run's depth, at most
        :data:`CHORD_FRACTION` of the thinner tooth's thickness along the normal."""
        j = math.floor(s / CHORD_STEP)
        w = s / CHORD_STEP - j
        chord = ((1.0 - w) * self._chord(fl, k, j, theta_p)
                 + w * self._chord(fl, k, j + 1, theta_p))
        depth = min(self.depth, CHORD_FRACTION * chord)
        lo, hi = getattr(self, "depth_range", (math.inf, 0.0))
        #: the smallest and largest depth a pair was read at [m]
        self.depth_range = (min(lo, depth), max(hi, depth))
        return depth

    def _chord(self, fl: int, k: int, j: int, theta_p: float) -> float:
        """Thickness [m] of the thinner tooth along the normal at ``s = j CHORD_STEP``
        (where a ray along the inward normal leaves the sector; capped at twice the
        run's depth), cached."""
        if not hasattr(self, "_chords"):
            self._chords = {}
        key = (fl, k, j)
        if key not in self._chords:
            keep = getattr(self, "_majors", None)
            xp, xf, np_, nf, _ = self._ref_points(fl, k, j * CHORD_STEP, theta_p)
            self._majors = keep
            cap = 2.0 * self.depth
            out = cap
            for body, x, n in ((self.p, xp, np_), (self.f, xf, -nf)):
                if body.probe(x + cap * n)[2] >= -1e-3:
                    continue
                lo, hi = 0.0, cap
                for _ in range(14):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if body.probe(x + mid * n)[2] >= -1e-3 else (lo, mid)
                out = min(out, lo)
            self._chords[key] = out
        return self._chords[key]

    def law(self, rows: list[dict]):
        """The local law of ``rows``' pairs (:class:`LayerLaw` when the sectors are read
        at depth, else :class:`HertzLaw`)."""
        if self.depth > 0.0:
            k, zeta, kappa = (np.array(v) for v in zip(*(row["law"] for row in rows),
                                                         strict=True))
            return LayerLaw(k, zeta, kappa, self._tables)
        return HertzLaw(np.array([row["kh"] for row in rows]))


def static_pair_approach(roller: Roller, s: float, force: float, tooth: int = 1,
                         solvers: dict | None = None) -> dict[str, float]:
    """The quasi-static approach [m] of one drive pair at ``s`` [m] under ``force`` [N],
    both rotors held, split into its parts: what the rolling model takes for the pair
    the mesh cycle's FE measures (``validation/rolling.py``).

    The pair of pinion tooth ``tooth`` is placed at ``s`` on the line of action; its
    force enters the sectors as in a step (spread along the Hertz ellipse) and the
    static displacement (the stiffness alone, the hubs tied to their held rotors) is
    read where the step reads it. Returns ``fe_pinion``, ``fe_face`` (each sector's
    displacement at the reading along the contact normal), ``local`` (the local law's
    approach: the layers' compression, or Hertz's when read at the surface),
    ``total`` (their sum, the pair's approach), ``depth`` [m] and ``surface_pinion``,
    ``surface_face`` (each sector's displacement at the surface under the spread load,
    for comparison). ``solvers``: a dict the static factorisations are kept in
    between calls (keyed by body name).
    """
    from fe_impact.fe.linalg import SPDSolver

    solvers = {} if solvers is None else solvers
    theta_p = roller.roll_placed - (roller.geo.mesh.s_pitch - s) / roller.r_bp \
        - tooth * roller.pitch_p
    rows = [row for row in roller._rows(theta_p, roller.ratio * theta_p)
            if row["tooth"] == tooth and row["flank"] == 0]
    if not rows:
        raise CaseError(f"s = {s * 1e3:.4g} mm: pinion tooth {tooth}'s drive pair is not in "
                        "the sectors' reach there")
    row = rows[0]
    out = {"depth": float(row.get("depth", 0.0))}
    for body, key in ((roller.p, "p"), (roller.f, "f")):
        name = "pinion" if key == "p" else "face"
        if not body.elastic:
            out[f"fe_{name}"] = out[f"surface_{name}"] = 0.0
            continue
        if body.name not in solvers:
            solvers[body.name] = SPDSolver(body.K.tocsr()[:-1, :-1].tocsr()).solve
        load, read = np.zeros(body.n - 1), np.zeros(body.n - 1)
        np.add.at(load, row[key][0], row[key][1])
        np.add.at(read, row[key + "_read"][0], row[key + "_read"][1])
        u = np.asarray(solvers[body.name](force * load)).ravel()
        out[f"fe_{name}"], out[f"surface_{name}"] = float(read @ u), float(load @ u)
    out["local"] = float(roller.law([row]).approach(np.array([force]))[0])
    out["total"] = out["fe_pinion"] + out["fe_face"] + out["local"]
    return out


# -- the local law of a pair: its approach as a function of its force -----------------------------
#: Depth of the FE reading below the contact point, in flank element sizes (the default).
PROBE_ELEMENTS = 2.0
#: ... at most this fraction of the tooth's thickness along the normal there (the two
#: flanks' distance; sampled every :data:`CHORD_STEP` along the path, interpolated).
CHORD_FRACTION = 0.5
CHORD_STEP = 0.25e-3
#: The tabulated layer compression: ``zeta = depth / a`` from ... to (log-spaced) ...
_ZETA = np.geomspace(1e-2, 1e5, 36)
#: ... at this many ellipse shapes ``b / a`` spanning the path's (log-spaced).
_KAPPAS = 4
_GAUSS_T, _GAUSS_W = np.polynomial.legendre.leggauss(24)


class HertzLaw:
    """``delta = (P / K_H)^(2/3)``: the two flanks' Hertz approach (Johnson 1985, s. 4.2),
    per pair (vectorised over the pairs of a step).

    Parameters
    ----------
    kh : ndarray (n,)
        ``K_H`` [N/m^1.5].
    """

    def __init__(self, kh: np.ndarray) -> None:
        self.kh = np.asarray(kh, float)
        self.c = self.kh ** (-2.0 / 3.0)

    def take(self, idx) -> HertzLaw:
        return HertzLaw(self.kh[idx])

    def approach(self, lam: np.ndarray) -> np.ndarray:
        """Local approach [m] at the forces ``lam`` [N]."""
        return self.c * np.cbrt(lam) ** 2

    def slope(self, lam: np.ndarray) -> np.ndarray:
        """``d delta / d lam`` [m/N] (infinite at 0: clamped)."""
        return (2.0 / 3.0) * self.c / np.maximum(np.cbrt(lam), 1e-100)

    def energy(self, lam: np.ndarray) -> np.ndarray:
        """Stored energy ``int lam d delta`` [J]."""
        return 0.4 * lam * self.approach(lam)


@functools.lru_cache(maxsize=32)
def layer_table(kappa: float, poisson: float) -> np.ndarray:
    """``H(zeta) = C E / (p0 b)`` on :data:`_ZETA`: the compression ``C`` of the layer
    ``0..z`` of one half-space below the centre of a Hertz ellipse of semi-axes ``a``,
    ``b = kappa a`` and peak pressure ``p0``, at ``zeta = z / a``
    (:func:`~fe_impact.physics.hertz.ellipse_layer_compression` at ``a = 1 m``,
    ``E = 1 Pa``, ``p0 = 1 Pa``: the compression scales as ``p0 a / E``)."""
    from fe_impact.physics.hertz import ellipse_layer_compression

    return np.array([ellipse_layer_compression(z, 1.0, kappa, 1.0, 1.0, poisson)
                     for z in _ZETA]) / kappa


class LayerLaw:
    """Local approach of a pair read at depth ``d`` in both bodies: the two half-spaces'
    compression of the layer ``0..d`` under the Hertz pressure of the pair's force.

    With the Hertz ellipse of 1 N (``a1``, ``b1 = kappa a1``, ``p01``) the ellipse
    of ``P`` is ``a = a1 t``, ``b = b1 t``, ``p0 = p01 t`` (``t = P^(1/3)``), and
    the compression of two like bodies is ``2 p0 b H(d / a) / E = k t^2
    H(zeta_d / t)`` with ``k = 2 p01 b1 / E``, ``zeta_d = d / a1``
    (:func:`layer_table`). ``H`` is tabulated at :data:`_KAPPAS` shapes spanning
    the path's and interpolated linearly in ``ln kappa`` between them,
    monotone-cubically in ``ln zeta``. As ``d -> infinity`` it is the Hertz
    approach; it rises monotonically with ``P``.

    Parameters
    ----------
    k, zeta_d, kappa : ndarray (n,)
        Per pair.
    tables : tuple
        ``(ln kappa nodes, H splines, dH/dln zeta splines)`` of :meth:`tabulate`.
    """

    def __init__(self, k: np.ndarray, zeta_d: np.ndarray, kappa: np.ndarray, tables) -> None:
        self.k, self.zeta_d = np.asarray(k, float), np.asarray(zeta_d, float)
        self.kappa, self.tables = np.asarray(kappa, float), tables
        nodes = tables[0]
        lk = np.log(self.kappa)
        self._j = np.clip(np.searchsorted(nodes, lk) - 1, 0, max(len(nodes) - 2, 0))
        if len(nodes) > 1:
            self._w = np.clip((lk - nodes[self._j]) / (nodes[self._j + 1] - nodes[self._j]),
                              0.0, 1.0)
        else:
            self._w = np.zeros_like(lk)

    @classmethod
    def tabulate(cls, kappa_range: tuple[float, float], poisson: float) -> tuple:
        """The tables of :class:`LayerLaw` for ``b/a`` in ``kappa_range``."""
        from scipy.interpolate import PchipInterpolator

        lo, hi = kappa_range
        kappas = np.geomspace(lo, hi, _KAPPAS) if hi > lo * (1 + 1e-6) else np.array([lo])
        splines = [PchipInterpolator(np.log(_ZETA), layer_table(round(float(k), 9), poisson))
                   for k in kappas]
        return np.log(kappas), splines, [s.derivative() for s in splines]

    def take(self, idx) -> LayerLaw:
        return LayerLaw(self.k[idx], self.zeta_d[idx], self.kappa[idx], self.tables)

    def _g(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``kappa H`` and its ``d/dln zeta`` at ``zeta = zeta_d / t`` (clamped to the
        table: beyond it ``H`` is flat to 1e-4)."""
        lz = np.log(np.clip(self.zeta_d / np.maximum(t, 1e-300), _ZETA[0], _ZETA[-1]))
        _, hs, ds = self.tables
        h = np.array([s(lz) for s in hs]).reshape(len(hs), -1)
        d = np.array([s(lz) for s in ds]).reshape(len(hs), -1)
        cols = np.arange(h.shape[1])
        j1 = np.minimum(self._j + 1, len(hs) - 1)
        w = self._w
        return ((1 - w) * h[self._j, cols] + w * h[j1, cols],
                (1 - w) * d[self._j, cols] + w * d[j1, cols])

    def approach(self, lam: np.ndarray) -> np.ndarray:
        """Local approach [m] at the forces ``lam`` [N]."""
        t = np.cbrt(np.maximum(lam, 0.0))
        return self.k * t * t * self._g(t)[0]

    def slope(self, lam: np.ndarray) -> np.ndarray:
        """``d delta / d lam`` [m/N]."""
        t = np.maximum(np.cbrt(np.maximum(lam, 0.0)), 1e-100)
        g, gl = self._g(t)
        return self.k / t * ((2.0 / 3.0) * g - gl / 3.0)

    def energy(self, lam: np.ndarray) -> np.ndarray:
        """``lam delta - int_0^lam delta dP`` [J] (24-point Gauss in ``t = P^(1/3)``)."""
        lam = np.atleast_1d(np.maximum(lam, 0.0))
        big_t = np.cbrt(lam)
        out = lam * self.approach(lam)
        for i, (T, k) in enumerate(zip(big_t, self.k, strict=True)):
            if T <= 0.0:
                continue
            t = 0.5 * T * (_GAUSS_T + 1.0)
            g = self.take([i] * len(t))._g(t)[0]
            out[i] -= 0.5 * T * float(_GAUSS_W @ (3.0 * k * t**4 * g))
        return out


def solve_contact(gfree: np.ndarray, D: np.ndarray, law, tol: float = 1e-10,
                  sweeps: int = 50) -> np.ndarray:
    """Forces ``lam >= 0`` with ``h = gfree + D lam + delta(lam) >= 0``, ``lam h = 0``.

    ``delta`` is the pairs' local approach, increasing from 0 (``law``: a
    :class:`HertzLaw`, a :class:`LayerLaw`, or an array of ``K_H``, meaning
    ``delta = (lam / K_H)^(2/3)``). For ``D`` symmetric positive semi-definite
    ``lam`` minimises the strictly convex ``g.lam + lam.D.lam / 2 + sum int_0^lam
    delta``: the solution is unique. Active-set Newton (damped to keep the active
    forces positive), started from a few projected Gauss-Seidel sweeps; a pair
    leaves the set when its force falls to zero, joins it when its gap is
    negative. Accepted when every gap is within ``tol`` of the largest free gap
    (zero on the active pairs, above it elsewhere); else Gauss-Seidel finishes.
    """
    if not hasattr(law, "approach"):
        law = HertzLaw(law)
    n = len(gfree)
    scale = max(float(np.abs(gfree).max(initial=0.0)), 1e-30)
    lam = _gauss_seidel(gfree, D, law, np.zeros(n), 3)

    def residual(lam):
        return gfree + D @ lam + law.approach(lam)

    for _ in range(sweeps):
        active = np.flatnonzero(lam > 0.0)
        if len(active):
            lam[active] = _newton(gfree, D, law, lam, active, tol * scale)
        h = residual(lam)
        on = lam > 0.0
        if (np.all(np.abs(h[on]) <= tol * scale)
                and np.all(h[~on] >= -tol * scale)):
            return lam
        lam = _gauss_seidel(gfree, D, law, lam, 2)
    lam = _gauss_seidel(gfree, D, law, lam, 5000)
    return lam


def _newton(g, D, law, lam, active, tol: float) -> np.ndarray:
    """Damped Newton on the active pairs' ``g + D lam + delta(lam) = 0`` (in ``lam``;
    its Jacobian ``D + diag(delta')`` is positive definite); a force the full step
    would make negative is halved instead; one that falls below 1e-300 is set to
    zero (the pair leaves)."""
    others = np.setdiff1d(np.arange(len(g)), active)
    rest = g[active] + D[np.ix_(active, others)] @ lam[others]
    Da, la = D[np.ix_(active, active)], law.take(active)
    x = lam[active].copy()
    for _ in range(100):
        f = rest + Da @ x + la.approach(x)
        if np.abs(f).max() <= tol:
            break
        J = Da + np.diag(la.slope(x))
        step = np.linalg.solve(J, f)
        new = x - step
        neg = new <= 0.0
        new[neg] = 0.5 * x[neg]
        x = np.where(new < 1e-300, 0.0, new)
        if not np.all(x > 0.0):
            break
    return x


def _gauss_seidel(g, D, law, lam, sweeps: int) -> np.ndarray:
    """Projected Gauss-Seidel sweeps; each scalar problem ``a + D_ii t^3 + delta(t^3) = 0``
    (``t = lam^(1/3)``) is increasing for ``t > 0``: Newton from above, kept in the
    bracket (a step that leaves it bisects)."""
    lam = lam.copy()
    for _ in range(sweeps):
        for i in range(len(g)):
            a = g[i] + D[i] @ lam - D[i, i] * lam[i]
            if a >= 0.0:
                lam[i] = 0.0
                continue
            lam[i] = _scalar_root(a, D[i, i], law.take([i]))
    return lam


def _scalar_root(a: float, d: float, law) -> float:
    """``lam > 0`` with ``a + d lam + delta(lam) = 0`` (``a < 0``, ``d >= 0``)."""
    def f(t):
        x = np.array([t**3])
        return (a + d * t**3 + float(law.approach(x)[0]),
                3.0 * t * t * (d + float(law.slope(x)[0])))

    lo, hi = 0.0, (-a / d) ** (1 / 3) if d > 0.0 else 1.0
    while f(hi)[0] < 0.0:       # d = 0: the approach alone closes the gap
        lo, hi = hi, 2.0 * hi
    t = hi
    for _ in range(200):
        v, dv = f(t)
        if v > 0.0:
            hi = t
        else:
            lo = t
        step = v / dv if dv > 0.0 else math.inf
        new = t - step
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - t) <= 1e-15 * t or hi - lo <= 1e-15 * hi:
            t = new
            break
        t = new
    return t**3
