"""Frictionless penalty contact between two deformable bodies.

The gap is evaluated at the quadrature points of the slave surface (a
Gauss-point-to-segment formulation), so P1 and P2 faces are treated alike.
Each slave point of the *deformed* slave surface is projected on the
*deformed* master surface (closest point, Gauss-Newton on the isoparametric
triangle); the gap is ``g = n . (x_s - x_m)`` with ``n`` the outward master
normal there, negative when the bodies overlap.

The gaps are then tested with one function per slave node (a mortar-type
weighted gap, :class:`GapState`), and the penalty acts on those weighted gaps.
The test functions are the pressure's interpolation:

- 3-node faces: the linear shape functions.
- 6-node faces, ``multiplier = "linear"`` (default): the linear hat functions
  of the face's three corners, so only corner nodes carry a pressure, which
  is linear over each face (a P2-P1 pairing, like the Taylor-Hood element:
  the pressure space is coarser than the displacement trace, which keeps the
  pressure stable; Popp, Wohlmuth, Gee and Wall 2012 use it for quadratic
  mortar contact). Mid-side nodes get the mean of their corners for output.
- 6-node faces, ``multiplier = "split"``: the hat functions of the face's four
  linear sub-triangles (segment weights as in Puso, Laursen and Solberg 2008),
  so every node carries a pressure. Its resolution is twice as fine, but the
  pressure space is as large as the displacement trace; at the auto penalty
  a single node can carry a pressure 4-5% above its neighbours on a
  distorted triangle, at every mesh size (measured on the Hertz validation).

Linearisation (used as the Newton direction of the contact iteration):
``dg = n . (du_s - sum_b N_b(xi_m) du_b)`` with the variation of ``n`` and of
the projection dropped, which vanishes at the converged gap for these smooth
small-slip contacts (Wriggers, Computational Contact Mechanics, ch. 4).
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.spatial import cKDTree

from fe_impact.errors import MeshError
from fe_impact.fe.case import MULTIPLIERS
from fe_impact.fe.mesh import FEMesh

logger = logging.getLogger(__name__)

# Node order of a 6-node triangle (meshio/VTK): vertices 0,1,2, mid-sides 01, 12, 20.
_FLIP = {3: [0, 2, 1], 6: [0, 2, 1, 5, 4, 3]}
_INSIDE_TOL = 1e-6


def tri_shape(xi: np.ndarray, eta: np.ndarray, nn: int) -> tuple[np.ndarray, np.ndarray]:
    """Shape functions of 3- or 6-node triangles and their derivatives.

    Returns ``N`` with shape (..., nn) and ``dN`` with shape (..., nn, 2).
    """
    L0, L1, L2 = 1.0 - xi - eta, xi, eta
    one = np.ones_like(xi)
    if nn == 3:
        N = np.stack([L0, L1, L2], axis=-1)
        d = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
        dN = np.broadcast_to(d, N.shape + (2,)).copy() * one[..., None, None]
        return N, dN
    N = np.stack([L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1),
                  4 * L0 * L1, 4 * L1 * L2, 4 * L2 * L0], axis=-1)
    dxi = np.stack([-(4 * L0 - 1), 4 * L1 - 1, 0 * one,
                    4 * (L0 - L1), 4 * L2, -4 * L2], axis=-1)
    deta = np.stack([-(4 * L0 - 1), 0 * one, 4 * L2 - 1,
                     -4 * L1, 4 * L1, 4 * (L0 - L2)], axis=-1)
    return N, np.stack([dxi, deta], axis=-1)


@dataclass(frozen=True, eq=False)
class ContactSurface:
    """A surface group with faces oriented outward from its body.

    Attributes
    ----------
    name : str
    faces : ndarray, shape (n_faces, 3 or 6)
        Point indices; ``(x1 - x0) x (x2 - x0)`` points out of the body.
    """

    name: str
    faces: np.ndarray

    @classmethod
    def from_mesh(cls, mesh: FEMesh, name: str) -> ContactSurface:
        faces = mesh.surface(name)
        return cls(name, orient_outward(mesh, faces, name))

    @property
    def nodes_per_face(self) -> int:
        return self.faces.shape[1]

    def complete_nodes(self, faces: np.ndarray) -> np.ndarray:
        """Nodes (sorted) all of whose faces are among ``faces`` (face indices).

        A node's weighted gap integrates over all its faces; at the edge of a
        subset its support would be cut and its gap and area wrong.
        """
        all_nodes, count = self._valence
        sub, sub_count = np.unique(self.faces[faces], return_counts=True)
        pos = np.searchsorted(all_nodes, sub)
        return sub[sub_count == count[pos]]

    @functools.cached_property
    def _valence(self) -> tuple[np.ndarray, np.ndarray]:
        """The surface's nodes (sorted) and the number of faces holding each."""
        return np.unique(self.faces, return_counts=True)

    def geometry(self, x: np.ndarray, xi: np.ndarray, eta: np.ndarray,
                 faces: np.ndarray | None = None):
        """Points, tangents of faces at (xi, eta); broadcasting over faces.

        ``x`` is the (n_points, 3) nodal position array (reference or deformed).
        """
        f = self.faces if faces is None else faces
        N, dN = tri_shape(xi, eta, self.nodes_per_face)
        X = x[f]  # (nf, nn, 3)
        pos = np.einsum("...a,...ai->...i", N, X)
        t1 = np.einsum("...a,...ai->...i", dN[..., 0], X)
        t2 = np.einsum("...a,...ai->...i", dN[..., 1], X)
        return pos, t1, t2, N


def orient_outward(mesh: FEMesh, faces: np.ndarray, name: str) -> np.ndarray:
    """Reorder each triangle so that its normal points away from its tetrahedron."""
    n = mesh.n_points
    if n >= 2_000_000:
        raise MeshError("meshes above 2 million points are not supported by face matching")
    tets = mesh.cells[:, :4]
    local = np.array([[0, 1, 2, 3], [0, 1, 3, 2], [0, 2, 3, 1], [1, 2, 3, 0]])
    tf = tets[:, local]  # (ne, 4 faces, 3 face vertices + opposite)
    keys_t = _face_keys(np.sort(tf[..., :3], axis=-1).reshape(-1, 3), n)
    opp = tf[..., 3].reshape(-1)
    keys_s = _face_keys(np.sort(faces[:, :3], axis=1), n)
    order = np.argsort(keys_t)
    pos = np.searchsorted(keys_t[order], keys_s)
    pos = np.minimum(pos, len(order) - 1)
    found = keys_t[order][pos] == keys_s
    if not found.all():
        raise MeshError(f"surface group '{name}' has {np.count_nonzero(~found)} triangles "
                        "that are not faces of any tetrahedron")
    x = mesh.points
    x0, x1, x2 = (x[faces[:, k]] for k in range(3))
    normal = np.cross(x1 - x0, x2 - x0)
    inward = np.einsum("ij,ij->i", normal, x[opp[order][pos]] - x0) > 0
    out = faces.copy()
    out[inward] = faces[inward][:, _FLIP[faces.shape[1]]]
    return out


