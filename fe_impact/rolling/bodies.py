"""The two gears' coordinates and constant matrices from the sector mesh.

:func:`sector_bodies` reads ``sectors.msh`` (:mod:`fe_impact.rolling.sectors`),
assembles each sector's stiffness and consistent mass, ties the hub to the
rotor and adds the rotor coordinate (:class:`~fe_impact.rolling.model.Body`):
``u = E u_free + psi theta`` for the absolute small displacement of the sector,
``psi`` its rigid rotation mode in the drive sense, so that ``u_free`` is the
displacement relative to the turning frame and the reduced matrices are
``[E psi]^T M [E psi]`` (the rotor's remaining inertia ``J - psi^T M psi`` on
its diagonal) and ``[E psi]^T K [E psi]`` (``K psi = 0``: a rigid rotation
strains nothing).
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from fe_impact.errors import CaseError
from fe_impact.rolling.model import Body
from fe_impact.rolling.sectors import SECTOR_TEETH, tooth_range

logger = logging.getLogger(__name__)

__all__ = ["sector_bodies"]


def _body(name: str, mesh, K, M, volume: str, hub: str, flanks: list[str], inertia: float,
          axis_point: np.ndarray, axis: np.ndarray) -> Body:
    cells = mesh.cells[mesh.volume(volume)]
    nodes = np.unique(cells)
    hub_nodes = np.intersect1d(mesh.surface_points(hub), nodes)
    free_nodes = np.setdiff1d(nodes, hub_nodes)
    dofs_all = (3 * mesh.point_dof[nodes][:, None] + np.arange(3)).ravel()
    free = (3 * mesh.point_dof[free_nodes][:, None] + np.arange(3)).ravel()
    n_mesh = K.shape[0]
    x = mesh.points[nodes]
    psi = np.zeros(n_mesh)
    psi[dofs_all] = np.cross(-axis, x - axis_point).ravel()   # drive sense: about -axis
    n_free = len(free)
    E = sp.csr_matrix((np.ones(n_free), (free, np.arange(n_free))), shape=(n_mesh, n_free))
    T = sp.hstack([E, sp.csr_matrix(psi[:, None])]).tocsr()
    Mb = (T.T @ M @ T).tolil()
    own = float(psi @ (M @ psi))
    rest = inertia - own
    if rest <= 0.0:
        raise CaseError(f"{name}: the sector's own inertia {own:.4g} kg m^2 exceeds the gear "
                        f"set's {inertia:.4g} kg m^2; give the gear its real inertia")
    Mb[n_free, n_free] = inertia
    Kb = (T.T @ K @ T).tolil()
    Kb[n_free, :] = 0.0
    Kb[:, n_free] = 0.0
    index = -np.ones(n_mesh, dtype=np.int64)
    index[free] = np.arange(n_free)
    tris = np.concatenate([mesh.surface(g)[:, :3] for g in flanks])
    corner_dofs = index[3 * mesh.point_dof[tris][..., None] + np.arange(3)]
    if np.any(corner_dofs < 0):
        raise CaseError(f"{name}: a flank node lies on the hub")
    points = mesh.points
    body = Body(name, Mb.tocsr(), Kb.tocsr(), axis_point, axis, points=points,
                triangles=tris, tri_dofs=corner_dofs, n_dofs_mesh=n_mesh, free_dofs=free)
    body.tree = cKDTree(points[tris].mean(axis=1))
    body.cells = cells
    node_dofs = -np.ones((len(points), 3), dtype=np.int64)
    node_dofs[nodes] = index[3 * mesh.point_dof[nodes][:, None] + np.arange(3)]
    body.node_dofs = node_dofs
    corners = points[tris]
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    body.flank_size = float(np.median(edges))
    # centrifugal load per unit omega^2 in the turning frame: the consistent mass times
    # the points' distance vector from the axis (the rotor's entry is psi^T M r = 0)
    radial = np.zeros(n_mesh)
    rel = x - axis_point
    radial[dofs_all] = (rel - np.outer(rel @ axis, axis)).ravel()
    body.centrifugal = np.append((M @ radial)[free], 0.0)
    body.own_inertia = own
    body.mass = _mass(M, dofs_all)
    logger.info("%s: %d elastic DOFs, sector inertia %.4g of %.4g kg m^2", name, n_free, own,
                inertia)
    return body


def _mass(M, dofs: np.ndarray) -> float:
    """Mass of the DOFs' body [kg] (x-translation energy of the consistent mass)."""
    e = np.zeros(M.shape[0])
    e[dofs[0::3]] = 1.0
    return float(e @ (M @ e))


def sector_bodies(mesh_path, gearset, stage: int, stiffen: float = 1.0,
                  teeth: int = SECTOR_TEETH) -> tuple[Body, Body]:
    """Pinion and face-gear :class:`~fe_impact.rolling.model.Body` of ``sectors.msh``.

    ``stiffen`` multiplies Young's modulus (the kinematic check's stiffened material);
    ``teeth``: the sectors' teeth each, as the mesh was built with.
    """
    from fe_impact.fe.case import MaterialSpec
    from fe_impact.fe.elasticity import assemble_mass, build_model
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.gears.tca import GearPair

    mat = gearset.material
    mesh = load_mesh(mesh_path, unit="mm")
    spec = MaterialSpec(("pinion", "face_gear"), float(mat.youngs_modulus) * stiffen,
                        float(mat.poisson_ratio), float(mat.density))
    model = build_model(mesh, (spec,))
    K, M = model.K, assemble_mass(model)
    pair = GearPair.from_gearset(gearset, stage)
    teeth = tooth_range(teeth)
    (cp, ap), (cf, af) = pair.pinion_axis, pair.face_axis
    pinion = _body("pinion", mesh, K, M, "pinion", "pinion_hub",
                   [f"pinion_{s}_{k}" for s in ("drive", "coast") for k in teeth],
                   gearset.pinion.inertia, cp, ap)
    face = _body("face_gear", mesh, K, M, "face_gear", "face_hub",
                 [f"face_{s}_{k}" for s in ("drive", "coast") for k in teeth],
                 gearset.stages[stage - 1].inertia, cf, af)
    for body in (pinion, face):
        body.model = model       # for the stress of the PVD frames
    return pinion, face
