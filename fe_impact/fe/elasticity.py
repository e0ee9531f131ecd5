"""Small-strain linear elasticity on P1/P2 tetrahedra.

scikit-fem gives the basis (quadrature, isoparametric map, DOF numbering);
the stiffness and mass are assembled by the compiled element loops of
:mod:`fe_impact.fe.assembly` (scikit-fem's ``asm`` is kept as their
reference: :func:`assemble_stiffness`, :func:`assemble_mass_skfem`).
Materials enter as per-element Lamé fields, so a multi-material model is
assembled in one pass. DOFs are scikit-fem's: vector DOF ``3 * s + c`` for
scalar DOF ``s`` and component ``c``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fe_impact.fe.assembly import element_data, mass_matrix, stiffness_matrix, von_mises_means
from fe_impact.fe.case import MaterialSpec
from fe_impact.fe.mesh import FEMesh

logger = logging.getLogger(__name__)


def lame_from_youngpoisson(E: float, nu: float) -> tuple[float, float]:
    """Lamé parameters (lambda, mu) in Pa from Young's modulus and Poisson's ratio."""
    return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))


@dataclass(frozen=True, eq=False)
class ElasticModel:
    """Assembled stiffness and per-element material data.

    Attributes
    ----------
    basis : skfem.Basis
        Vector P1 or P2 basis (quadrature exact for the stiffness of affine elements).
    K : scipy.sparse.csr_matrix, shape (n_dofs, n_dofs)
    material : ndarray of int, shape (n_elements,)
        Index into ``materials`` of each element.
    """

    mesh: FEMesh
    basis: object
    K: sp.csr_matrix
    materials: tuple[MaterialSpec, ...]
    material: np.ndarray
    elements: object = field(default=None, repr=False)   # fe.assembly.ElementData

    @property
    def n_dofs(self) -> int:
        return self.K.shape[0]

    def element_field(self, name: str) -> np.ndarray:
        """Per-element value of a material attribute, e.g. ``"density"``."""
        vals = np.array([getattr(m, name) for m in self.materials])
        return vals[self.material]

    def point_values(self, u: np.ndarray) -> np.ndarray:
        """Nodal (n_points, 3) displacement from a DOF vector (0 at unused points)."""
        out = np.zeros((self.mesh.n_points, 3))
        used = self.mesh.point_dof >= 0
        out[used] = u.reshape(-1, 3)[self.mesh.point_dof[used]]
        return out


def element_materials(mesh: FEMesh, materials: tuple[MaterialSpec, ...]) -> np.ndarray:
    """Material index of every element (-1 where a volume has no material)."""
    mat = -np.ones(len(mesh.cells), dtype=np.int64)
    for i, m in enumerate(materials):
        for v in m.volumes:
            mat[mesh.volume(v)] = i
    return mat


def stiffness_intorder(order: int) -> int:
    """The model's quadrature order: stiffness integrands are polynomials of degree
    2(p-1), exact for affine elements."""
    return max(2 * (order - 1), 1)


def build_model(mesh: FEMesh, materials: tuple[MaterialSpec, ...]) -> ElasticModel:
    """Assemble the stiffness matrix of the whole mesh."""
    from skfem import Basis, ElementTetP1, ElementTetP2, ElementVector

    elem = ElementTetP2() if mesh.order == 2 else ElementTetP1()
    intorder = stiffness_intorder(mesh.order)
    basis = Basis(mesh.skfem_mesh, ElementVector(elem), intorder=intorder)
    mat = element_materials(mesh, materials)
    if np.any(mat < 0):
        raise ValueError("some elements have no material")
    elements = element_data(basis)
    lam_mu = _lame(materials)[mat]
    K = stiffness_matrix(elements, lam_mu[:, 0], lam_mu[:, 1], intorder)
    logger.info("assembled K: %d DOFs, %d nonzeros", K.shape[0], K.nnz)
    return ElasticModel(mesh, basis, K, materials, mat, elements)


def _lame(materials) -> np.ndarray:
    """(lambda, mu) of each material (Pa), shape (n_materials, 2)."""
    return np.array([lame_from_youngpoisson(m.youngs_modulus, m.poisson_ratio)
                     for m in materials])


def assemble_stiffness(basis, mat: np.ndarray, materials) -> sp.csr_matrix:
    """Stiffness matrix for per-element materials by scikit-fem's ``asm``.

    The reference for :func:`fe_impact.fe.assembly.stiffness_matrix`, which
    :func:`build_model` uses (the same matrix to round-off, about six times
    faster).
    """
    from skfem import BilinearForm, asm
    from skfem.helpers import ddot, sym_grad, trace

    lam_mu = _lame(materials)
    nqp = basis.X.shape[1]
    lam = np.repeat(lam_mu[mat, 0][:, None], nqp, axis=1)
    mu = np.repeat(lam_mu[mat, 1][:, None], nqp, axis=1)

    @BilinearForm
    def stiffness(u, v, w):
        eu, ev = sym_grad(u), sym_grad(v)
        return 2.0 * w.mu * ddot(eu, ev) + w.lam * trace(eu) * trace(ev)

    return asm(stiffness, basis, lam=lam, mu=mu).tocsr()


def von_mises(model: ElasticModel, u: np.ndarray) -> np.ndarray:
    """Element-mean von Mises stress (Pa) of the DOF vector ``u``; shape (n_elements,).

    The compiled element loop (:func:`~fe_impact.fe.assembly.von_mises_means`) on the
    basis' quadrature; :func:`von_mises_skfem` where the model has no element data.
    """
    if model.elements is None:
        return von_mises_skfem(model, u)
    mu = np.array([lame_from_youngpoisson(m.youngs_modulus, m.poisson_ratio)[1]
                   for m in model.materials])[model.material]
    return von_mises_means(model.elements, u, mu, stiffness_intorder(model.mesh.order))


def von_mises_skfem(model: ElasticModel, u: np.ndarray) -> np.ndarray:
    """:func:`von_mises` through scikit-fem's interpolation (its reference)."""
    lam_mu = np.array([lame_from_youngpoisson(m.youngs_modulus, m.poisson_ratio)
                       for m in model.materials])[model.material]
    grad = model.basis.interpolate(u).grad  # (3, 3, ne, nq)
    eps = 0.5 * (grad + np.swapaxes(grad, 0, 1))
    tr = np.einsum("iiek->ek", eps)
    dev = eps - np.eye(3)[:, :, None, None] * tr / 3.0
    # sigma = 2 mu eps + lam tr I; deviator of sigma = 2 mu dev(eps)
    s2 = np.einsum("ijek,ijek->ek", dev, dev)
    vm = np.sqrt(1.5 * s2) * 2.0 * lam_mu[:, 1][:, None]
    dx = model.basis.dx
    return (vm * dx).sum(axis=1) / dx.sum(axis=1)


