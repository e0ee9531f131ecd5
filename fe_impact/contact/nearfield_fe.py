"""Combined near field: half-space grid over a coarse FE far field (Vijayakar 1991).

The compliance of a contact patch is split at a matching depth ``d`` below
each surface (Vijayakar, IJNME 31, 1991, 525-545, in the form used here):

    w_b(x) = [w_hs(x, surface) - w_hs(x, depth d)]_b + u_FE,b(x, depth d)

for each body ``b``, ``w`` the normal displacement away from the other
body at the surface point ``x`` of the fine grid:

- the bracket is the half-space's own relative displacement between the
  surface and the point at depth ``d`` under it (Love's cell influence
  minus Boussinesq's point-load displacement at depth, both convolutions on
  the grid: :mod:`fe_impact.contact.nearfield`);
- ``u_FE,b`` is the coarse FE's displacement of the point at depth ``d``,
  the body loaded by the grid's pressure as point forces on its surface
  (P2 or P1 shape functions of the tetrahedron holding each point).

What is subtracted, and why: the coarse FE resolves neither the patch nor
the steep field just below it, but a few elements deep the displacement no
longer depends on how the load is spread (Saint-Venant): there the coarse FE
is right, and it carries what the half-space lacks (the finite body, its
supports, bending). The half-space part is therefore counted only between
the surface and depth ``d``: the coarse FE's own response above ``d`` is
never used, so nothing is counted twice. ``d`` must hold several coarse
elements and stay small against the radii of curvature of the surfaces and
the distance to an edge (the half-space assumption of the layer above it).

Matching on the FE's own loads (``FarField(same_load=True)``, Vijayakar's
choice): when the FE is loaded not by the grid's pressure but by a smoother
version of it (the pressure gathered on bilinear hats and spread back by
their shapes, :class:`HatBasis`), the half-space term subtracted at depth is
that of the same hat-spread loads, not of the grid's pressure:

    w(x) = w_hs(x, surface; p) + sum_b [u_FE,b(x, d; Hp) - w_hs,b(x, d; Hp)]

The bracket is then the FE's finite-body correction under one and the same
load, and the hats can be as wide as the coarse elements, so that the FE
resolves the load it is given (with the grid pressure subtracted, the hats
must stay well below the depth, where the coarse FE does not resolve them).
What is left is the difference between the finite-body corrections of ``p``
and of ``Hp``, second order in the hat spacing over the tooth's size (the
hats keep the force and its first moments).

The coarse FE enters as a low-rank operator: one solve per loaded surface
DOF (the nodes under the grid), then ``P_depth Z P_surface^T``; with the
convolution it is applied per iteration in O(n log n + n m) for n cells and
m loaded DOFs. Its non-symmetric far part is iterated on at a fixed force
(:func:`solve_combined`): a uniform far-field shift only moves the rigid
approach, so the iteration converges in a few passes.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from fe_impact.contact import nearfield as nf
from fe_impact.fe.mesh import FEMesh

logger = logging.getLogger(__name__)

#: Edges of a 10-node tetrahedron in the mesh's node order (VTK/meshio: nodes
#: 4-9 on edges 01, 12, 02, 03, 13, 23).
TET10_EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
#: Candidate elements searched per probe point (nearest centroids).
CANDIDATES = 12
#: A probe point with a barycentric coordinate below minus this is searched
#: again among the elements whose bounding box holds it.
INSIDE_TOLERANCE = 1e-6
#: Far-field fixed-point iteration: stop when the far-field displacement
#: changes by less than this fraction of the approach.
FAR_TOLERANCE = 1e-6
MAX_FAR_ITERATIONS = 50
#: Smallest matching depth, in coarse elements at the contact, for which the
#: coarse FE's displacement at depth is trusted (Saint-Venant).
MIN_DEPTH_ELEMENTS = 3.0
#: Largest patch half-width against the smaller local radius of curvature
#: for which the half-space layer is accepted (Hertz's own small-strain
#: condition a << R; at a/R = 0.1 the curvature changes the approach by
#: about 1% (Johnson 1985, section 4.2)).
MAX_PATCH_TO_RADIUS = 0.1
#: Cells across the patch below which the grid is refused (the counted
#: contact radius is then worse than 5%, half a cell).
MIN_CELLS_ACROSS = 20


def probe_matrix(mesh: FEMesh, points: np.ndarray, volume: str, direction
                 ) -> sp.csr_matrix:
    """Interpolation of the displacement along ``direction`` at ``points`` (k, 3), in m.

    ``direction``: a component (0, 1, 2) or a unit 3-vector.

    Returns the sparse (k, n_dofs) matrix of the element shape functions of
    the tetrahedron of ``volume`` holding each point (the one with the largest
    smallest barycentric coordinate among the nearest candidates, so a point
    a rounding error outside the straight-sided element is clamped in). DOF
    ``3 * point_dof[node] + component``.
    """
    if np.ndim(direction) == 0:
        direction = np.eye(3)[int(direction)]
    direction = np.asarray(direction, dtype=float)
    cells = mesh.cells[mesh.volume(volume)]
    vert = mesh.points[cells[:, :4]]                          # (e, 4, 3)
    tree = cKDTree(vert.mean(axis=1))
    k = min(CANDIDATES, len(cells))
    _, cand = tree.query(points, k=k)
    cand = cand.reshape(len(points), k)
    lam = _barycentric(vert, cand, points)                    # (n, k, 4)
    best = np.argmax(lam.min(axis=2), axis=1)
    rows = np.arange(len(points))
    el = cand[rows, best]
    L = lam[rows, best]
    # Stretched elements: the nearest centroids need not hold the point.
    # Those left outside are searched among the elements whose box holds them.
    missed = np.flatnonzero(L.min(axis=1) < -INSIDE_TOLERANCE)
    if missed.size:
        lo, hi = vert.min(axis=1), vert.max(axis=1)
        for i in missed:
            box = np.flatnonzero(np.all((lo <= points[i]) & (points[i] <= hi), axis=1))
            if box.size:
                lb = _barycentric(vert, box[None, :], points[i:i + 1])[0]
                j = int(np.argmax(lb.min(axis=1)))
                if lb[j].min() > L[i].min():
                    el[i], L[i] = box[j], lb[j]
    L = np.clip(L, 0.0, None)
    L /= L.sum(axis=1, keepdims=True)
    if mesh.order == 2:
        shape = np.concatenate([L * (2 * L - 1)] + [4 * L[:, [i]] * L[:, [j]]
                                                      for i, j in TET10_EDGES], axis=1)
    else:
        shape = L
    nodes = cells[el, :shape.shape[1]]
    n_dofs = 3 * int(mesh.point_dof.max() + 1)
    used = [c for c in range(3) if direction[c] != 0.0]
    dofs = np.concatenate([3 * mesh.point_dof[nodes] + c for c in used], axis=1)
    vals = np.concatenate([shape * direction[c] for c in used], axis=1)
    return sp.csr_matrix((vals.ravel(), (np.repeat(rows, vals.shape[1]), dofs.ravel())),
                         shape=(len(points), n_dofs))


def _barycentric(vert: np.ndarray, cand: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of ``points`` (n, 3) in the tetrahedra ``vert[cand]`` (n, k)."""
    used, inv_idx = np.unique(cand, return_inverse=True)
    T = np.stack([vert[used, i, :] - vert[used, 3, :] for i in range(3)], axis=-1)
    Tinv = np.linalg.inv(T)                                   # (u, 3, 3)
    rhs = points[:, None, :] - vert[cand, 3, :]               # (n, k, 3)
    l3 = np.einsum("nkij,nkj->nki", Tinv[inv_idx.reshape(cand.shape)], rhs)
    return np.concatenate([l3, 1.0 - l3.sum(axis=-1, keepdims=True)], axis=-1)


