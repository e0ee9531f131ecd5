"""Degrees of freedom: the DOFs of mesh points and surfaces, supports and rigid bodies.

DOF ``3 * mesh.point_dof[p] + c`` is component ``c`` (x, y, z) of point
``p``. The transient solver's unknowns are reduced coordinates ``z`` with
``u = T z`` (:class:`Kinematics`): supported components are zero and the nodes
of a rigid body's surface follow its translation or small rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fe_impact.errors import CaseError
from fe_impact.fe.case import Case, RigidBodySpec
from fe_impact.fe.elasticity import lumped_mass
from fe_impact.fe.mesh import FEMesh


def point_dofs(mesh: FEMesh, points: np.ndarray) -> np.ndarray:
    """The three DOFs of each of ``points``, point by point: shape (3 n,)."""
    return (3 * mesh.point_dof[points][:, None] + np.arange(3)).ravel()


def surface_dofs(mesh: FEMesh, surface: str, component: int) -> np.ndarray:
    """DOFs of one component (0, 1, 2: x, y, z) of a surface group's points."""
    return 3 * mesh.point_dof[mesh.surface_points(surface)] + component


def supported(case: Case, mesh: FEMesh, n_dofs: int) -> np.ndarray:
    """Bool mask of the DOFs that ``[[supports]]`` hold at zero."""
    fixed = np.zeros(n_dofs, dtype=bool)
    for s in case.supports:
        for c in s.fix:
            fixed[surface_dofs(mesh, s.surface, c)] = True
    return fixed


def rigid_mode(spec: RigidBodySpec, x: np.ndarray) -> np.ndarray:
    """Displacement of points ``x`` (n, 3) per unit rigid-body coordinate."""
    d = np.asarray(spec.direction)
    if spec.motion == "translation":
        return np.broadcast_to(d, x.shape).copy()
    return np.cross(d, x - np.asarray(spec.point))


@dataclass(frozen=True, eq=False)
class Kinematics:
    """Map ``u = T z`` between reduced coordinates and all DOFs.

    Attributes
    ----------
    T : csr_matrix, shape (n_dofs, n_free + n_rigid)
    free : DOFs that are unknowns of their own (columns ``0..n_free-1``)
    fixed : DOFs held at zero by supports
    rigid : the rigid-body specs; body ``k`` is column ``n_free + k``
    """

    T: sp.csr_matrix
    free: np.ndarray
    fixed: np.ndarray
    rigid: tuple[RigidBodySpec, ...]

    @property
    def n(self) -> int:
        return self.T.shape[1]

    @property
    def n_free(self) -> int:
        return len(self.free)

    @classmethod
    def build(cls, case: Case, mesh: FEMesh, n_dofs: int) -> Kinematics:
        fixed = supported(case, mesh, n_dofs)
        tied = -np.ones(n_dofs, dtype=np.int64)
        coef = np.zeros(n_dofs)
        for k in range(len(case.rigid_bodies)):
            dofs, c = _rigid_body_dofs(case, mesh, k, tied, fixed)
            tied[dofs] = k
            coef[dofs] = c
        is_tied = tied >= 0
        fixed &= ~is_tied
        free = np.flatnonzero(~fixed & ~is_tied)
        n_free = len(free)
        rows = np.concatenate([free, np.flatnonzero(is_tied)])
        cols = np.concatenate([np.arange(n_free), n_free + tied[is_tied]])
        vals = np.concatenate([np.ones(n_free), coef[is_tied]])
        T = sp.csr_matrix((vals, (rows, cols)), shape=(n_dofs, n_free + len(case.rigid_bodies)))
        return cls(T, free, np.flatnonzero(fixed), case.rigid_bodies)

    def reduce(self, A: sp.spmatrix) -> sp.csr_matrix:
        """``T^T A T``: a matrix on all DOFs in reduced coordinates."""
        return (self.T.T @ A @ self.T).tocsr()

    def mass(self, M: sp.spmatrix, lumped: bool = False
             ) -> tuple[sp.csr_matrix, np.ndarray | None]:
        """Reduced mass ``T^T M T + diag(inertia)`` with the rigid bodies' inertias.

        ``lumped``: from the HRZ-lumped ``M`` (diagonal; its diagonal is
        returned too, else None).
        """
        inertia = np.zeros(self.n)
        inertia[self.n_free:] = [b.inertia for b in self.rigid]
        T = self.T
        if lumped:
            m = np.asarray(T.T.multiply(T.T) @ lumped_mass(M)).ravel() + inertia
            return sp.diags(m).tocsr(), m
        return (T.T @ M @ T + sp.diags(inertia)).tocsr(), None


def _rigid_body_dofs(case: Case, mesh: FEMesh, k: int, tied: np.ndarray,
                     fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """DOFs of rigid body ``k``'s surface and their coefficients in its mode.

    Refuses a node already tied to another body and a support the motion
    would move.
    """
    body = case.rigid_bodies[k]
    pts = mesh.surface_points(body.surface)
    dofs = point_dofs(mesh, pts)
    clash = tied[dofs] >= 0
    if clash.any():
        other = case.rigid_bodies[int(tied[dofs][clash][0])].surface
        raise CaseError(f"{case.path.name}: rigid_bodies[{k}] surface '{body.surface}' "
                        f"shares {int(clash.sum() // 3) or 1} nodes with '{other}'; "
                        "a node can follow one rigid body only")
    c = rigid_mode(body, mesh.points[pts]).ravel()
    scale = np.abs(c).max(initial=0.0)
    moved = fixed[dofs] & (np.abs(c) > 1e-9 * max(scale, 1e-300))
    if moved.any():
        raise CaseError(f"{case.path.name}: rigid_bodies[{k}] ({body.motion} of "
                        f"'{body.surface}') moves {int(moved.sum())} DOFs that "
                        "[[supports]] fix; remove the support or change the motion")
    return dofs, c
