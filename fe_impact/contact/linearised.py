"""Penalty contact on linearised gaps, for time integration in reduced coordinates.

The gaps of the contact zone's slave nodes are linearised about their last
projection on the master surface, ``g = g_ref + B (z - z_ref)`` with ``z``
the reduced coordinates of :class:`~fe_impact.fe.kinematics.Kinematics`, and
re-projected whenever the zone has moved by more than a tolerance
(:class:`ContactModel`). :func:`zone_frames` gives each zone node a
normal/tangent frame so an implicit step can keep only the normal
coordinates in contact, and :class:`SurfaceMonitor` watches the slave nodes
outside the zone so faces join it before they touch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fe_impact.contact.surfaces import GapState, nodal_pressure
from fe_impact.contact.zone import ContactZone, face_size
from fe_impact.fe.elasticity import ElasticModel
from fe_impact.fe.kinematics import Kinematics, point_dofs
from fe_impact.fe.linalg import SparseProduct
from fe_impact.fe.mesh import FEMesh


class ContactModel:
    """Penalty forces on linearised weighted gaps, re-projected as the bodies move.

    ``laws``: each pair's :class:`~fe_impact.contact.friction.FrictionLaw` (None:
    frictionless). With friction on any pair, each projection also forms the
    rows' tangential frames and slip Jacobians (:attr:`Bt_full`, :attr:`Bt`);
    without, nothing of it is formed.

    ``tolerance`` (m): the zone's deformation that calls for a re-projection;
    ``slip_tolerance`` (m, friction only): the slide of a row's slave point along
    its master face that does (see :meth:`moved`).
    """

    def __init__(self, mesh: FEMesh, model: ElasticModel, kin: Kinematics, zone: ContactZone,
                 tolerance: float, laws: list | None = None,
                 slip_tolerance: float | None = None) -> None:
        self.mesh, self.model, self.kin, self.zone = mesh, model, kin, zone
        self.tolerance = tolerance
        self.slip_tolerance = slip_tolerance
        self.laws = list(laws) if laws is not None and any(
            law is not None for law in laws) else None
        self.n_projections = 0
        self.projector: sp.csr_matrix | None = None
        self.update(np.zeros(kin.n))

    @property
    def friction(self) -> bool:
        """True if a pair has Coulomb friction."""
        return self.laws is not None

    def point_values(self, z: np.ndarray) -> np.ndarray:
        """Nodal (n_points, 3) displacement of the reduced coordinates ``z``."""
        return self.model.point_values(self.kin.T @ z)

    def update(self, z: np.ndarray) -> None:
        """Project the zone's slave nodes on the configuration ``z``."""
        up = self.point_values(z)
        self.states: list[GapState] = self.zone.gap_states(self.mesh, up)
        B = sp.vstack([s.B for s in self.states]).tocsr()
        self.B = (B @ self.kin.T).tocsr()
        self.g_ref = np.concatenate([s.gap for s in self.states])
        self.active_rows = np.isfinite(self.g_ref)
        self.g_ref = np.where(self.active_rows, self.g_ref, 0.0)
        self.B = sp.diags(self.active_rows.astype(float)) @ self.B
        self.B_full = self.B
        if self.projector is not None:
            self.B = (self.B @ self.projector).tocsr()
        self._transpose()
        self.eps_w = np.concatenate([p.penalty * s.weight for p, s in
                                     zip(self.zone.pairs, self.states, strict=True)])
        self.eps_w = np.where(self.active_rows, self.eps_w, 0.0)
        self.sizes = [len(s.gap) for s in self.states]
        self.T_zone = self.kin.T[point_dofs(self.mesh, self.zone.points())]
        self._zone_cols, self._T_zone_held = _held_columns(self.T_zone)
        self.z_ref = z.copy()
        self.n_projections += 1
        if self.laws is not None:
            self._slip_rows(up)

    def _slip_rows(self, up: np.ndarray) -> None:
        """Tangential frames (:attr:`t1`, :attr:`t2`, (r, 3)), slip Jacobians on all DOFs
        (:attr:`Bt_full`, (2 r, n_dofs): the t1 rows, then the t2 rows) and in reduced
        coordinates (:attr:`Bt`), and each row's law (:attr:`row_law`, pair index)."""
        from fe_impact.contact.friction import relative_jacobian, slip_jacobians, tangent_frames

        t1s, t2s, B1, B2, law = [], [], [], [], []
        for k, (pair, sf, mf, st) in enumerate(zip(self.zone.pairs, self.zone.slave_faces,
                                                   self.zone.master_faces, self.states,
                                                   strict=True)):
            t1, t2 = tangent_frames(st.normal)
            J = relative_jacobian(pair, self.mesh, up, sf, mf)
            b1, b2 = slip_jacobians(J, t1, t2)
            t1s.append(t1)
            t2s.append(t2)
            B1.append(b1)
            B2.append(b2)
            law.append(np.full(len(st.gap), k))
        self.t1, self.t2 = np.concatenate(t1s), np.concatenate(t2s)
        mask = sp.diags(self.active_rows.astype(float))
        self.Bt_full = sp.vstack([mask @ sp.vstack(B1), mask @ sp.vstack(B2)]).tocsr()
        self.Bt = (self.Bt_full @ self.kin.T).tocsr()
        self.row_law = np.concatenate(law)
        # B_t and B_t^T on what they reach (_slip_product, add_tangential), formed at
        # their first use in a projection (the static solver makes none)
        self._Bt_held: tuple[np.ndarray, SparseProduct] | None = None
        self._BtT_held: tuple[np.ndarray, SparseProduct] | None = None

    def row_keys(self) -> np.ndarray:
        """A key per row naming its pair and slave node (stable over projections)."""
        n = self.mesh.n_points
        return np.concatenate([st.nodes + k * n for k, st in enumerate(self.states)])

    def add_tangential(self, t: np.ndarray, out: np.ndarray, sign: float = 1.0) -> np.ndarray:
        """``out += sign B_t^T t`` in place, ``t`` the rows' tangential forces (r, 2),
        touching only the coordinates ``B_t`` reaches (as :meth:`add_forces`; the
        explicit step with friction makes it every step)."""
        if self._BtT_held is None:
            BtT = self.Bt.T.tocsr()
            rows = np.flatnonzero(np.diff(BtT.indptr))
            self._BtT_held = rows, SparseProduct(BtT[rows])
        rows, BtT_held = self._BtT_held
        out[rows] += sign * (BtT_held @ np.concatenate([t[:, 0], t[:, 1]]))
        return out

    def slips(self, z: np.ndarray, z_old: np.ndarray) -> np.ndarray:
        """The rows' slip increments ``B_t (z - z_old)`` from ``z_old`` to ``z`` (r, 2), m,
        on the coordinates ``B_t`` reaches only."""
        c, Bt_held = self._slip_product()
        return (Bt_held @ (z[c] - z_old[c])).reshape(2, -1).T

    def row_coefficients(self, speed: np.ndarray | None = None) -> np.ndarray:
        """Each row's Coulomb coefficient at the slip speed ``speed`` (m/s; None: at
        rest, ``mu_static``); 0 on frictionless pairs."""
        mu = np.zeros(len(self.row_law))
        for k, law in enumerate(self.laws):
            on = self.row_law == k
            if law is not None and on.any():
                mu[on] = law.coefficient(0.0 if speed is None else speed[on])
        return mu
    def set_projector(self, projector: sp.csr_matrix | None) -> None:
        """Keep only the normal components of the zone nodes in the gap Jacobian.

        ``projector`` is :func:`zone_frames`' ``n n^T`` per zone node: gaps and
        contact forces then act along each node's surface normal (the
        node-to-surface convention); ``None`` restores the full Jacobian.
        """
        self.projector = projector
        self.B = self.B_full if projector is None else (self.B_full @ projector).tocsr()
        self._transpose()

    def _transpose(self) -> None:
        """``B^T`` (the forces ``B^T lam`` of every step: transposed once), and ``B`` on the
        columns that hold anything, for :meth:`gaps` (products of every step: MKL's
        call costs a third of scipy's here). ``B^T``'s rows that hold anything are
        formed at the first :meth:`add_forces` after a change of ``B`` (the explicit
        step's; the Newmark step takes ``BT``)."""
        self.BT = self.B.T.tocsr()
        self._BT_held: tuple[np.ndarray, SparseProduct] | None = None
        cols, B_held = _held_columns(self.B)
        self._gap_cols, self._B_held = cols, SparseProduct(B_held)

    def add_forces(self, lam: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out += B^T lam`` in place, touching only the coordinates ``B`` reaches
        (on the explicit benchmark 93 rows of 16,440 coordinates: a product with
        the whole ``B^T`` passes over every empty row)."""
        if self._BT_held is None:
            rows = np.flatnonzero(np.diff(self.BT.indptr))
            self._BT_held = rows, SparseProduct(self.BT[rows])
        rows, BT_held = self._BT_held
        out[rows] += BT_held @ lam
        return out

    def moved(self, z: np.ndarray) -> bool:
        """True if the zone deformed by more than :attr:`tolerance` since the projection
        or, with friction and a :attr:`slip_tolerance`, a row's slave point slid along
        its master face by more than that.

        The deformation (the zone nodes' motion less its mean) bounds the error of
        the linearised gaps, as without friction; the slide, that of the slips and
        the tangent frames, which hold while a slave point stays near its master
        point. Friction without a slip tolerance takes the deformation alone.
        """
        c = self._zone_cols
        du = (self._T_zone_held @ (z[c] - self.z_ref[c])).reshape(-1, 3)
        du -= du.mean(axis=0)
        if float(np.abs(du).max(initial=0.0)) > self.tolerance:
            return True
        return self.slip_tolerance is not None and self.laws is not None and \
            self.slide(z) > self.slip_tolerance

    def slide(self, z: np.ndarray) -> float:
        """The largest slide (m) of a row's slave point along its master face from the
        projection to ``z``: the norm of the row's slip ``B_t (z - z_ref)`` (friction)."""
        c, Bt_held = self._slip_product()
        s = (Bt_held @ (z[c] - self.z_ref[c])).reshape(2, -1)
        return float(np.sqrt(s[0] * s[0] + s[1] * s[1]).max(initial=0.0))

    def _slip_product(self) -> tuple[np.ndarray, SparseProduct]:
        """The columns ``B_t`` reaches and ``B_t`` on them."""
        if self._Bt_held is None:
            cols, Bt_held = _held_columns(self.Bt)
            self._Bt_held = cols, SparseProduct(Bt_held)
        return self._Bt_held

    def gaps(self, z: np.ndarray) -> np.ndarray:
        c = self._gap_cols      # B (z - z_ref) on the coordinates B reaches
        return self.g_ref + self._B_held @ (z[c] - self.z_ref[c])

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
    projector: sp.csr_matrix | None     # None: every component kept (friction)
    condensed: np.ndarray


def zone_frames(mesh: FEMesh, kin: Kinematics, contact: ContactModel,
                all_components: bool = False,
                tangential: np.ndarray | None = None) -> ZoneFrames:
    """Frames whose normal is the direction the gaps see each zone node move.

    ``all_components``: condense the tangent slots too (friction: the
    tangential forces act on them), and the projector keeps every component.
    ``tangential``: the nodes (``mesh.point_dof`` numbers) whose tangent slots
    are condensed too and whose every component the projector keeps (friction
    on the rows in contact only: :func:`tangential_nodes`); the other zone nodes
    keep their normal slot alone, as without friction.

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
    full = np.zeros(len(jf), dtype=bool)
    if tangential is not None and not all_components:
        full = np.isin(mesh.point_dof[pts[free]], tangential)
        nn[full] = np.eye(3)
    P = sp.csr_matrix((np.concatenate([nn.ravel(), one]), (rr, cc)), shape=(kin.n, kin.n))
    # Unrotated nodes keep every coordinate they move with: their free
    # components and, if tied, their rigid body's.
    other = contact.T_zone[(3 * np.flatnonzero(~free)[:, None] + np.arange(3)).ravel()]
    if all_components:
        condensed = np.unique(np.concatenate([jf.ravel(), other.indices]))
        return ZoneFrames(R, None, condensed)
    condensed = np.unique(np.concatenate([jf[:, 0], jf[full, 1:].ravel(), other.indices]))
    return ZoneFrames(R, P, condensed)


def tangential_nodes(mesh: FEMesh, contact: ContactModel, rows: np.ndarray) -> np.ndarray:
    """The nodes (``mesh.point_dof`` numbers) the slip rows ``rows`` of ``contact``
    reach: the slave node's face neighbours and the master points' face nodes."""
    Bt = contact.Bt_full
    r = len(contact.active_rows)
    cols = np.unique(sp.vstack([Bt[rows], Bt[r + np.asarray(rows)]]).tocsr().indices)
    return np.unique(cols // 3)



def patch_growth(mesh: FEMesh, contact: ContactModel, forced: np.ndarray, h: np.ndarray,
                 held: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows whose tangent coordinates join the condensed ones, and the nodes that
    adds beyond ``held`` (empty: nothing to grow).

    The rows with a force (``forced``) and, as a margin, the rows whose contact-free
    gap ``h`` is below twice the deepest penetration or a tenth of the spread of the
    projection's gaps, so that the patch grows a few times, not row by row."""
    ok = contact.active_rows
    g = contact.g_ref[ok]
    spread = float(g.max() - g.min()) if len(g) else 0.0
    margin = max(-2.0 * float(np.min(h)), 0.1 * spread)
    rows = np.flatnonzero(forced | (ok & (h < margin)))
    return rows, np.setdiff1d(tangential_nodes(mesh, contact, rows), held)

#: The share of a pair's search distance beyond its first touch within which the rows'
#: tangent coordinates are condensed from the start (:func:`predicted_patch`). A
#: Hertzian patch's edge lies where the undeformed gap exceeds the first touch's by
#: half the approach; the search distances are set beyond the largest approach (a
#: tooth impact's 1.2 Hertz approaches, 1.25 times the largest prescribed displacement,
#: the largest load's edge and half again under a load), so 0.6 of them takes in the
#: patch of the largest contact with the growth's margin, mostly without a growth.
PREDICTED_PATCH_FRACTION = 0.6
#: The same share for a transient impact's rows (the dynamic solver's start). Each
#: growth condenses a margin of a tenth of the projection's gap spread
#: (:func:`patch_growth`), so a prediction just short of the patch costs more than
#: one a little beyond it. On the stage-1 100 r/min flank impact with the seed's
#: friction (one core), the default level's condensation held 13,905 coordinates
#: after one growth from 0.6 (108 s of CPU), 9,761 with none from 0.7 (55 s),
#: 10,993 from 0.8 (68 s); the coarse level's none from each: 4,300 (11 s), 4,802
#: (12 s), 5,336 (13 s). The peak force the same to 1e-11.
IMPACT_PATCH_FRACTION = 0.7


def predicted_patch(mesh: FEMesh, contact: ContactModel, reach: list[float | None],
                    fraction: float | None = None) -> np.ndarray:
    """The nodes (``mesh.point_dof`` numbers) whose tangent coordinates are condensed
    before any contact: those the rows reach whose gap in the projection lies within
    ``fraction`` (default :data:`PREDICTED_PATCH_FRACTION`) of each pair's search
    distance ``reach`` (m) beyond its smallest gap (None: no row of that pair).

    Only a start: a row with a force that reaches a node left out grows the patch
    (:func:`patch_growth`), so the solution does not depend on it, only the number
    of factorisations (each growth makes one) and the size of the dense block.
    """
    if fraction is None:
        fraction = PREDICTED_PATCH_FRACTION
    rows, start = [], 0
    for st, s in zip(contact.states, reach, strict=True):
        n = len(st.gap)
        ok = contact.active_rows[start:start + n]
        g = contact.g_ref[start:start + n]
        if s is not None and ok.any() and fraction > 0.0:
            g_min = float(g[ok].min())
            rows.append(start + np.flatnonzero(ok & (g <= g_min + fraction * max(
                s - g_min, 0.0))))
        start += n
    rows = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    if len(rows) == 0:
        return np.zeros(0, dtype=np.int64)
    return tangential_nodes(mesh, contact, rows)


def flight_patch(mesh: FEMesh, contact: ContactModel, rate: np.ndarray, dt: float
                 ) -> np.ndarray:
    """The nodes whose tangent coordinates :func:`patch_growth` would condense at the
    first touch of a rigid flight, before any contact: ``rate`` (m/s) is each row's
    gap rate in the flight, ``dt`` (s) the step. The gaps one step past the first
    touch stand for the contact-free gaps of that step's solve (a rigid motion is its
    own contact-free solution)."""
    ok = contact.active_rows & (rate < 0.0)
    if not ok.any():
        return np.zeros(0, dtype=np.int64)
    t = float(np.min(contact.g_ref[ok] / -rate[ok])) + dt
    h = np.where(contact.active_rows, contact.g_ref + t * np.minimum(rate, 0.0), np.inf)
    rows, nodes = patch_growth(mesh, contact, h < 0.0, h, np.zeros(0, dtype=np.int64))
    return nodes


def _held_columns(A: sp.csr_matrix) -> tuple[np.ndarray, sp.csr_matrix]:
    """The columns of ``A`` that hold anything, and ``A`` on them alone: ``A x`` is then
    ``A_held x[columns]`` with the same sums in the same order, without a pass
    over the whole of ``x`` (a step's gaps and zone motion reach a few hundred
    of the model's coordinates)."""
    cols = np.unique(A.indices)
    return cols, A[:, cols].tocsr()


#: The zone's watch margin: this fraction of its reach beyond the first contact
#: (:class:`SurfaceMonitor`).
MARGIN_FRACTION = 0.15


class SurfaceMonitor:
    """Linearised gaps of every slave node, to see faces outside the zone coming close.

    The zone grows when the smallest gap outside it, extrapolated to the next
    check (every step) at the rate it closed since the last one, falls below
    :attr:`margin` (:data:`MARGIN_FRACTION` of the zone's reach beyond the
    first contact, at most a quarter of a face): a face joins before it can
    touch, and a zone that merely has neighbours a few microns away is left
    alone. A tooth impact's zone reaches 1.2 Hertz approaches beyond the first
    contact (:data:`~fe_impact.calibration.sweep.ZONE_REACH`) and a Newmark
    step closes a gap by at most the impact speed times t_c / 60, about 0.05
    Hertz approaches: the margin (0.18 of them) is three steps of that at the
    impact speed, and a face joins at least 0.13 of them before it could touch.
    With a quarter of the reach and the check after next, four of the nine
    default impacts grew their zone though the faces outside never came closer
    than 0.37 Hertz approaches (stage 3 at 300 r/min: the same impact to the
    reported digits without the growth, its 100 steps 21 s instead of 44 s).
    """

    def __init__(self, mesh: FEMesh, kin: Kinematics, zone: ContactZone,
                 reach: list[float], states: list) -> None:
        self.mesh, self.zone = mesh, zone
        self.pairs = []
        margins = []
        for s, st in zip(reach, states, strict=True):
            ok = np.isfinite(st.gap)
            self.pairs.append((st.nodes[ok], st.gap[ok], (st.B[ok] @ kin.T).tocsr()))
            margins.append(MARGIN_FRACTION * max(s - float(np.min(st.gap[ok])), 0.0))
        self.margin = min(min(margins), 0.25 * min(face_size(mesh, p.slave)
                                                   for p in zone.pairs))
        self._outside_cache: dict[int, tuple[int, np.ndarray, sp.csr_matrix]] = {}
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
        for k in range(len(self.pairs)):
            g0, B = self._outside(k)
            if len(g0):
                g_min = min(g_min, float((g0 + B @ z).min()))
        return g_min

    def _outside(self, k: int) -> tuple[np.ndarray, sp.csr_matrix]:
        """Reference gaps and gap rows of pair ``k``'s watched nodes that the zone does not
        hold: those not all of whose faces are in it (cached: zones only grow)."""
        faces = self.zone.slave_faces[k]
        cached = self._outside_cache.get(k)
        if cached is None or cached[0] != len(faces):
            nodes, g0, B = self.pairs[k]
            out = ~np.isin(nodes, self.zone.pairs[k].slave.complete_nodes(faces))
            cached = (len(faces), g0[out], B[out])
            self._outside_cache[k] = cached
        return cached[1], cached[2]

    def close_outside(self, z: np.ndarray) -> bool:
        g = self.outside_gap(z)
        if not math.isfinite(g):
            return False
        self.closest = min(self.closest, g)
        self.closing = max(self._last - g, 0.0) if self._last is not None else 0.0
        self._last = g
        return g - self.closing < self.margin

    def grow_margin(self) -> float:
        """Gap below which faces outside join the zone once it has to grow (m)."""
        self._last = None   # the faces outside change
        return 2.0 * (self.margin + 2.0 * self.closing)