@dataclass(frozen=True)
class Side:
    """One body of the contact, as the near field sees it.

    Attributes
    ----------
    volume : str
        FE volume group of the body.
    youngs, poisson : float
        Its elastic constants (Pa, -).
    height : callable
        ``height(x, y)``: height (m, along the frame's normal) of the body's
        undeformed surface over the grid point (x, y) of the contact plane.
    inward : float
        +1 if the body lies on the normal's side of its surface, -1 on the other.
    exists : callable, optional
        ``exists(x, y)`` -> bool: where the body's surface lies over the
        plane (a flank's end crossing the grid); default everywhere. The far
        field's hat loads are spread only there (:func:`hat_samples`).
    """

    volume: str
    youngs: float
    poisson: float
    height: Callable[[np.ndarray, np.ndarray], np.ndarray]
    inward: float
    exists: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None


@dataclass(frozen=True)
class HatBasis:
    """Bilinear hats on a regular lattice of the contact plane: the far field's loads.

    The coarse FE at the matching depth sees a load only through its
    resultants over lengths below the depth (Saint-Venant), so the grid's
    cell forces are gathered onto the hats (each cell's force split by the
    hats' values at its centre: the total force and its first moments are
    kept) and each hat is solved once, as a unit force spread by its own
    shape. Spacing below the matching depth keeps the error of the depth
    response second order in spacing / depth.

    Attributes
    ----------
    half_x, half_y : float
        Half-extents of the lattice (m); points beyond load the edge hats.
    nx, ny : int
        Hats along x and y (at least 2 each).
    """

    half_x: float
    half_y: float
    nx: int
    ny: int

    def weights(self, x: np.ndarray, y: np.ndarray) -> sp.csr_matrix:
        """Hat values at the points (x, y): sparse (n_points, nx ny), rows summing to 1."""
        ix, tx = _hat_1d(x, self.half_x, self.nx)
        iy, ty = _hat_1d(y, self.half_y, self.ny)
        rows = np.repeat(np.arange(len(x)), 4)
        cols = np.column_stack([ix * self.ny + iy, ix * self.ny + iy + 1,
                                (ix + 1) * self.ny + iy, (ix + 1) * self.ny + iy + 1]).ravel()
        vals = np.column_stack([(1 - tx) * (1 - ty), (1 - tx) * ty, tx * (1 - ty),
                                tx * ty]).ravel()
        return sp.csr_matrix((vals, (rows, cols)), shape=(len(x), self.nx * self.ny))


