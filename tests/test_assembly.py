"""The compiled assembly against scikit-fem's ``asm`` (its independent reference)."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from fe_impact.fe import elasticity as el
from fe_impact.fe.case import MaterialSpec
from fe_impact.fe.mesh import mesh_from_meshio

STEEL = MaterialSpec(("a",), 212e9, 0.289, 7860.0)
SOFT = MaterialSpec(("b",), 70e9, 0.33, 2700.0)


def two_material_box(order: int, curved: bool):
    """A 3 x 3 x 3 unit box of tetrahedra in two volumes; P2 mid-edge nodes moved
    off the chords (curved, isoparametric elements) if ``curved``."""
    from skfem import MeshTet

    m = MeshTet.init_tensor(*(np.linspace(0.0, 1.0, 4),) * 3)
    p, t = m.p.T, m.t.T
    half = p[t].mean(axis=1)[:, 0] < 0.5
    sets = {"a": [np.flatnonzero(half)], "b": [np.flatnonzero(~half)]}
    if order == 1:
        return mesh_from_meshio(meshio.Mesh(p, [("tetra", t)], cell_sets=sets))
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]  # VTK tetra10 order
    pairs = np.sort(np.stack([t[:, [a, b]] for a, b in edges], axis=1), axis=2)
    uniq, inv = np.unique(pairs.reshape(-1, 2), axis=0, return_inverse=True)
    mid = 0.5 * (p[uniq[:, 0]] + p[uniq[:, 1]])
    if curved:
        mid += 0.02 * np.sin(7.0 * mid[:, [1, 2, 0]])   # a tenth of the 0.33 edge at most
    t10 = np.hstack([t, len(p) + inv.reshape(-1, 6)])
    return mesh_from_meshio(meshio.Mesh(np.vstack([p, mid]), [("tetra10", t10)],
                                        cell_sets=sets))


@pytest.mark.parametrize(("order", "curved"), [(1, False), (2, False), (2, True)])
def test_matrices_equal_scikit_fem(order, curved):
    mesh = two_material_box(order, curved)
    model = el.build_model(mesh, (STEEL, SOFT))
    K_ref = el.assemble_stiffness(model.basis, model.material, model.materials)
    M, M_ref = el.assemble_mass(model), el.assemble_mass_skfem(model)
    # Same quadrature and map, sums in another order: each entry is a sum of at
    # most ~20 elements x 4-11 points, so round-off of a few 1e-16 of the
    # largest entry; 1e-13 leaves room and is far below any modelling error.
    for A, R in ((model.K, K_ref), (M, M_ref)):
        assert abs(A - R).max() <= 1e-13 * abs(R).max()
        # no stored entry where scikit-fem has none, but for round-off zeros
        outside = A - A.multiply(R.astype(bool))
        assert outside.nnz == 0 or abs(outside).max() <= 1e-13 * abs(R).max()
        assert A.nnz >= 0.999 * R.nnz


@pytest.mark.parametrize(("order", "curved"), [(1, False), (2, False), (2, True)])
def test_von_mises_equals_scikit_fem(order, curved):
    """The compiled element means of the von Mises stress against scikit-fem's
    interpolation, for a smooth displacement with every strain component."""
    mesh = two_material_box(order, curved)
    model = el.build_model(mesh, (STEEL, SOFT))
    x = mesh.points[mesh.point_dof >= 0]
    u = np.zeros(model.n_dofs)
    dofs = 3 * mesh.point_dof[mesh.point_dof >= 0]
    for c in range(3):
        u[dofs + c] = 1e-4 * np.sin(2.0 * x[:, c] + x[:, (c + 1) % 3]) * (1.0 + x[:, (c + 2) % 3])
    vm, ref = el.von_mises(model, u), el.von_mises_skfem(model, u)
    # the same quadrature and map, sums in another order: a few ulps of each mean
    np.testing.assert_allclose(vm, ref, rtol=1e-12)
    assert ref.min() > 0.0
