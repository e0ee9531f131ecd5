"""Read Gmsh meshes with named physical groups into a scikit-fem mesh.

The physical-group names are the interface: volumes are referred to by the
names of 3-D groups and surfaces by the names of 2-D groups. Tetrahedra may
be linear (P1) or quadratic (P2, isoparametric).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from fe_impact.errors import MeshError

logger = logging.getLogger(__name__)

UNITS = {"m": 1.0, "mm": 1e-3}
_VOLUME_TYPES = {"tetra": 1, "tetra10": 2}


@dataclass(frozen=True, eq=False)
class FEMesh:
    """A tetrahedral mesh with named volumes and surfaces, in metres.

    Attributes
    ----------
    skfem_mesh : skfem.MeshTet or skfem.MeshTet2
        The mesh scikit-fem assembles on.
    order : int
        1 for linear, 2 for quadratic tetrahedra.
    points : ndarray, shape (n_points, 3)
        Node coordinates as read (m); meshio's (VTK) node ordering.
    cells : ndarray, shape (n_elements, 4 or 10)
        Tetrahedra as point indices, VTK ordering.
    volumes : dict of str to ndarray
        Element indices of each volume group.
    surfaces : dict of str to ndarray, shape (n_faces, 3 or 6)
        Triangles of each surface group as point indices.
    point_dof : ndarray, shape (n_points,)
        Scalar scikit-fem DOF of each point; -1 for points not in any element.
    """

    skfem_mesh: object
    order: int
    points: np.ndarray
    cells: np.ndarray
    volumes: dict
    surfaces: dict
    point_dof: np.ndarray

    def volume(self, name: str) -> np.ndarray:
        """Element indices of volume group ``name``; a clear error if absent."""
        if name not in self.volumes:
            if name in self.surfaces:
                raise MeshError(f"group '{name}' is a surface, a volume group is needed; "
                                f"volume groups: {sorted(self.volumes)}")
            raise MeshError(f"no volume group '{name}' in the mesh; "
                            f"volume groups: {sorted(self.volumes)}")
        return self.volumes[name]

    def surface(self, name: str) -> np.ndarray:
        """Triangles of surface group ``name``; a clear error if absent."""
        if name not in self.surfaces:
            if name in self.volumes:
                raise MeshError(f"group '{name}' is a volume, a surface group is needed; "
                                f"surface groups: {sorted(self.surfaces)}")
            raise MeshError(f"no surface group '{name}' in the mesh; "
                            f"surface groups: {sorted(self.surfaces)}")
        return self.surfaces[name]

    def surface_points(self, name: str) -> np.ndarray:
        """Sorted unique point indices of a surface group."""
        return np.unique(self.surface(name))

    @property
    def n_points(self) -> int:
        return self.points.shape[0]


def load_mesh(path: str | Path, unit: str = "m") -> FEMesh:
    """Read a Gmsh ``.msh`` file with named physical groups.

    Parameters
    ----------
    path : str or Path
        The mesh file (MSH 4.1 or 2.2, as meshio reads it).
    unit : {"m", "mm"}
        Length unit of the coordinates in the file; converted to metres.
    """
    import meshio

    path = Path(path)
    if unit not in UNITS:
        raise MeshError(f"unknown length unit '{unit}'; pick one of {sorted(UNITS)}")
    if path.is_dir():
        raise MeshError(f"mesh file {path} is a directory; give a Gmsh .msh file")
    if not path.is_file():
        raise MeshError(f"mesh file not found: {path}")
    with open(path, "rb") as fh:
        head = fh.read(64).lstrip()
    if not head.startswith(b"$MeshFormat"):   # ASCII and binary MSH alike
        what = "is empty" if not head else "does not start with $MeshFormat"
        raise MeshError(f"mesh file {path} {what}: not a Gmsh MSH file")
    try:
        m = meshio.read(path, file_format="gmsh")
    except (Exception, SystemExit) as exc:  # meshio raises many kinds, even SystemExit
        raise MeshError(f"cannot read mesh file {path}: {exc}") from exc
    return mesh_from_meshio(m, scale=UNITS[unit], source=str(path))


def mesh_from_meshio(m, scale: float = 1.0, source: str = "mesh") -> FEMesh:
    """Build an :class:`FEMesh` from a meshio mesh carrying Gmsh physical names."""
    vtype = _single_type(m, _VOLUME_TYPES, "tetrahedra (tetra or tetra10)", source)
    stype = {1: "triangle", 2: "triangle6"}[_VOLUME_TYPES[vtype]]
    order = _VOLUME_TYPES[vtype]
    sets = m.cell_sets_dict
    if not sets:
        raise MeshError(f"no physical groups in {source}: name the volumes and surfaces "
                        "with Gmsh physical groups")
    points = np.ascontiguousarray(m.points[:, :3], dtype=float) * scale
    cells = np.ascontiguousarray(m.cells_dict[vtype], dtype=np.int64)
    volumes, surfaces = {}, {}
    for name, blocks in sets.items():
        if name.startswith("gmsh:"):
            continue
        if vtype in blocks:
            volumes[name] = np.asarray(blocks[vtype], dtype=np.int64)
        elif stype in blocks:
            surfaces[name] = m.cells_dict[stype][blocks[stype]].astype(np.int64)
    skm = _skfem_mesh(points, cells, order)
    point_dof = _match_points(points, cells, skm, order)
    logger.info("mesh %s: %d points, %d P%d tetrahedra, volumes %s, surfaces %s", source,
                len(points), len(cells), order, sorted(volumes), sorted(surfaces))
    return FEMesh(skm, order, points, cells, volumes, surfaces, point_dof)


def _single_type(m, types: dict, what: str, source: str) -> str:
    found = [t for t in m.cells_dict if t in types]
    if not found:
        raise MeshError(f"{source} has no {what}; cell types found: {sorted(m.cells_dict)}")
    if len(found) > 1:
        raise MeshError(f"{source} mixes {found}: use one element order")
    return found[0]


def _skfem_mesh(points: np.ndarray, cells: np.ndarray, order: int):
    from skfem import MeshTet, MeshTet2

    used = np.unique(cells[:, :4])
    if order == 1:
        # Compact the vertex numbering: scikit-fem wants no unused points.
        remap = -np.ones(len(points), dtype=np.int64)
        remap[used] = np.arange(len(used))
        return MeshTet(points[used].T.copy(), remap[cells].T.copy())
    # MeshTet2 takes the ten nodes in meshio/VTK order, like skfem.io.from_meshio.
    allp = np.unique(cells)
    remap = -np.ones(len(points), dtype=np.int64)
    remap[allp] = np.arange(len(allp))
    return MeshTet2(points[allp].T.copy(), remap[cells].T.copy())


def _match_points(points: np.ndarray, cells: np.ndarray, skm, order: int) -> np.ndarray:
    """Scalar DOF of each point, found by coordinates (robust to internal renumbering)."""
    from skfem import Basis, ElementTetP1, ElementTetP2

    basis = Basis(skm, ElementTetP2() if order == 2 else ElementTetP1(), intorder=1)
    tree = cKDTree(basis.doflocs.T)
    used = np.unique(cells)
    dist, idx = tree.query(points[used])
    size = np.ptp(points, axis=0).max()
    if dist.max() > 1e-9 * size:
        raise MeshError("mesh nodes do not match the element's nodes; is the quadratic "
                        "mesh curved in an unsupported way?")
    point_dof = -np.ones(len(points), dtype=np.int64)
    point_dof[used] = idx
    return point_dof