def _hat_1d(x: np.ndarray, half: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    h = 2.0 * half / (n - 1)
    u = np.clip((np.asarray(x) + half) / h, 0.0, n - 1)
    i = np.minimum(np.floor(u).astype(np.int64), n - 2)
    return i, u - i


#: Samples per hat spacing along each axis when a hat's load is spread on the FE.
HAT_SAMPLES = 8


def hat_samples(hats: HatBasis, exists: Callable[[np.ndarray, np.ndarray], np.ndarray]
                | None = None) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix]:
    """How each hat's unit force is spread: sample points ``x, y`` (m) on a lattice
    of :data:`HAT_SAMPLES` per hat spacing, and their shares ``phi`` (samples,
    hats; each column sums to 1, in proportion to the hat's value).

    ``exists(x, y)`` -> bool: where the body's surface exists (a flank's end
    crossing the lattice); the samples beyond it are dropped and each hat's
    force is spread over those left, so the FE is loaded only on its own
    surface and the half-space term subtracted sees the same load. A hat
    with no sample left keeps its whole spread (no cell inside loads it).
    """
    mx, my = (hats.nx - 1) * HAT_SAMPLES + 1, (hats.ny - 1) * HAT_SAMPLES + 1
    X, Y = np.meshgrid(np.linspace(-hats.half_x, hats.half_x, mx),
                       np.linspace(-hats.half_y, hats.half_y, my), indexing="ij")
    x, y = X.ravel(), Y.ravel()
    phi = hats.weights(x, y)
    if exists is not None:
        keep = np.asarray(exists(x, y), dtype=bool)
        inside = phi.multiply(keep[:, None]).tocsr()
        empty = np.asarray(inside.sum(axis=0)).ravel() == 0.0
        phi = (inside + phi @ sp.diags(empty.astype(float))).tocsr()
        phi.eliminate_zeros()
    phi = (phi @ sp.diags(1.0 / np.asarray(phi.sum(axis=0)).ravel())).tocsr()
    return x, y, phi