def assemble_mass(model: ElasticModel) -> sp.csr_matrix:
    """Consistent mass matrix ``int rho u . v`` (kg), exact for affine elements."""
    elements = model.elements if model.elements is not None else element_data(model.basis)
    return mass_matrix(elements, model.element_field("density"), 2 * model.mesh.order)


def assemble_mass_skfem(model: ElasticModel) -> sp.csr_matrix:
    """:func:`assemble_mass` by scikit-fem's ``asm`` (its reference, about six times slower)."""
    from skfem import Basis, BilinearForm, ElementTetP1, ElementTetP2, ElementVector, asm
    from skfem.helpers import dot

    order = model.mesh.order
    elem = ElementTetP2() if order == 2 else ElementTetP1()
    basis = Basis(model.mesh.skfem_mesh, ElementVector(elem), intorder=2 * order)
    rho = np.repeat(model.element_field("density")[:, None], basis.X.shape[1], axis=1)

    @BilinearForm
    def mass(u, v, w):
        return w.rho * dot(u, v)

    return asm(mass, basis, rho=rho).tocsr()


def lumped_mass(M: sp.csr_matrix) -> np.ndarray:
    """HRZ lumping: the diagonal of ``M`` scaled to conserve each component's mass.

    For affine elements of one type, the element diagonals are the same
    fraction of the element mass everywhere, so scaling the assembled diagonal
    is element-wise HRZ (Hinton, Rock and Zienkiewicz 1976). All entries are
    positive for P1 and P2 tetrahedra, unlike row sums for P2, whose vertex
    entries are negative.
    """
    diag = M.diagonal()
    out = np.empty_like(diag)
    for c in range(3):
        rows = slice(c, None, 3)
        total = M[rows][:, rows].sum()
        out[rows] = diag[rows] * (total / diag[rows].sum())
    return out
