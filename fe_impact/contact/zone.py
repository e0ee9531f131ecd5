"""Contact pairs and the candidate contact zone shared by the static and dynamic solvers.

Only a small patch of each contact surface can touch. The zone is the set of
slave faces whose gap is below a search distance, with the master faces
opposite them; the solvers condense the stiffness onto the zone's DOFs and
check after each solve whether a face outside it has come into contact.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from fe_impact.contact.surfaces import ContactPair, ContactSurface, project
from fe_impact.fe.case import Case
from fe_impact.fe.elasticity import ElasticModel
from fe_impact.fe.mesh import FEMesh
from fe_impact.physics.hertz import effective_modulus

logger = logging.getLogger(__name__)

#: Auto penalty = PENALTY_FACTOR[multiplier] * E* / h (h: median edge of the
#: contact faces, :func:`contact_face_size`), for static and Newmark analyses.
#: The penetration/approach ratio of a Hertzian patch is p0/(eps delta) =
#: 2 E*/(pi a eps). Measured on the sphere-on-block validation (quadratic
#: faces), with ``a/h`` the contact radius over the contact faces' size:
#:
#: - linear pressure: stable, so the penalty may approach the Lagrange-multiplier
#:   limit. At 1000 the penetration is 0.31% of the approach at a = 1.1 h (1.0%
#:   at 300); going on to 3000 moves the largest nodal pressure by at most
#:   0.3% of p0 at a = 2.2 h and 0.04% at a = 4.5 h.
#: - split pressure: a single node's pressure grows with the penalty (peak
#:   pressure error 2% at 300 and 7% at 1000, a = 2.2 h), so it stays at 300.
#:   3-node faces, where every node carries a pressure whatever the
#:   multiplier, keep 300 as well.
#:
#: These factors were measured with h the median face of the whole surface
#: group, which on the Hertz meshes is 2.83 (coarse), 1.36 (medium) and 1.03
#: (fine) times the contact faces' h: the penalties the studies ran at were
#: 1000 / 1.36 = 735 and 970 in the contact faces' h at the medium and fine
#: levels, which the 300-3000 range above brackets. With the contact faces'
#: h, 1000 is kept: with it and the segment integration together, the static
#: Hertz study's quick levels moved by -0.006 and -0.0005 points of force
#: error (0.351 -> 0.345%, 0.239 -> 0.238%) and the fine level's peak pressure
#: error from 2.43 to 2.26% of p0 (the contact radii unchanged), within the
#: 0.3% of p0 the factor's range allows.
PENALTY_FACTOR = {"linear": 1000.0, "split": 300.0}
#: Explicit integration: the penalty sets the stable time step (the contact
#: nodes' frequency sqrt(eps w / m) grows with sqrt(eps)), so the auto penalty is
#: much softer: penetration about 2 h / (pi a * 30), 0.5% of the approach at a = 4 h.
PENALTY_FACTOR_EXPLICIT = 30.0


def contact_pairs(case: Case, mesh: FEMesh, model: ElasticModel,
                  factor: float | None = None) -> list[ContactPair]:
    """The case's contact pairs with their penalties (``"auto"``: factor E* / h).

    ``factor``: the auto penalty's factor; default :data:`PENALTY_FACTOR` of
    the pair's pressure interpolation.
    """
    pairs = []
    for spec in case.contacts:
        slave = ContactSurface.from_mesh(mesh, spec.slave)
        master = ContactSurface.from_mesh(mesh, spec.master)
        penalty = spec.penalty
        if penalty is None:
            kind = spec.multiplier if slave.nodes_per_face == 6 else "split"
            f = factor if factor is not None else PENALTY_FACTOR[kind]
            penalty = f * pair_modulus(mesh, model, slave, master) / contact_face_size(
                mesh, slave, master)
        pairs.append(ContactPair(slave, master, penalty, spec.multiplier))
        logger.info("contact %s -> %s: penalty %.3g Pa/m", spec.slave, spec.master, penalty)
    return pairs


#: The contact faces of a surface (:func:`contact_faces`): those whose gap to the
#: other surface lies within this many of the first touch's face sizes of the
#: smallest gap. On a sphere of radius R the band reaches sqrt(2 R 0.1 h) from
#: the touch: 0.63 mm, three faces, on the coarse Hertz mesh (h = 0.2 mm, R =
#: 10 mm); on flat or conforming faces it takes in the whole facing patch.
CONTACT_BAND = 0.1


def contact_faces(mesh: FEMesh, surface: ContactSurface, other: ContactSurface) -> np.ndarray:
    """Faces of ``surface`` where the bodies first touch (indices), undeformed.

    Each face's centroid is projected on ``other``; the faces whose gap is
    within :data:`CONTACT_BAND` of the touching face's own size of the
    smallest gap are kept. None opposite ``other``: every face.
    """
    f = surface.faces
    cent = mesh.points[f[:, :3]].mean(axis=1)
    proj = project(cent, other, mesh.points, np.arange(len(other.faces)))
    if not proj.valid.any():
        return np.arange(len(f))
    gap = np.where(proj.valid, proj.gap, np.inf)
    first = int(np.argmin(gap))
    h0 = face_size(mesh, surface, np.max, np.array([first]))
    return np.flatnonzero(gap <= gap[first] + CONTACT_BAND * h0)


def contact_face_size(mesh: FEMesh, slave: ContactSurface, master: ContactSurface) -> float:
    """The auto penalty's element size h (m): the median edge of the contact faces
    (:func:`contact_faces`) of the finer of the two surfaces.

    The median over the whole surface group took in faces far from the
    contact, up to 2.8 times larger on the coarse Hertz mesh.
    """
    return min(face_size(mesh, slave, np.median, contact_faces(mesh, slave, master)),
               face_size(mesh, master, np.median, contact_faces(mesh, master, slave)))


def pair_modulus(mesh: FEMesh, model: ElasticModel, slave: ContactSurface,
                 master: ContactSurface) -> float:
    """E* of the softest materials touching the two surfaces, Pa."""
    props = []
    for s in (slave, master):
        mats = model.material[elements_touching(mesh, s.faces[:, 0])]
        m = min((model.materials[i] for i in np.unique(mats)), key=lambda m: m.youngs_modulus)
        props.append((m.youngs_modulus, m.poisson_ratio))
    return effective_modulus(*props[0], *props[1])


def reference_states(mesh: FEMesh, pairs: list[ContactPair]) -> list:
    """Gap state of every slave node against the whole master, undeformed."""
    zero = np.zeros((mesh.n_points, 3))
    return [p.gap_state(mesh, zero, np.arange(len(p.slave.faces)),
                        np.arange(len(p.master.faces))) for p in pairs]


@dataclass
class ContactZone:
    """Candidate contact faces of each pair (indices into the pair's surfaces)."""

    pairs: list[ContactPair]
    slave_faces: list[np.ndarray]
    master_faces: list[np.ndarray]

    @classmethod
    def initial(cls, mesh: FEMesh, pairs: list[ContactPair], distances: list[float],
                states: list | None = None) -> ContactZone:
        """Slave faces with a node closer than ``distances[k]`` to the master.

        ``states``: the pairs' :func:`reference_states`, if already computed.
        """
        states = states if states is not None else reference_states(mesh, pairs)
        slave_faces, master_faces = [], []
        for pair, dist, st in zip(pairs, distances, states, strict=True):
            all_s = np.arange(len(pair.slave.faces))
            s = max(dist, 1e-3 * face_size(mesh, pair.slave))
            near = all_s[face_min_gap(pair, st, all_s) < s]
            slave_faces.append(near)
            # the slave's nodes sample its faces only at their corners: a master face
            # under the middle of a larger slave face lies up to that face's
            # circumradius from them
            spread = float(_reach(mesh, pair.slave.faces[near]).max(initial=0.0))
            master_faces.append(master_near(mesh, pair, mesh.points[
                np.unique(pair.slave.faces[near])], s + spread))
        return cls(pairs, slave_faces, master_faces)

    def points(self) -> np.ndarray:
        """Mesh points of all zone faces, sorted."""
        nodes = [p.slave.faces[f].ravel() for p, f in zip(self.pairs, self.slave_faces,
                                                          strict=True)]
        nodes += [p.master.faces[f].ravel() for p, f in zip(self.pairs, self.master_faces,
                                                           strict=True)]
        return np.unique(np.concatenate(nodes)) if nodes else np.zeros(0, dtype=np.int64)

    def gap_states(self, mesh: FEMesh, up: np.ndarray) -> list:
        """Gap states of the zone for the nodal displacement ``up`` (n_points, 3)."""
        return [p.gap_state(mesh, up, sf, mf) for p, sf, mf in
                zip(self.pairs, self.slave_faces, self.master_faces, strict=True)]

    def grow(self, mesh: FEMesh, up: np.ndarray, margin: float = 0.0) -> bool:
        """Add faces outside the zone that hold a watched node whose gap is below ``margin``,
        and master faces under zone nodes that slid off the zone's master faces.

        Watched: every slave node whose faces are not all in the zone (those
        on its edge too), with its weighted gap over all its faces. True if
        the zone grew.
        """
        grew = False
        for k, pair in enumerate(self.pairs):
            grew |= self._follow_slide(mesh, pair, k, up, margin)
            outside = np.setdiff1d(np.arange(len(pair.slave.faces)), self.slave_faces[k])
            if len(outside) == 0:
                continue
            # Watch every node the zone does not hold a whole support of (those
            # on its edge too), with its gap over its whole support: the
            # outside faces and the zone's faces that share a node with them
            # (the zone's inside, most of the fine faces, need no projection).
            edge = np.isin(pair.slave.faces[self.slave_faces[k]],
                           pair.slave.faces[outside]).any(axis=1)
            ring = np.union1d(outside, self.slave_faces[k][edge])
            st = pair.gap_state(mesh, up, ring, np.arange(len(pair.master.faces)),
                                jacobian=False)
            watched = ~np.isin(st.nodes, pair.slave.complete_nodes(self.slave_faces[k]))
            close = st.nodes[watched & (st.gap < margin)]
            bad = outside[np.isin(pair.slave.faces[outside], close).any(axis=1)]
            if len(bad):
                logger.info("contact %s: %d faces outside the search zone come close; "
                            "enlarging it", pair.slave.name, len(bad))
                self.slave_faces[k] = np.union1d(self.slave_faces[k], bad)
                pts = np.unique(pair.slave.faces[bad])
                # Master faces within two of the added faces' own size: the
                # surface's largest face (far from the contact) would take in
                # a wide band of small master faces.
                s = max(margin, 0.0) + 2.0 * face_size(mesh, pair.slave, np.max, bad)
                self.master_faces[k] = np.union1d(
                    self.master_faces[k], master_near(mesh, pair, up[pts] + mesh.points[pts], s))
                grew = True
        return grew


    def _follow_slide(self, mesh: FEMesh, pair: ContactPair, k: int, up: np.ndarray,
                      margin: float) -> bool:
        """Add the master faces under zone nodes that slid off the zone's master faces.

        A zone node that no zone master face covers, or that one covers in part
        with a gap below ``margin`` there, lies at the master's own edge
        (where it stays uncovered) or slid toward an edge of the zone's master
        faces that is not the master's (a body moved by a load slides as far
        as the load takes it): such a node within reach of such a cut edge
        takes the master faces near it into the zone. True if the zone grew.
        """
        st = pair.gap_state(mesh, up, self.slave_faces[k], self.master_faces[k],
                            jacobian=False)
        # uncovered, or partly covered and closing on the covered part
        part = ~np.isfinite(st.gap) | ((st.weight < (1.0 - 1e-9) * st.area) &
                                       (st.gap < margin))
        if not part.any():
            return False
        cut = _cut_edges(pair.master.faces, self.master_faces[k])
        if len(cut) == 0:
            return False
        x = mesh.points + up
        ends = x[cut]                                           # (n, 2, 3)
        mid = ends.mean(axis=1)
        half = 0.5 * np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
        faces = self.slave_faces[k]
        touching = faces[np.isin(pair.slave.faces[faces], st.nodes[part]).any(axis=1)]
        h = face_size(mesh, pair.slave, np.max, touching)
        pts = st.nodes[part]
        dist, near = cKDTree(mid).query(x[pts])
        slid = dist <= half[near] + h + max(margin, 0.0)
        if not slid.any():
            return False
        s = max(margin, 0.0) + 2.0 * h
        new = np.union1d(self.master_faces[k], master_near(mesh, pair, x[pts[slid]], s))
        if len(new) == len(self.master_faces[k]):
            return False
        logger.info("contact %s: %d zone nodes slid toward the edge of the zone's master "
                    "faces; %d master faces join it", pair.slave.name, int(slid.sum()),
                    len(new) - len(self.master_faces[k]))
        self.master_faces[k] = new
        return True


def _cut_edges(faces: np.ndarray, subset: np.ndarray) -> np.ndarray:
    """Corner pairs (n, 2) of the edges that bound the face subset but not the surface."""
    def boundary(f: np.ndarray) -> np.ndarray:
        e = np.sort(f[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
        key, count = np.unique(e, axis=0, return_counts=True)
        return key[count == 1]

    sub, whole = boundary(faces[subset]), boundary(faces)
    if len(sub) == 0:
        return sub
    n = int(faces.max()) + 1
    inner = ~np.isin(sub[:, 0] * n + sub[:, 1], whole[:, 0] * n + whole[:, 1])
    return sub[inner]


def master_near(mesh: FEMesh, pair: ContactPair, points: np.ndarray, s: float) -> np.ndarray:
    """Master faces that reach within ``s`` of any of ``points``.

    A face qualifies when the nearest point is closer to its centroid than
    ``s`` plus the face's own circumradius (plus a small slack), so large
    far-field faces do not pull a wide ring of small faces into the zone.
    """
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    faces = pair.master.faces
    dist, _ = cKDTree(points).query(mesh.points[faces[:, :3]].mean(axis=1))
    return np.flatnonzero(dist <= s + 1.5 * _reach(mesh, faces))


def _reach(mesh: FEMesh, faces: np.ndarray) -> np.ndarray:
    """Each face's largest distance from its centroid to a corner."""
    x = mesh.points[faces[:, :3]]
    return np.linalg.norm(x - x.mean(axis=1)[:, None, :], axis=2).max(axis=1)


def face_size(mesh: FEMesh, surface: ContactSurface, stat=np.median,
              faces: np.ndarray | None = None) -> float:
    """Typical edge length of a surface's triangles (vertex to vertex), m.

    ``faces``: indices of the triangles to measure (default: all of them).
    """
    f = surface.faces if faces is None else surface.faces[faces]
    x = mesh.points[f[:, :3]]
    edges = np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2)
    return float(stat(edges))


def face_min_gap(pair: ContactPair, state, faces: np.ndarray) -> np.ndarray:
    """Smallest nodal gap of each face (inf where none is opposite the master).

    Only the nodes with a weighted gap count (the corners of 6-node faces
    with the linear multiplier).
    """
    f = pair.slave.faces[faces]
    if len(state.nodes) == 0:
        return np.full(len(f), np.inf)
    pos = np.minimum(np.searchsorted(state.nodes, f), len(state.nodes) - 1)
    gap = np.where(state.nodes[pos] == f, state.gap[pos], np.inf)
    return gap.min(axis=1)


def elements_touching(mesh: FEMesh, points: np.ndarray) -> np.ndarray:
    """Elements with a vertex among ``points``."""
    return np.flatnonzero(np.isin(mesh.cells[:, :4], points).any(axis=1))
