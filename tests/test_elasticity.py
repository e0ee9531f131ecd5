"""Elasticity without contact: patch tests and observed convergence order."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from fe_impact.fe.case import MaterialSpec
from fe_impact.fe.elasticity import build_model
from fe_impact.fe.mesh import mesh_from_meshio

STEEL = MaterialSpec(("body",), 212e9, 0.289, 7860.0)


def box_mesh(n: int, order: int = 1):
    """Unit cube split into tetrahedra; P2 gets straight mid-edge nodes."""
    from skfem import MeshTet

    m = MeshTet.init_tensor(*(np.linspace(0.0, 1.0, n + 1),) * 3)
    p, t = m.p.T, m.t.T
    if order == 1:
        mm = meshio.Mesh(p, [("tetra", t)], cell_sets={"body": [np.arange(len(t))]})
        return mesh_from_meshio(mm)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]  # VTK tetra10 order
    pairs = np.sort(np.stack([t[:, [a, b]] for a, b in edges], axis=1), axis=2)
    uniq, inv = np.unique(pairs.reshape(-1, 2), axis=0, return_inverse=True)
    mid = 0.5 * (p[uniq[:, 0]] + p[uniq[:, 1]])
    t10 = np.hstack([t, len(p) + inv.reshape(-1, 6)])
    mm = meshio.Mesh(np.vstack([p, mid]), [("tetra10", t10)],
                     cell_sets={"body": [np.arange(len(t))]})
    return mesh_from_meshio(mm)


def solve_dirichlet(mesh, exact):
    """Prescribe ``exact`` on the boundary, solve the interior; nodal u (n_points, 3)."""
    from scipy.sparse.linalg import spsolve

    model = build_model(mesh, (STEEL,))
    x = model.basis.doflocs  # (3, n_dofs): DOF locations, component-interleaved
    u_ex = np.array([exact(x[:, i::3])[i] for i in range(3)]).T.ravel()
    bnd = model.basis.get_dofs().all()
    free = np.setdiff1d(np.arange(model.n_dofs), bnd)
    u = u_ex.copy()
    K = model.K
    u[free] = spsolve(K[free][:, free].tocsc(), -K[free][:, bnd] @ u_ex[bnd])
    return model, u, u_ex


def linear_field(x):
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.25, 0.2, 0.7]]) * 1e-3
    return A @ x + np.array([1e-4, -2e-4, 3e-4])[:, None]


def bending_field(x, kappa=1e-3, nu=STEEL.poisson_ratio):
    """Pure bending: sigma_xx = E kappa z, all other stresses zero (exact, no body force)."""
    X, Y, Z = x
    return kappa * np.array([X * Z, -nu * Y * Z, -(X ** 2 + nu * (Z ** 2 - Y ** 2)) / 2])


@pytest.mark.parametrize("order", [1, 2])
def test_patch_linear_field(order):
    # A linear field lies in both spaces: reproduced to round-off (1e-10 of its size).
    _, u, u_ex = solve_dirichlet(box_mesh(3, order), linear_field)
    assert np.abs(u - u_ex).max() < 1e-10 * np.abs(u_ex).max()


def test_p2_reproduces_quadratic_bending():
    # The bending solution is quadratic: P2 reproduces it exactly (round-off).
    _, u, u_ex = solve_dirichlet(box_mesh(2, 2), bending_field)
    assert np.abs(u - u_ex).max() < 1e-9 * np.abs(u_ex).max()


def l2_error(model, u):
    uh = np.asarray(model.basis.interpolate(u))  # (3, ne, nq)
    ue = bending_field(model.basis.mapping.F(model.basis.X))
    return np.sqrt(np.sum(((uh - ue) ** 2).sum(axis=0) * model.basis.dx))


def test_p1_converges_second_order_in_l2():
    # Observed order of the L2 error for P1 on the bending solution: theory 2.
    hs, errs = [], []
    for n in (2, 4, 8):
        model, u, _ = solve_dirichlet(box_mesh(n, 1), bending_field)
        hs.append(1.0 / n)
        errs.append(l2_error(model, u))
    rate = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert rate > 1.8
    # Ceiling on the finest error: 1% of the field's size (kappa/2 ~ 5e-4).
    assert errs[-1] < 5e-6


def test_stiffness_symmetric_and_rigid_modes_free():
    model = build_model(box_mesh(2, 2), (STEEL,))
    K = model.K
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()
    # Rigid translation and small rotation produce no force (to round-off).
    x = model.basis.doflocs
    t = np.tile([1.0, 0.0, 0.0], model.n_dofs // 3)
    rot = np.array([-x[1, 0::3], x[0, 0::3], 0 * x[0, 0::3]]).T.ravel()
    for mode in (t, rot):
        assert np.abs(K @ mode).max() < 1e-8 * abs(K).max()