def hat_half_space(hats: HatBasis, x: np.ndarray, y: np.ndarray, depth: float,
                   youngs: float, poisson: float,
                   exists: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                   ) -> np.ndarray:
    """Half-space normal displacement (m/N) at ``depth`` (m, 0 for the surface) under
    the points (x, y) of each hat's unit force spread as :func:`hat_samples`
    spreads it on the FE: (n_points, n_hats).

    Each sample carries its share of the force on its own cell: Love's
    rectangle at the surface (Johnson 1985, eq. 3.25), Boussinesq's axial
    displacement (eq. 3.21a) over a 3 x 3 Gauss rule of the cell below it.
    ``exists``: as :func:`hat_samples`.
    """
    sx, sy, phi = hat_samples(hats, exists)
    hx = 2.0 * hats.half_x / ((hats.nx - 1) * HAT_SAMPLES)
    hy = 2.0 * hats.half_y / ((hats.ny - 1) * HAT_SAMPLES)
    dx, dy = x[:, None] - sx[None, :], y[:, None] - sy[None, :]
    if depth <= 0.0:
        g = (nf.love_rectangle(dx, dy, hx / 2, hy / 2) / (hx * hy)
             * (1.0 - poisson ** 2) / (np.pi * youngs))
    else:
        gp, gw = np.polynomial.legendre.leggauss(3)
        g = np.zeros_like(dx)
        for gi, wi in zip(gp, gw, strict=True):
            for gj, wj in zip(gp, gw, strict=True):
                r = np.hypot(dx + gi * hx / 2, dy + gj * hy / 2)
                g += wi * wj / 4.0 * nf.depth_displacement(r, depth, youngs, poisson)
    return np.asarray(phi.T @ g.T).T