def _face_keys(sorted_tri: np.ndarray, n: int) -> np.ndarray:
    s = sorted_tri.astype(np.int64)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]


@dataclass(frozen=True, eq=False)
class SlavePoints:
    """Quadrature points of (a subset of) slave faces and their nodal test weights."""

    faces: np.ndarray     # (nf,) indices into the slave surface's faces
    xi: np.ndarray        # (nq,) reference coordinates per face
    eta: np.ndarray
    weight: np.ndarray    # (nf, nq) area weights on the reference configuration, m^2
    phi: np.ndarray       # (nq, nn) piecewise-linear test function of each face node


# A 6-node face is integrated on its four linear sub-triangles (corners in
# reference coordinates, as node indices of the face): the gap is smooth on
# each, and with the "split" multiplier they carry the test functions.
_SUB_TRIANGLES = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])
_REF_NODES = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], dtype=float)


def slave_points(surface: ContactSurface, x_ref: np.ndarray, faces: np.ndarray,
                 multiplier: str = "linear") -> SlavePoints:
    """Quadrature points, area weights and nodal test functions on slave faces.

    3-node faces: a degree-4 rule (6 points) with the P1 shape functions as
    test functions. 6-node faces: the same rule on each of the four linear
    sub-triangles, with as test functions the corner hat functions of the
    face (``multiplier="linear"``; the mid-side columns are zero) or the
    sub-triangle's own hat functions (``"split"``).
    """
    from skfem.quadrature import get_quadrature
    from skfem.refdom import RefTri

    if multiplier not in MULTIPLIERS:
        raise ValueError(f"multiplier {multiplier!r}: expected one of {MULTIPLIERS}")
    X, W = get_quadrature(RefTri, 4)
    nn = surface.nodes_per_face
    if nn == 3:
        xi, eta, w = X[0], X[1], W
        phi, _ = tri_shape(xi, eta, 3)
    else:
        xi_l, eta_l, w_l, phi_l = [], [], [], []
        lin, _ = tri_shape(X[0], X[1], 3)  # (nq, 3) hat functions of a sub-triangle
        for sub in _SUB_TRIANGLES:
            ref = lin @ _REF_NODES[sub]        # (nq, 2) points in the face's coordinates
            xi_l.append(ref[:, 0])
            eta_l.append(ref[:, 1])
            w_l.append(W / 4.0)
            p = np.zeros((len(W), 6))
            if multiplier == "linear":
                p[:, :3] = tri_shape(ref[:, 0], ref[:, 1], 3)[0]
            else:
                p[:, sub] = lin
            phi_l.append(p)
        xi, eta, w = np.concatenate(xi_l), np.concatenate(eta_l), np.concatenate(w_l)
        phi = np.concatenate(phi_l)
    _, t1, t2, _ = surface.geometry(x_ref, xi[None, :], eta[None, :],
                                    surface.faces[faces][:, None, :])
    jac = np.linalg.norm(np.cross(t1, t2), axis=-1)  # (nf, nq)
    return SlavePoints(np.asarray(faces), xi, eta, w[None, :] * jac, phi)


# -- mortar segments -------------------------------------------------------------
#: The slave faces' reference triangles that the segments are clipped to (in the
#: face's reference coordinates): the face itself (3 nodes), or its four linear
#: sub-triangles (6 nodes), on each of which the test functions are smooth.
_WHOLE = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
_SUBS = _REF_NODES[_SUB_TRIANGLES]


@njit(cache=True)
def _clip_edge(poly, n, ax, ay, bx, by, out):
    """Sutherland-Hodgman: the part of polygon ``poly[:n]`` left of the line a -> b."""
    m = 0
    for k in range(n):
        px, py = poly[k, 0], poly[k, 1]
        qx, qy = poly[(k + 1) % n, 0], poly[(k + 1) % n, 1]
        sp_ = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        sq = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
        if sp_ >= 0.0:
            out[m, 0], out[m, 1] = px, py
            m += 1
        if (sp_ >= 0.0) != (sq >= 0.0):
            t = sp_ / (sp_ - sq)
            out[m, 0], out[m, 1] = px + t * (qx - px), py + t * (qy - py)
            m += 1
    return m


@njit(cache=True)
def _segment_kernel(tri, subs, qx, qw, min_area):
    """Quadrature points on the overlaps of master triangles with slave sub-triangles.

    ``tri``: (np, 3, 2) each candidate pair's master corners in the slave face's
    reference coordinates; ``subs``: (ns, 3, 2) the slave reference triangles
    to clip to (counter-clockwise); ``qx`` (nq, 2), ``qw`` (nq,) a rule on the
    unit triangle. Each overlap polygon is cut into a fan of triangles, each
    carrying the rule. Returns per point the pair, the sub-triangle, ``xi``,
    ``eta`` and the weight in reference coordinates.
    """
    npair, ns, nq = tri.shape[0], subs.shape[0], qx.shape[0]
    cap = npair * ns * 7 * nq
    pair_o = np.empty(cap, dtype=np.int64)
    sub_o = np.empty(cap, dtype=np.int64)
    xi_o = np.empty(cap)
    eta_o = np.empty(cap)
    w_o = np.empty(cap)
    a = np.empty((12, 2))
    b = np.empty((12, 2))
    m = 0
    for p in range(npair):
        t = tri[p]
        area2 = ((t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1])
                 - (t[2, 0] - t[0, 0]) * (t[1, 1] - t[0, 1]))
        for s in range(ns):
            # the master triangle, counter-clockwise in the slave's coordinates
            for k in range(3):
                kk = k if area2 >= 0.0 else 2 - k
                a[k, 0], a[k, 1] = t[kk, 0], t[kk, 1]
            n = 3
            for e in range(3):
                c0, c1 = subs[s, e], subs[s, (e + 1) % 3]
                n = _clip_edge(a, n, c0[0], c0[1], c1[0], c1[1], b)
                for k in range(n):
                    a[k, 0], a[k, 1] = b[k, 0], b[k, 1]
                if n < 3:
                    break
            if n < 3:
                continue
            for k in range(1, n - 1):
                e1x, e1y = a[k, 0] - a[0, 0], a[k, 1] - a[0, 1]
                e2x, e2y = a[k + 1, 0] - a[0, 0], a[k + 1, 1] - a[0, 1]
                det = e1x * e2y - e2x * e1y
                if det <= min_area:
                    continue
                for q in range(nq):
                    pair_o[m], sub_o[m] = p, s
                    xi_o[m] = a[0, 0] + qx[q, 0] * e1x + qx[q, 1] * e2x
                    eta_o[m] = a[0, 1] + qx[q, 0] * e1y + qx[q, 1] * e2y
                    w_o[m] = qw[q] * det
                    m += 1
    return pair_o[:m], sub_o[:m], xi_o[:m], eta_o[:m], w_o[:m]