class FarField:
    """The coarse FE's displacement at depth under the grid's loads, for each side.

    Parameters
    ----------
    mesh : FEMesh
        The coarse mesh (both bodies).
    free : ndarray of int
        Free DOFs of its stiffness (supports held, prescribed motions at zero).
    solve : callable
        ``solve(B)`` -> ``K_ff^-1 B`` for a dense (n_free, m) block.
    sides : sequence of Side
    frame : tuple of ndarray, optional
        ``(origin, t1, t2, normal)`` (m, unit vectors) of the grid's contact
        plane in the mesh; default the plane z = 0 with x, y, z.
    hats : HatBasis, optional
        Gather the loads on these hats (one solve per hat and side, for every
        grid) instead of loading each FE surface DOF under the grid (one
        solve per DOF: exact for the coarse FE, but as many solves as the
        grid covers DOFs).
    fold : bool
        The mesh is the quarter x >= 0, y >= 0 of a body symmetric about
        x = 0 and y = 0 (symmetry supports): each grid load and probe is
        taken at (|x|, |y|), a load with a quarter of its force (the four
        mirror images of the full grid's symmetric pressure load the quarter
        model's point once).
    same_load : bool
        Match on the FE's own loads (with ``hats``, unfolded): the far part is
        the FE's displacement at depth under the hat-spread loads minus the
        half-space's displacement at the same points under the same
        hat-spread loads (:func:`hat_half_space`), and the near part is
        Love's whole surface influence (:meth:`near_kernel`). The two terms
        of the far part then see one and the same load, so hats as wide as
        the coarse elements (which the FE resolves) replace the grid's
        pressure there without a mismatch: the error left is the difference
        of the finite-body corrections of the pressure and of its hat
        spread, second order in the hat spacing (the hats keep the force and
        its first moments). Without it the subtracted term is the grid
        pressure's, and the hats must stay below the depth.
    lattice : int, optional
        With ``hats``: evaluate each hat's displacement at depth on a lattice
        of this many points per hat spacing over the hats' span, once per
        depth, and interpolate it bilinearly to each grid's cells (instead of
        probing the FE under every cell of every grid: 10 s a force on a
        36k-DOF pair). At depth ``d`` the far field varies over lengths of
        ``d``; a lattice spacing ``h`` leaves an interpolation error of about
        ``(h / d)^2 / 8`` of its variation over the patch.
    """

    def __init__(self, mesh: FEMesh, free: np.ndarray, solve: Callable[[np.ndarray], np.ndarray],
                 sides, fold: bool = False, frame=None, hats: HatBasis | None = None,
                 same_load: bool = False, lattice: int | None = None) -> None:
        self.mesh, self.free, self.solve = mesh, np.asarray(free), solve
        if frame is None:
            frame = (np.zeros(3), np.eye(3)[0], np.eye(3)[1], np.eye(3)[2])
        self.frame = tuple(np.asarray(v, dtype=float) for v in frame)
        self.sides, self.fold = tuple(sides), fold
        n_dofs = 3 * int(mesh.point_dof.max() + 1)
        self._free_index = -np.ones(n_dofs, dtype=np.int64)
        self._free_index[self.free] = np.arange(len(self.free))
        self._responses: dict[int, np.ndarray] = {}   # DOF -> K^-1 column (free DOFs)
        self.solves = 0
        self.hats = hats
        if same_load and (hats is None or fold):
            raise ValueError("near field: same_load matching needs hats and an unfolded mesh "
                             f"(hats={hats is not None}, fold={fold})")
        self.same_load = same_load
        self._hat_responses: list[np.ndarray] | None = None
        self.lattice = lattice
        self._lattice_cache: dict[float, list[np.ndarray]] = {}

    def _points(self, x: np.ndarray, y: np.ndarray, side: Side) -> np.ndarray:
        o, t1, t2, n = self.frame
        z = side.height(x, y)
        return o + x[:, None] * t1 + y[:, None] * t2 + z[:, None] * n

    def _hat_solutions(self) -> list[np.ndarray]:
        """Per side, ``K_ff^-1`` of each hat's unit load (n_free, n_hats), solved once."""
        if self._hat_responses is None:
            hb = self.hats
            self._hat_responses = []
            for s in self.sides:
                x, y, phi = hat_samples(hb, s.exists)
                surf = probe_matrix(self.mesh, self._points(x, y, s), s.volume, self.frame[3])
                F = (surf[:, self.free].T @ phi).toarray()      # unit resultant per hat
                self._hat_responses.append(np.asarray(self.solve(F)).reshape(F.shape))
                self.solves += F.shape[1]
        return self._hat_responses

    def _hat_half_space(self, x: np.ndarray, y: np.ndarray, depth: float, side: Side
                        ) -> np.ndarray:
        return hat_half_space(self.hats, x, y, depth, side.youngs, side.poisson, side.exists)

    def near_kernel(self, grid: nf.Grid, depth: float):
        """The half-space part that goes with this far field: with ``same_load``
        the whole surface influence (the subtraction is in the far part), else
        :func:`layer_kernel`."""
        if self.same_load:
            e_star = nf.effective_modulus(self.sides[0].youngs, self.sides[0].poisson,
                                          self.sides[1].youngs, self.sides[1].poisson)
            return nf.surface_kernel(grid, e_star)
        return layer_kernel(grid, self.sides, depth)

    def _response(self, dofs: np.ndarray) -> np.ndarray:
        """Columns ``K_ff^-1 e_dof`` (n_free, len(dofs)), solved once per DOF and kept."""
        new = [d for d in dofs if d not in self._responses]
        if new:
            B = np.zeros((len(self.free), len(new)))
            B[self._free_index[new], np.arange(len(new))] = 1.0
            X = self.solve(B)
            X = X.reshape(len(self.free), len(new))
            for c, d in enumerate(new):
                self._responses[d] = X[:, c]
            self.solves += len(new)
        return np.stack([self._responses[d] for d in dofs], axis=1)

    def _lattice_values(self, depth: float) -> list[np.ndarray]:
        """Per side, each hat's far-field displacement at the lattice points (points, hats)."""
        if depth not in self._lattice_cache:
            lx, ly = _lattice_axes(self.hats, self.lattice)
            X, Y = np.meshgrid(lx, ly, indexing="ij")
            x, y = X.ravel(), Y.ravel()
            n = self.frame[3]
            values = []
            for s, Z in zip(self.sides, self._hat_solutions(), strict=True):
                deep = probe_matrix(self.mesh, self._points(x, y, s) + s.inward * depth * n,
                                    s.volume, n)
                A = np.asarray(deep[:, self.free] @ Z)
                if self.same_load:
                    A = A - self._hat_half_space(x, y, depth, s)
                values.append(A)
            self._lattice_cache[depth] = values
        return self._lattice_cache[depth]

    def _lattice_weights(self, x: np.ndarray, y: np.ndarray) -> sp.csr_matrix:
        """Bilinear interpolation (points, lattice points) from the far field's lattice."""
        lx, ly = _lattice_axes(self.hats, self.lattice)
        return HatBasis(self.hats.half_x, self.hats.half_y, len(lx), len(ly)).weights(x, y)

    def operator(self, grid: nf.Grid, depth: float) -> Callable[[np.ndarray], np.ndarray]:
        """Pressure (Pa, grid.shape) -> far-field displacement (m) at the grid points.

        Sum over the sides of the coarse FE's displacement (away from the
        other body) of the point at ``depth`` under each grid point.
        """
        X, Y = grid.centres()
        x, y = X.ravel(), Y.ravel()
        weight = grid.cell_area
        if self.fold:
            x, y, weight = np.abs(x), np.abs(y), weight / 4.0
        n = self.frame[3]
        parts = []
        if self.hats is not None and self.lattice is not None:
            Lt = (self.hats.weights(x, y).T * weight).tocsr()
            interp = self._lattice_weights(x, y)
            return _apply([(interp @ A, Lt) for A in self._lattice_values(depth)], grid)
        if self.hats is not None:
            Lt = (self.hats.weights(x, y).T * weight).tocsr()  # (hats, n): cell force split
            for s, Z in zip(self.sides, self._hat_solutions(), strict=True):
                deep = probe_matrix(self.mesh, self._points(x, y, s) + s.inward * depth * n,
                                    s.volume, n)
                A = np.asarray(deep[:, self.free] @ Z)
                if self.same_load:
                    A = A - self._hat_half_space(x, y, depth, s)
                parts.append((A, Lt))
            return _apply(parts, grid)
        for s in self.sides:
            at = self._points(x, y, s)
            surf = probe_matrix(self.mesh, at, s.volume, n)
            deep = probe_matrix(self.mesh, at + s.inward * depth * n, s.volume, n)
            surf, deep = surf[:, self.free].tocsc(), deep[:, self.free].tocsr()
            loaded = np.flatnonzero(np.diff(surf.indptr))       # free DOFs carrying load
            Z = self._response(self.free[loaded])
            A = np.asarray(deep @ Z)                            # (n, m): depth response
            Lt = surf[:, loaded].T.tocsr() * weight             # (m, n): loads
            parts.append((A, Lt))
        return _apply(parts, grid)