@dataclass(frozen=True, eq=False)
class Segments:
    """Quadrature points of slave faces split at the master's edges (mortar segments).

    ``face``: index into the face subset; ``master``: the master face whose
    overlap holds the point (-1: a face no master face covers, which keeps
    the plain rule of :func:`slave_points`); ``phi``: the nodal test functions.
    """

    face: np.ndarray     # (n,)
    master: np.ndarray   # (n,) master face index, -1 for the plain rule
    xi: np.ndarray
    eta: np.ndarray
    weight: np.ndarray   # (n,) area weights on the reference configuration, m^2
    phi: np.ndarray      # (n, nn)


def overlap_candidates(anchor: np.ndarray, r_s: np.ndarray, centre: np.ndarray,
                       r_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` of slave faces and master faces that may overlap.

    A slave face's footprint on the master lies within ``2 r_s`` of ``anchor``
    (its projected points' mean; ``r_s`` the face's circumradius about its
    centroid), and master face ``j`` within ``r_m[j]`` of ``centre[j]``; so an
    overlap needs ``|centre_j - anchor_i| <= 2 r_s_i + r_m_j``, and the pairs
    within ``2 (r_s_i + r_m_j)`` are kept. The master faces are searched by
    size class (radii within a factor 2), so that a few large faces far from
    the contact do not widen the search around every small slave face: under
    one radius for all, a tip-edge rounding meshed 7 um across drew thousands
    of candidates per slave face from the contact's fine master faces.
    """
    if len(anchor) == 0 or len(centre) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    size_class = np.floor(np.log2(r_m / r_m.min())).astype(np.int64)
    pis, pjs = [], []
    for c in np.unique(size_class):
        members = np.flatnonzero(size_class == c)
        near = cKDTree(centre[members]).query_ball_point(
            anchor, 2.0 * (r_s + r_m[members].max()))
        counts = np.array([len(n) for n in near], dtype=np.int64)
        if counts.sum() == 0:
            continue
        pi = np.repeat(np.arange(len(anchor)), counts)
        pj = members[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])]
        keep = np.linalg.norm(centre[pj] - anchor[pi], axis=1) <= 2.0 * (r_s[pi] + r_m[pj])
        pis.append(pi[keep])
        pjs.append(pj[keep])
    if not pis:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    pi, pj = np.concatenate(pis), np.concatenate(pjs)
    order = np.lexsort((pj, pi))
    return pi[order], pj[order]


def mortar_segments(slave: ContactSurface, master: ContactSurface, x_ref: np.ndarray,
                    x: np.ndarray, slave_faces: np.ndarray, master_faces: np.ndarray,
                    multiplier: str = "linear") -> Segments:
    """Slave quadrature split at the master's edges, in the configuration ``x``.

    The gap and the master's shape functions are smooth only within one
    master face, so a rule spread over a slave face that several master
    faces cover integrates them inexactly: the master's nodal forces are
    wrong, and a uniform pressure between non-matching meshes comes out
    uneven (+-3% on a coarse slave over a fine master). Here each slave face
    (or, on 6-node faces, each of its linear sub-triangles) is cut into its
    overlaps with the master faces: the master's corners are projected
    along the slave face's normal into its reference coordinates, each
    overlap polygon is clipped (Sutherland-Hodgman), cut into triangles and
    given the rule of :data:`SEGMENT_RULE_DEGREE` (Puso and Laursen 2004, segment integration;
    Popp, Gee and Wall 2009). On flat faces the split is exact; on curved
    6-node faces the edges are the master's chords projected on the slave
    face's corner plane.

    The candidate master faces of a slave face are those within reach of
    where its plain quadrature points project (:func:`project`): any gap
    is covered. A face no master face overlaps keeps the plain rule (its
    points then project outside the master, as before).
    """
    plain = slave_points(slave, x_ref, slave_faces, multiplier)
    nf, nq = plain.weight.shape
    f = slave.faces[slave_faces]
    X = x[f[:, :3]]                                   # (nf, 3, 3) slave corners, current
    e1, e2 = X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    ns = np.cross(e1, e2)
    pts = slave.geometry(x, plain.xi[None, :], plain.eta[None, :], f[:, None, :])[0]
    proj = project(pts.reshape(-1, 3), master, x, master_faces)
    valid = proj.valid.reshape(nf, nq)
    hit = valid.any(axis=1)
    anchor = np.where(hit[:, None], (proj.point.reshape(nf, nq, 3) * valid[..., None]).sum(1)
                      / np.maximum(valid.sum(1), 1)[:, None], 0.0)
    mf = master.faces[master_faces]
    cm = x[mf[:, :3]].mean(axis=1)
    r_m = np.linalg.norm(x[mf[:, :3]] - cm[:, None, :], axis=2).max(axis=1)
    r_s = np.linalg.norm(X - X.mean(axis=1)[:, None, :], axis=2).max(axis=1)
    rows = np.flatnonzero(hit)
    pi, pj = overlap_candidates(anchor[rows], r_s[rows], cm, r_m)
    pi = rows[pi]
    # facing faces only: the master's normal against the slave's
    Xm = x[mf[pj, :3]]
    nm = np.cross(Xm[:, 1] - Xm[:, 0], Xm[:, 2] - Xm[:, 0])
    facing = np.einsum("ij,ij->i", nm, ns[pi]) < 0.0
    pi, pj, Xm = pi[facing], pj[facing], Xm[facing]
    # The master corners carried along the master's normal (the direction of
    # the closest-point projection) into the slave face's plane, then in the
    # slave face's reference coordinates.
    nm, nsp = nm[facing], ns[pi]
    t = -np.einsum("pki,pi->pk", Xm - X[pi, 0][:, None, :], nsp) / \
        np.einsum("pi,pi->p", nm, nsp)[:, None]
    Xm = Xm + t[..., None] * nm[:, None, :]
    g11 = np.einsum("ij,ij->i", e1, e1)
    g12 = np.einsum("ij,ij->i", e1, e2)
    g22 = np.einsum("ij,ij->i", e2, e2)
    det = g11 * g22 - g12 * g12
    r = Xm - X[pi, 0][:, None, :]
    b1 = np.einsum("pki,pi->pk", r, e1[pi])
    b2 = np.einsum("pki,pi->pk", r, e2[pi])
    tri = np.stack([(g22[pi, None] * b1 - g12[pi, None] * b2) / det[pi, None],
                    (g11[pi, None] * b2 - g12[pi, None] * b1) / det[pi, None]], axis=-1)
    # the test functions are smooth over the whole face but for the split
    # multiplier, whose hat functions are those of the sub-triangles
    subs = _SUBS if slave.nodes_per_face == 6 and multiplier == "split" else _WHOLE
    qx, qw = _rule()
    pair, sub, xi, eta, wref = _segment_kernel(np.ascontiguousarray(tri),
                                               np.ascontiguousarray(subs), qx, qw, 1e-14)
    face, mface = pi[pair], master_faces[pj[pair]]
    # faces without an overlap keep the plain rule
    bare = np.setdiff1d(np.arange(nf), face)
    face = np.concatenate([face, np.repeat(bare, nq)])
    mface = np.concatenate([mface, np.full(len(bare) * nq, -1, dtype=np.int64)])
    xi = np.concatenate([xi, np.tile(plain.xi, len(bare))])
    eta = np.concatenate([eta, np.tile(plain.eta, len(bare))])
    sub = np.concatenate([sub, np.full(len(bare) * nq, -1, dtype=np.int64)])
    _, t1, t2, _ = slave.geometry(x_ref, xi, eta, f[face])
    jac = np.linalg.norm(np.cross(t1, t2), axis=-1)
    weight = np.concatenate([wref, np.zeros(len(bare) * nq)]) * jac
    weight[len(wref):] = plain.weight[bare].ravel()
    phi = _test_functions(xi, eta, sub, slave.nodes_per_face, multiplier)
    if len(bare):
        phi[len(wref):] = np.tile(plain.phi, (len(bare), 1))
    return Segments(face, mface, xi, eta, weight, phi)


#: Degree of the rule on each segment's triangles. On a flat face the
#: integrands, a test function times a master shape function or the gap,
#: are quadratic on a segment: degree 2 integrates them exactly (the patch
#: test to round-off). On curved 6-node faces the gap is smooth on a
#: segment, a fraction of a face: on the static Hertz study's medium level
#: the force moves by at most 3.7e-5 against degree 4 (five loads), which
#: costs twice the points.
SEGMENT_RULE_DEGREE = 2


@functools.lru_cache(maxsize=1)
def _rule() -> tuple[np.ndarray, np.ndarray]:
    """The segments' rule on the unit triangle: points (nq, 2), weights summing to 1/2."""
    from skfem.quadrature import get_quadrature
    from skfem.refdom import RefTri

    X, W = get_quadrature(RefTri, SEGMENT_RULE_DEGREE)
    return np.ascontiguousarray(X.T), np.ascontiguousarray(W)


def _test_functions(xi, eta, sub, nn, multiplier) -> np.ndarray:
    """The nodal test functions at points ``(xi, eta)`` of sub-triangle ``sub``."""
    lin, _ = tri_shape(xi, eta, 3)
    if nn == 3:
        return lin
    phi = np.zeros((len(xi), 6))
    if multiplier == "linear":
        phi[:, :3] = lin
        return phi
    for s, nodes in enumerate(_SUB_TRIANGLES):
        on = sub == s
        if not on.any():
            continue
        c = _REF_NODES[nodes]
        T = np.column_stack([c[1] - c[0], c[2] - c[0]])
        loc = np.linalg.solve(T, np.stack([xi[on] - c[0, 0], eta[on] - c[0, 1]]))
        phi[np.ix_(on, nodes)] = tri_shape(loc[0], loc[1], 3)[0]
    return phi


@dataclass(frozen=True, eq=False)
class Projection:
    """Closest points of slave points on the master surface."""

    valid: np.ndarray    # (n,) a projection inside some master face was found
    face: np.ndarray     # (n,) master face index
    xi: np.ndarray
    eta: np.ndarray
    point: np.ndarray    # (n, 3)
    normal: np.ndarray   # (n, 3) unit outward master normal
    gap: np.ndarray      # (n,) n . (x_s - x_m)


def project(points: np.ndarray, master: ContactSurface, x: np.ndarray,
            faces: np.ndarray, k: int = 8, iterations: int = 6,
            hint: Projection | None = None) -> Projection:
    """Project points on the master faces ``faces`` of the configuration ``x``.

    The ``k`` faces with the nearest centroids are tried, each by
    ``iterations`` Gauss-Newton steps on its reference coordinates from the
    centroid; the closest projection falling inside a face wins. Points with
    no such projection (beyond the master's edge) are marked invalid. The
    loop over points and faces is compiled (:func:`_project_kernel`).

    ``hint``, the projection of the same points on the same faces in a
    nearby configuration, is tried first: a point whose Gauss-Newton
    iteration from its previous face and coordinates ends inside that face
    by :data:`_HINT_MARGIN` keeps it (:func:`_project_hinted`); the others
    are searched as above. Within a gap much smaller than the surface's radii
    of curvature a point's closest-point projection is unique, so a
    projection well inside a face is the one the search would find.
    """
    if hint is not None and len(hint.face) == len(points):
        kept, xi, eta, point, nrm, gap = _project_hinted(
            np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(x, dtype=float),
            np.ascontiguousarray(master.faces, dtype=np.int64),
            np.where(hint.valid, hint.face, -1).astype(np.int64), hint.xi, hint.eta,
            iterations, _HINT_MARGIN)
        rest = np.flatnonzero(~kept)
        valid, face = kept.copy(), np.where(kept, hint.face, 0)
        if len(rest):
            other = project(points[rest], master, x, faces, k, iterations)
            valid[rest], face[rest] = other.valid, other.face
            xi[rest], eta[rest], point[rest] = other.xi, other.eta, other.point
            nrm[rest], gap[rest] = other.normal, other.gap
        return Projection(valid, face, xi, eta, point, nrm, gap)
    k = int(min(k, len(faces)))
    nodes = x[master.faces[faces]]
    cent = nodes[:, :3].mean(axis=1)
    # A face lies in the convex hull of its Bezier control points: the corners
    # and, on a 6-node face, 2 m - (a + b) / 2 for the mid-side node m of the
    # edge a-b. So no point of the face is farther from the centroid than the
    # farthest control point, and a face whose centroid is farther than that
    # beyond the best projection so far cannot win.
    control = nodes[:, :3]
    if nodes.shape[1] == 6:
        ends = nodes[:, [0, 1, 2]] + nodes[:, [1, 2, 0]]
        control = np.concatenate([control, 2.0 * nodes[:, 3:6] - 0.5 * ends], axis=1)
    reach = np.linalg.norm(control - cent[:, None, :], axis=2).max(axis=1)
    dist, cand = cKDTree(cent).query(points, k=k)
    cand = np.ascontiguousarray(cand.reshape(len(points), k), dtype=np.int64)
    best, xi, eta, point, nrm, gap = _project_kernel(
        np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(nodes, dtype=float),
        cand, np.ascontiguousarray(dist.reshape(len(points), k)),
        np.ascontiguousarray(reach[cand]), iterations, _INSIDE_TOL)
    valid = best >= 0
    face = faces[np.where(valid, cand[np.arange(len(points)), np.maximum(best, 0)], cand[:, 0])]
    return Projection(valid, face, xi, eta, point, nrm, gap)


@njit(cache=True)
def _shape(xi, eta, nn, N, dxi, deta):
    """Fill the shape functions of a 3- or 6-node triangle and their derivatives."""
    L0 = 1.0 - xi - eta
    if nn == 3:
        N[0], N[1], N[2] = L0, xi, eta
        dxi[0], dxi[1], dxi[2] = -1.0, 1.0, 0.0
        deta[0], deta[1], deta[2] = -1.0, 0.0, 1.0
        return
    N[0], N[1], N[2] = L0 * (2 * L0 - 1), xi * (2 * xi - 1), eta * (2 * eta - 1)
    N[3], N[4], N[5] = 4 * L0 * xi, 4 * xi * eta, 4 * eta * L0
    dxi[0], dxi[1], dxi[2] = -(4 * L0 - 1), 4 * xi - 1, 0.0
    dxi[3], dxi[4], dxi[5] = 4 * (L0 - xi), 4 * eta, -4 * eta
    deta[0], deta[1], deta[2] = -(4 * L0 - 1), 0.0, 4 * eta - 1
    deta[3], deta[4], deta[5] = -4 * xi, 4 * xi, 4 * (L0 - eta)


@njit(cache=True)
def _gauss_newton(p, X, xi, eta, iterations, N, dxi, deta, pos, t1, t2):
    """Closest point of point ``p`` on the face of node positions ``X`` ((nn, 3))
    from ``(xi, eta)``.

    At most ``iterations`` Gauss-Newton steps on the reference coordinates,
    stopping once a step is below 1e-14; ``pos``, ``t1``, ``t2`` are left
    holding the point and the tangents at the returned coordinates. Returns
    ``xi``, ``eta`` and the size of the last step (inf if none was made).
    """
    nn = X.shape[0]
    step = np.inf
    for it in range(iterations + 1):
        _shape(xi, eta, nn, N, dxi, deta)
        for d in range(3):
            pos[d] = 0.0
            t1[d] = 0.0
            t2[d] = 0.0
            for a in range(nn):
                xa = X[a, d]
                pos[d] += N[a] * xa
                t1[d] += dxi[a] * xa
                t2[d] += deta[a] * xa
        if it == iterations or step < 1e-14:
            break
        a11 = t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]
        a12 = t1[0] * t2[0] + t1[1] * t2[1] + t1[2] * t2[2]
        a22 = t2[0] * t2[0] + t2[1] * t2[1] + t2[2] * t2[2]
        b1 = 0.0
        b2 = 0.0
        for d in range(3):
            r = p[d] - pos[d]
            b1 += t1[d] * r
            b2 += t2[d] * r
        det = a11 * a22 - a12 * a12
        dxi_, deta_ = (a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det
        xi, eta = xi + dxi_, eta + deta_
        step = abs(dxi_) + abs(deta_)
    return xi, eta, step


@njit(cache=True)
def _store(i, p, pos, t1, t2, pt_o, nrm_o, gap_o):
    """Row ``i`` of the outputs: the projected point, the unit normal ``t1 x t2``
    and the gap of point ``p``."""
    nx = t1[1] * t2[2] - t1[2] * t2[1]
    ny = t1[2] * t2[0] - t1[0] * t2[2]
    nz = t1[0] * t2[1] - t1[1] * t2[0]
    s = 1.0 / np.sqrt(nx * nx + ny * ny + nz * nz)
    nrm_o[i, 0], nrm_o[i, 1], nrm_o[i, 2] = nx * s, ny * s, nz * s
    g = 0.0
    for d in range(3):
        pt_o[i, d] = pos[d]
        g += nrm_o[i, d] * (p[d] - pos[d])
    gap_o[i] = g


@njit(cache=True)
def _outputs(n):
    """The projection kernels' outputs for ``n`` points: reference coordinates,
    point, normal (zero) and gap (+inf, as for a point with no projection)."""
    return np.zeros(n), np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3)), np.full(n, np.inf)


@njit(cache=True)
def _scratch(nn):
    """Work arrays of :func:`_gauss_newton` on ``nn``-node faces: shape functions and
    their two derivatives, the point and its two tangents."""
    return (np.empty(nn), np.empty(nn), np.empty(nn), np.empty(3), np.empty(3),
            np.empty(3))


@njit(cache=True)
def _far_outside(p, X, far, tol):
    """True if no closest point of ``p`` on the face ``X`` ((nn, 3) node positions)
    lies inside it by ``tol`` in reference coordinates, judged without iterating.

    With corners ``a0, a1, a2`` the face is ``x = F + B``: ``F`` the flat
    triangle ``a0 + xi e1 + eta e2`` and, on a 6-node face, the bubble
    ``B = 4 (L0 L1 d01 + L1 L2 d12 + L2 L0 d20)`` of the mid-side nodes'
    offsets ``d`` from their chords, so ``|B| <= 4/3 dev`` and
    ``|dB/dxi|, |dB/deta| <= 8 dev`` (``dev = max |d|``) over the face. At a
    closest point ``x*`` (``(p - x*) . x_j = 0``) the flat projection's
    coordinates differ from ``x*``'s by ``G^-1 r`` (``G = [e_i . e_j]``),
    where ``|r_j| <= |p - x*| |B_j| + |B| |e_j|`` and ``|p - x*|`` is at most
    ``far``, the centroid's distance plus the face's reach. A flat
    projection farther outside than that, plus ``tol``, has no closest
    point inside: the search (:func:`_project_kernel`) skips the face
    without its Gauss-Newton iteration. (A Gauss-Newton end that is not
    yet a closest point is not covered; on the faces the iteration
    converges within its steps.)
    """
    e10 = X[1, 0] - X[0, 0]
    e11 = X[1, 1] - X[0, 1]
    e12 = X[1, 2] - X[0, 2]
    e20 = X[2, 0] - X[0, 0]
    e21 = X[2, 1] - X[0, 1]
    e22 = X[2, 2] - X[0, 2]
    r0 = p[0] - X[0, 0]
    r1 = p[1] - X[0, 1]
    r2 = p[2] - X[0, 2]
    a11 = e10 * e10 + e11 * e11 + e12 * e12
    a12 = e10 * e20 + e11 * e21 + e12 * e22
    a22 = e20 * e20 + e21 * e21 + e22 * e22
    b1 = e10 * r0 + e11 * r1 + e12 * r2
    b2 = e20 * r0 + e21 * r1 + e22 * r2
    det = a11 * a22 - a12 * a12
    xi = (a22 * b1 - a12 * b2) / det
    eta = (a11 * b2 - a12 * b1) / det
    dev2 = 0.0
    if X.shape[0] == 6:
        for m in range(3):
            q = (m + 1) % 3
            d0 = X[3 + m, 0] - 0.5 * (X[m, 0] + X[q, 0])
            d1 = X[3 + m, 1] - 0.5 * (X[m, 1] + X[q, 1])
            d2 = X[3 + m, 2] - 0.5 * (X[m, 2] + X[q, 2])
            dev2 = max(dev2, d0 * d0 + d1 * d1 + d2 * d2)
    dev = np.sqrt(dev2)
    rb1 = dev * (8.0 * far + 4.0 / 3.0 * np.sqrt(a11))
    rb2 = dev * (8.0 * far + 4.0 / 3.0 * np.sqrt(a22))
    s1 = (a22 * rb1 + abs(a12) * rb2) / det + tol
    s2 = (abs(a12) * rb1 + a11 * rb2) / det + tol
    return xi < -s1 or eta < -s2 or xi + eta > 1.0 + s1 + s2


@njit(cache=True)
def _project_kernel(points, nodes, cand, cdist, reach, iterations, tol):
    """Closest in-face projection of each point over its candidate faces.

    ``nodes``: the faces' node positions (nf, nn, 3); ``cand``: each point's
    candidate faces (rows of ``nodes``), nearest centroid first (``cdist``).
    A candidate whose centroid lies farther than its ``reach`` beyond the
    best distance found is skipped, and so is one whose flat projection lies
    too far outside it (:func:`_far_outside`: three quarters of the
    candidates of a coarse tooth pair's flanks, the search six times
    faster, the same projections). The Gauss-Newton iteration stops early
    once its step is below 1e-14 in reference coordinates. Returns the
    winning candidate's column (-1: none inside), reference coordinates,
    point, unit normal ``t1 x t2`` and gap (+inf if none).
    """
    n, k = cand.shape
    best = -np.ones(n, dtype=np.int64)
    xi_o, eta_o, pt_o, nrm_o, gap_o = _outputs(n)
    N, dxi, deta, pos, t1, t2 = _scratch(nodes.shape[1])
    for i in range(n):
        dbest = np.inf
        xi_b, eta_b = 1.0 / 3.0, 1.0 / 3.0
        for c in range(k):
            if cdist[i, c] - reach[i, c] > np.sqrt(dbest):
                continue
            X = nodes[cand[i, c]]
            if _far_outside(points[i], X, cdist[i, c] + reach[i, c], 2.0 * tol):
                continue
            xi, eta, _ = _gauss_newton(points[i], X, 1.0 / 3.0, 1.0 / 3.0, iterations,
                                       N, dxi, deta, pos, t1, t2)
            if xi < -tol or eta < -tol or xi + eta > 1.0 + tol:
                continue
            dist = 0.0
            for d in range(3):
                dist += (points[i, d] - pos[d]) ** 2
            if dist < dbest:
                dbest = dist
                best[i] = c
                xi_b, eta_b = xi, eta
                _store(i, points[i], pos, t1, t2, pt_o, nrm_o, gap_o)
        xi_o[i], eta_o[i] = xi_b, eta_b
    return best, xi_o, eta_o, pt_o, nrm_o, gap_o


#: A hinted projection is kept if it ends this far inside its face (in each
#: reference coordinate): between the iterations of a load step the flanks move
#: by about a thousandth of a face, so the points that may change face are
#: searched again. On three coarse tooth-pair positions 75% of the points kept
#: theirs, and the load steps took 24% less time (stage 2's nine positions:
#: 22.5 -> 17.2 s). The kept projections are the searched ones (same face, gaps
#: within 1e-17 m), but for 59 of 976k points that the search missed: on
#: faces stretched 8 to 1 the nearest centroids can miss the face that holds
#: the projection, which the hint keeps (approach at 1 kN changed by 1e-5).
_HINT_MARGIN = 0.02


@njit(cache=True)
def _project_hinted(points, x, mfaces, face0, xi0, eta0, iterations, margin):
    """Projection of each point on its hinted face ``face0`` (-1: none) from the
    hinted coordinates; ``kept`` where it ends inside by ``margin``. The other
    outputs as :func:`_project_kernel`'s, for the kept points."""
    n = points.shape[0]
    kept = np.zeros(n, dtype=np.bool_)
    xi_o, eta_o, pt_o, nrm_o, gap_o = _outputs(n)
    N, dxi, deta, pos, t1, t2 = _scratch(mfaces.shape[1])
    X = np.empty((mfaces.shape[1], 3))
    for i in range(n):
        f = face0[i]
        if f < 0:
            continue
        for a in range(mfaces.shape[1]):
            for d in range(3):
                X[a, d] = x[mfaces[f, a], d]
        xi, eta, step = _gauss_newton(points[i], X, xi0[i], eta0[i], iterations,
                                      N, dxi, deta, pos, t1, t2)
        # converged: the last step at the round-off of coordinates in metres
        if not step < 1e-9 or xi < margin or eta < margin or xi + eta > 1.0 - margin:
            continue
        kept[i] = True
        xi_o[i], eta_o[i] = xi, eta
        _store(i, points[i], pos, t1, t2, pt_o, nrm_o, gap_o)
    return kept, xi_o, eta_o, pt_o, nrm_o, gap_o


@dataclass(frozen=True, eq=False)
class GapState:
    """Weighted gaps at the slave nodes and their linearisation ``dg = B du``.

    The weighted gap of node ``a`` is ``g_a = int phi_a g dA / A_a`` with
    ``A_a = int phi_a dA`` its tributary area: one constraint per slave node
    that carries a test function (all nodes of 3-node faces; the corners of
    6-node faces with the linear multiplier) and whose faces are all in the
    face subset (a node on its edge would have a cut support), so the
    pressure ``eps <-g_a>`` is a smooth nodal field (a gap sampled at every
    quadrature point over-constrains the surface and the pressure oscillates
    from point to point).
    """

    nodes: np.ndarray    # (n,) slave point indices
    gap: np.ndarray      # (n,) m; +inf where no master face is opposite
    weight: np.ndarray   # (n,) area the gap averages (its support a master face covers), m^2
    B: sp.csr_matrix | None   # (n, 3 * n_scalar_dofs); None if not asked for
    point: np.ndarray    # (n, 3) deformed slave nodes
    normal: np.ndarray   # (n, 3) averaged master normal
    area: np.ndarray | None = None   # (n,) the whole support's area A_a, m^2


@dataclass(frozen=True, eq=False)
class _SlaveLayout:
    """What :meth:`ContactPair.gap_state` needs of a slave face subset against a
    master face subset: the segments' quadrature points, test weights, nodes."""

    snodes: np.ndarray   # (n_pts, nn) each quadrature point's slave face nodes
    Ns: np.ndarray       # (n_pts, nn) their shape functions
    master: np.ndarray   # (n_pts,) the master face of each point's segment (-1: none)
    reach: np.ndarray    # (n_pts,) the size (circumradius) of each point's slave face
    W: sp.csr_matrix     # (n, n_pts) phi_a(q) w_q of the tested nodes
    nodes: np.ndarray    # (n,) tested nodes
    area: np.ndarray     # (n,) their tributary areas (the whole support)


#: Face subsets whose layout a pair keeps (the zone, and the ring the growth
#: check projects; a zone that grows replaces them).
_LAYOUTS_KEPT = 4


@dataclass(frozen=True, eq=False)
class ContactPair:
    """A slave/master surface pair with its penalty (Pa/m) and pressure interpolation."""

    slave: ContactSurface
    master: ContactSurface
    penalty: float
    multiplier: str = "linear"
    _layouts: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    _hints: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def _layout(self, mesh: FEMesh, x: np.ndarray, slave_faces: np.ndarray,
                master_faces: np.ndarray, key: tuple, rebuild: bool = False) -> _SlaveLayout:
        """The mortar segments of ``slave_faces`` on ``master_faces``
        (:func:`mortar_segments`), split once per pair of subsets in the
        undeformed configuration (the solvers project the same zone at every
        iteration; a node's gap is then the same whatever subsets were asked
        before), or in the configuration ``x`` when ``rebuild``."""
        kept = self._layouts.get(key)
        if kept is not None and kept[0] is mesh and not rebuild:
            return kept[1]
        seg = mortar_segments(self.slave, self.master, mesh.points,
                              x if rebuild else mesh.points, slave_faces,
                              master_faces, self.multiplier)
        f = self.slave.faces[slave_faces]
        snodes = f[seg.face]
        Ns, _ = tri_shape(seg.xi, seg.eta, self.slave.nodes_per_face)
        # Aggregate quadrature points onto nodes: W[a, q] = phi_a(q) w_q.
        nodes, inv = np.unique(f, return_inverse=True)
        inv = inv.reshape(f.shape)[seg.face]                    # (n_pts, nn)
        c = seg.phi * seg.weight[:, None]
        cols = np.broadcast_to(np.arange(len(seg.face))[:, None], c.shape)
        W = sp.csr_matrix((c.ravel(), (inv.ravel(), cols.ravel())),
                          shape=(len(nodes), len(seg.face)))
        plain = slave_points(self.slave, mesh.points, slave_faces, self.multiplier)
        area = np.zeros(len(nodes))
        np.add.at(area, np.unique(f, return_inverse=True)[1].reshape(f.shape),
                  np.einsum("fq,qa->fa", plain.weight, plain.phi))
        # Mid-side nodes carry no test function with "linear"; nodes on the
        # edge of the face subset have a cut support and are left out.
        tested = (area > 0.0) & np.isin(nodes, self.slave.complete_nodes(slave_faces))
        x0 = mesh.points[f[:, :3]]
        reach = np.linalg.norm(x0 - x0.mean(axis=1)[:, None, :], axis=2).max(axis=1)
        layout = _SlaveLayout(snodes, Ns, seg.master, reach[seg.face], W[tested],
                              nodes[tested], area[tested])
        self._layouts.pop(key, None)
        while len(self._layouts) >= _LAYOUTS_KEPT:
            self._layouts.pop(next(iter(self._layouts)))
        self._layouts[key] = (mesh, layout)
        return layout

    def gap_state(self, mesh: FEMesh, u: np.ndarray, slave_faces: np.ndarray,
                  master_faces: np.ndarray, jacobian: bool = True) -> GapState:
        """Gaps of the deformed configuration ``x = X + u`` (u: (n_points, 3)).

        ``jacobian=False``: the gaps alone, ``B`` left None (the zone's growth
        check, which only compares gaps with a margin).

        The segments are split once per pair of face subsets; when a point
        near the master projects well inside another master face than its
        segment's (the faces slid over each other, :func:`_segments_stale`),
        they are split again in the current configuration.
        """
        x = mesh.points + u
        key = (id(mesh), np.asarray(slave_faces).tobytes(), np.asarray(master_faces).tobytes())
        lay = self._layout(mesh, x, slave_faces, master_faces, key)
        proj = self._project(mesh, x, lay, master_faces, key)
        if _segments_stale(lay, proj):
            logger.debug("contact %s: segments split again (%d points on another face)",
                         self.slave.name, int(np.sum(proj.valid & (proj.face != lay.master))))
            lay = self._layout(mesh, x, slave_faces, master_faces, key, rebuild=True)
            self._hints.pop(key, None)
            proj = self._project(mesh, x, lay, master_faces, key)
        if jacobian:
            Nm, _ = tri_shape(proj.xi, proj.eta, self.master.nodes_per_face)
            Bq = _gap_jacobian(mesh, lay.snodes, lay.Ns, self.master.faces[proj.face], Nm,
                               proj.normal, proj.valid)
        # the points projected inside a master face only
        Wv = lay.W.copy()
        Wv.data = Wv.data * proj.valid[Wv.indices]
        valid_area = np.asarray(Wv.sum(axis=1)).ravel()
        ok = valid_area > 1e-3 * lay.area
        scale = np.where(ok, 1.0 / np.where(ok, valid_area, 1.0), 0.0)
        Wn = sp.diags(scale) @ Wv
        gap = np.where(ok, Wn @ np.where(proj.valid, proj.gap, 0.0), np.inf)
        normal = Wn @ proj.normal
        normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
        # The penalty acts on the area the gap averages: the part of the
        # node's support a master face covers (at a master edge, less than
        # its whole support).
        weight = np.where(ok, valid_area, lay.area)
        return GapState(lay.nodes, gap, weight, (Wn @ Bq).tocsr() if jacobian else None,
                        x[lay.nodes], normal, lay.area)

    def projected_layout(self, mesh: FEMesh, x: np.ndarray, slave_faces: np.ndarray,
                         master_faces: np.ndarray) -> tuple[_SlaveLayout, Projection]:
        """The mortar layout of ``slave_faces`` on ``master_faces`` and its points'
        projection in the configuration ``x`` (nodal coordinates, (n_nodes, 3) m).

        The projection :meth:`gap_state` has just made of the same subsets and
        configuration is reused; otherwise the points are projected again. Other
        contact laws on the same rows (friction's tangential slips) read their
        segments and master points from here, so they see what the gaps see.
        """
        key = (id(mesh), np.asarray(slave_faces).tobytes(), np.asarray(master_faces).tobytes())
        lay = self._layout(mesh, x, slave_faces, master_faces, key)
        kept = self._hints.get(key)
        if kept is not None and kept[0] is mesh and len(kept[1].face) == len(lay.Ns):
            return lay, kept[1]
        return lay, self._project(mesh, x, lay, master_faces, key)

    def _project(self, mesh: FEMesh, x: np.ndarray, lay: _SlaveLayout,
                 master_faces: np.ndarray, key: tuple) -> Projection:
        """Project the layout's points, the last projection of the same subsets
        as the hint."""
        pts = np.einsum("pa,pai->pi", lay.Ns, x[lay.snodes])
        kept = self._hints.get(key)
        hint = kept[1] if kept is not None and kept[0] is mesh else None
        proj = project(pts, self.master, x, master_faces, hint=hint)
        while len(self._hints) >= _LAYOUTS_KEPT and key not in self._hints:
            self._hints.pop(next(iter(self._hints)))
        self._hints[key] = (mesh, proj)
        return proj


#: A point within a face's size of the master whose projection lies this far
#: inside another master face than its segment's (in each reference coordinate)
#: has left its segment: the faces slid. Nearer a master edge it is the split's
#: approximation on curved faces (the master's edges are chords, a 6-node
#: slave face is cut on its corner plane), and farther from the master the
#: projection's direction tilts; neither matters to a contact.
_STALE_MARGIN = 0.05


def _segments_stale(lay: _SlaveLayout, proj: Projection) -> bool:
    """True if a point near the master projects well inside a master face other
    than its segment's."""
    inside = (proj.xi > _STALE_MARGIN) & (proj.eta > _STALE_MARGIN) & \
        (proj.xi + proj.eta < 1.0 - _STALE_MARGIN)
    return bool(np.any(proj.valid & (proj.face != lay.master) & inside &
                       (proj.gap < lay.reach)))


def _gap_jacobian(mesh: FEMesh, snodes, Ns, mnodes, Nm, normal, valid) -> sp.csr_matrix:
    """d gap / d u of each point: its slave nodes' shape functions minus its master
    point's, times the normal; one row of ``3 a`` entries a point (``a`` nodes).

    Built as CSR directly: a row's nodes are distinct (slave and master nodes
    belong to different bodies), so there is nothing to sum, and the COO route
    sorted and summed 430k entries for nothing (a third of a projection's time
    on a coarse tooth pair). The columns within a row are not sorted.
    """
    n = len(normal)
    nodes = np.concatenate([snodes, mnodes], axis=1)            # (n, a)
    coef = np.concatenate([Ns, -Nm], axis=1) * valid[:, None]   # (n, a)
    vals = coef[:, :, None] * normal[:, None, :]                # (n, a, 3)
    cols = 3 * mesh.point_dof[nodes][:, :, None] + np.arange(3)
    per_row = cols.shape[1] * 3
    ndof = 3 * (mesh.point_dof.max() + 1)
    return sp.csr_matrix((vals.reshape(-1), cols.reshape(-1),
                          np.arange(0, n * per_row + 1, per_row)), shape=(n, ndof))


def nodal_areas(mesh: FEMesh, surface: ContactSurface) -> np.ndarray:
    """Tributary area of every node of a surface (m^2; an (n_points,) array, 0 off it).

    A node's area is the integral of its hat function on the faces (on the
    four linear sub-triangles of a 6-node face, so that every node, mid-side
    ones too, has a positive area and the areas resolve half a face). The
    contact area is the area of the nodes whose pressure is positive.
    """
    faces = np.arange(len(surface.faces))
    sp_ = slave_points(surface, mesh.points, faces, "split")
    per_node = sp_.weight @ sp_.phi                     # (n_faces, nodes per face)
    out = np.zeros(mesh.n_points)
    np.add.at(out, surface.faces.ravel(), per_node.ravel())
    return out


def nodal_pressure(mesh: FEMesh, pair: ContactPair, state: GapState,
                   pressure: np.ndarray) -> np.ndarray:
    """Scatter the pressure at ``state.nodes`` into an (n_points,) array, zero elsewhere.

    Mid-side nodes of 6-node faces that carry no pressure of their own (the
    linear multiplier) get the mean of their two corners, the value of the
    face's linear pressure there.
    """
    out = np.zeros(mesh.n_points)
    out[state.nodes] = pressure
    f = pair.slave.faces
    if f.shape[1] == 6 and len(state.nodes):
        mid = f[:, 3:].ravel()
        untested = ~np.isin(mid, state.nodes)
        ends = f[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2)
        out[mid[untested]] = 0.5 * out[ends[untested]].sum(axis=1)
    return out