def _lattice_axes(hats: HatBasis, per_spacing: int) -> tuple[np.ndarray, np.ndarray]:
    mx, my = (hats.nx - 1) * per_spacing + 1, (hats.ny - 1) * per_spacing + 1
    return (np.linspace(-hats.half_x, hats.half_x, mx),
            np.linspace(-hats.half_y, hats.half_y, my))


def _apply(parts, grid: nf.Grid) -> Callable[[np.ndarray], np.ndarray]:
    """Pressure -> sum over the sides of ``A (Lt p)``, on the grid's shape."""
    def apply(p: np.ndarray) -> np.ndarray:
        q = p.ravel()
        w = np.zeros_like(q)
        for A, Lt in parts:
            w += A @ (Lt @ q)
        return w.reshape(grid.shape)
    return apply


def layer_kernel(grid: nf.Grid, sides, depth: float):
    """Half-space part of the combined compliance: Love's surface influence of
    both bodies minus each body's Boussinesq displacement at ``depth``."""
    e_star = nf.effective_modulus(sides[0].youngs, sides[0].poisson,
                                  sides[1].youngs, sides[1].poisson)
    parts = [nf.surface_kernel(grid, e_star)] + [
        nf.depth_kernel(grid, depth, s.youngs, s.poisson) for s in sides]

    def kernel(sx, sy):
        return parts[0](sx, sy) - parts[1](sx, sy) - parts[2](sx, sy)
    return kernel


#: Newton iterations of :func:`surface_height` (the map from surface parameters
#: to the contact plane is nearly affine over a patch: two or three suffice).
HEIGHT_ITERATIONS = 6
#: A plane point whose Newton iterate lies farther than this (m) from it has no
#: surface point over it (past the parametrisation's reach): its height is NaN.
HEIGHT_TOLERANCE = 1e-9


def surface_height(surface: Callable[[np.ndarray, np.ndarray], np.ndarray],
                   start: tuple[float, float], frame, step: tuple[float, float],
                   inside: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                   ) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Height over the contact plane of a parametric surface, from the surface itself.

    Parameters
    ----------
    surface : callable
        ``surface(s, t)`` -> points (n, 3) in the mesh frame (m), element-wise
        in the parameter arrays; evaluated past the flank's ends where asked.
    start : (float, float)
        Parameters of the contact point.
    frame : tuple
        ``(origin, t1, t2, normal)`` of the contact plane (m, unit vectors).
    step : (float, float)
        Parameter steps of the finite-difference Jacobian.
    inside : callable, optional
        ``inside(s, t)`` -> bool: where the surface exists (a flank's ends);
        the height is NaN elsewhere.

    Returns
    -------
    callable
        ``height(x, y)`` (m, along the normal) at the plane points (x, y): the
        surface point whose projection on the plane is (x, y), found by
        Newton's method on the parameters (the true flank, not its quadratic
        Taylor form and not the FE's facets).
    """
    o, t1, t2, n = (np.asarray(v, dtype=float) for v in frame)

    def plane(s, t):
        d = np.asarray(surface(s, t), dtype=float) - o
        return d @ t1, d @ t2, d @ n

    def height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        shape = np.broadcast(x, y).shape
        x, y = np.broadcast_to(x, shape).ravel(), np.broadcast_to(y, shape).ravel()
        s = np.full(x.shape, float(start[0]))
        t = np.full(x.shape, float(start[1]))
        for _ in range(HEIGHT_ITERATIONS):
            px, py, _ = plane(s, t)
            ax, ay, _ = plane(s + step[0], t)
            bx, by, _ = plane(s, t + step[1])
            j11, j21 = (ax - px) / step[0], (ay - py) / step[0]
            j12, j22 = (bx - px) / step[1], (by - py) / step[1]
            det = j11 * j22 - j12 * j21
            rx, ry = x - px, y - py
            s = s + (j22 * rx - j12 * ry) / det
            t = t + (-j21 * rx + j11 * ry) / det
        with np.errstate(invalid="ignore"):
            px, py, pz = plane(s, t)
            found = np.hypot(px - x, py - y) <= HEIGHT_TOLERANCE
        if not np.all(found):
            logger.debug("near field: %d of %d plane points have no surface point over "
                         "them (Newton off the parametrisation)", int(np.sum(~found)), found.size)
        pz = np.where(found, pz, np.nan)
        if inside is not None:
            pz = np.where(inside(s, t), pz, np.nan)
        return pz.reshape(shape)

    return height


def solve_combined(separation: np.ndarray, near: Callable[[np.ndarray], np.ndarray],
                   far: Callable[[np.ndarray], np.ndarray], force: float, cell_area: float,
                   start: np.ndarray | None = None,
                   allowed: np.ndarray | None = None) -> nf.PressureSolution:
    """Pressure under ``force`` (N) with compliance ``near + far``.

    ``near`` (symmetric, the half-space layer) goes to the Polonsky-Keer CG;
    ``far`` (the coarse FE, smooth over the patch, not symmetric) is iterated
    on: ``p_k+1 = CG(separation + far(p_k))``. The returned approach includes
    the far field. ``allowed``: the cells where both surfaces exist
    (:func:`fe_impact.contact.nearfield.solve_pressure`).
    """
    sol = nf.solve_pressure(separation, near, force, cell_area, start=start, allowed=allowed)
    shift = far(sol.pressure)
    for _ in range(MAX_FAR_ITERATIONS):
        sol = nf.solve_pressure(separation + shift, near, force, cell_area,
                                start=sol.pressure, allowed=allowed)
        new = far(sol.pressure)
        change = float(np.abs(new - shift).max())
        shift = new
        if change < FAR_TOLERANCE * abs(sol.approach):
            break
    else:
        logger.warning("near field: far-field iteration not converged (change %.2e m)", change)
    g = np.where(np.isfinite(separation), separation, 0.0) + shift + near(sol.pressure)
    on = sol.pressure > 0
    approach = float(np.mean(g[on]))
    return nf.PressureSolution(sol.pressure, approach, force, sol.iterations,
                               float(np.abs(g[on] - approach).max()))


def solve_combined_approach(separation, near, far, approach: float, cell_area: float,
                            force_guess: float, rtol: float = 1e-9,
                            allowed: np.ndarray | None = None) -> nf.PressureSolution:
    """:func:`solve_combined` under a given rigid approach (m): secant on log force."""
    def at(force, start=None):
        return solve_combined(separation, near, far, force, cell_area, start, allowed)
    return nf.secant_on_force(at, approach, force_guess, rtol)


def check_grid(grid: nf.Grid, patch_half_x: float, patch_half_y: float | None = None,
               key: str = "grid") -> None:
    """Refuse a grid coarser than the patch it must resolve, or smaller than the patch.

    At least :data:`MIN_CELLS_ACROSS` cells across the patch along each grid
    axis (half-widths ``patch_half_x``, ``patch_half_y`` in m; ``y`` defaults
    to ``x``) and a grid reaching past its edge.
    """
    halves = (patch_half_x, patch_half_x if patch_half_y is None else patch_half_y)
    for axis, cell, n, half in (("x", grid.dx, grid.nx, halves[0]),
                                ("y", grid.dy, grid.ny, halves[1])):
        across = 2.0 * half / cell
        if across < MIN_CELLS_ACROSS:
            raise ValueError(f"near field: {key} cell along {axis} {cell:.3g} m gives "
                             f"{across:.1f} cells across the patch (half-width {half:.3g} m); "
                             f"at least {MIN_CELLS_ACROSS} are needed: refine the grid")
        if n * cell / 2.0 < half:
            raise ValueError(f"near field: {key} half-width along {axis} {n * cell / 2:.3g} m "
                             f"is inside the patch (half-width {half:.3g} m): enlarge the grid")


def check_half_space(patch_half_width: float, radius: float, depth: float,
                     element: float, edge_distance: float = np.inf) -> None:
    """Refuse a contact the half-space layer does not describe (one line each).

    ``radius``: the smaller local radius of curvature of the two surfaces
    (m; a tip-edge rounding's radius); ``element``: the coarse element size at
    the contact; ``edge_distance``: from the patch centre to the nearest face
    edge (m).
    """
    ratio = patch_half_width / radius
    if ratio > MAX_PATCH_TO_RADIUS:
        raise ValueError(f"near field: patch half-width / radius of curvature = {ratio:.3g} "
                         f"(a = {patch_half_width:.3g} m, R = {radius:.3g} m); the half-space "
                         f"assumption needs at most {MAX_PATCH_TO_RADIUS}: use the refined FE")
    if depth > 0.5 * radius:
        raise ValueError(f"near field: matching depth {depth:.3g} m is above half the radius "
                         f"of curvature {radius:.3g} m: the layer above it is no half-space; "
                         "use a finer far-field mesh (smaller depth) or the refined FE")
    if depth < MIN_DEPTH_ELEMENTS * element:
        raise ValueError(f"near field: matching depth {depth:.3g} m holds "
                         f"{depth / element:.2g} coarse elements ({element:.3g} m); at least "
                         f"{MIN_DEPTH_ELEMENTS:g} are needed: deepen it or refine the far field")
    if edge_distance < depth + patch_half_width:
        raise ValueError(f"near field: patch edge {edge_distance - patch_half_width:.3g} m "
                         f"from a face edge, within the matching depth {depth:.3g} m: the "
                         "half-space layer would reach past the edge; use the refined FE")


def check_rounding(rounding_radius: float, grid: nf.Grid, key: str = "tip_edge_radius") -> None:
    """Refuse a rounding (m) that the grid cannot resolve: smaller than the cell
    across it times :data:`MIN_CELLS_ACROSS` (the rounding must hold the patch)."""
    cell = max(grid.dx, grid.dy)
    if rounding_radius < MIN_CELLS_ACROSS * cell:
        raise ValueError(f"near field: {key} = {rounding_radius:.3g} m is smaller than "
                         f"{MIN_CELLS_ACROSS} grid cells ({MIN_CELLS_ACROSS * cell:.3g} m): "
                         "refine the grid, or use the refined FE for this rounding")
