"""J2 plasticity: return mapping against closed forms, the zone's plastic force
against the assembled stiffness, dissipation on a uniaxial cycle, tangents
against finite differences."""

from __future__ import annotations

import math

import meshio
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from fe_impact.fe.case import MaterialSpec
from fe_impact.fe.elasticity import build_model, von_mises
from fe_impact.fe.mesh import mesh_from_meshio
from fe_impact.fe.plasticity import (
    PlasticZone,
    consistent_tangent,
    elements_near,
    radial_return,
    solve_fixed_point,
    solve_newton,
    tensor_to_voigt,
    voigt_to_tensor,
)

E, NU, Y, H = 212e9, 0.289, 835e6, 10e9
E_T = E * H / (E + H)                       # uniaxial elastic-plastic tangent
MU = E / (2 * (1 + NU))
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
STEEL = MaterialSpec(("body",), E, NU, 7860.0, yield_strength=Y, hardening_modulus=H)
ELASTIC = MaterialSpec(("body",), E, NU, 7860.0)


def elastic_voigt() -> np.ndarray:
    C = np.zeros((6, 6))
    C[:3, :3] = LAM
    C[:3, :3] += 2 * MU * np.eye(3)
    C[3:, 3:] = MU * np.eye(3)
    return C


def box_mesh(n: int, order: int, size=(1.0, 1.0, 1.0)):
    """Box [0, size] split into tetrahedra; P2 gets straight mid-edge nodes."""
    from skfem import MeshTet

    m = MeshTet.init_tensor(*(np.linspace(0.0, s, n + 1) for s in size))
    p, t = m.p.T, m.t.T
    if order == 1:
        return mesh_from_meshio(meshio.Mesh(p, [("tetra", t)],
                                            cell_sets={"body": [np.arange(len(t))]}))
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]  # VTK tetra10 order
    pairs = np.sort(np.stack([t[:, [a, b]] for a, b in edges], axis=1), axis=2)
    uniq, inv = np.unique(pairs.reshape(-1, 2), axis=0, return_inverse=True)
    mid = 0.5 * (p[uniq[:, 0]] + p[uniq[:, 1]])
    t10 = np.hstack([t, len(p) + inv.reshape(-1, 6)])
    return mesh_from_meshio(meshio.Mesh(np.vstack([p, mid]), [("tetra10", t10)],
                                        cell_sets={"body": [np.arange(len(t))]}))


def linear_field(model, A: np.ndarray) -> np.ndarray:
    """DOF vector of u(x) = A x."""
    x = model.basis.doflocs                     # (3, n_dofs)
    c = np.arange(model.n_dofs) % 3
    return np.einsum("ij,jn->in", A, x)[c, np.arange(model.n_dofs)]


def uniaxial_path(eps_xx: np.ndarray, eps_p=None, alpha=None):
    """Drive one point through axial strains with the lateral stresses held at zero.

    Lateral strains are found by Newton iteration with the consistent tangent;
    returns axial stress, lateral strain, the state after each increment and
    the Newton iterations used.
    """
    ep = np.zeros((1, 6)) if eps_p is None else eps_p.copy()
    al = np.zeros(1) if alpha is None else alpha.copy()
    lat = 0.0
    out = []
    iters = []
    for exx in eps_xx:
        n_it = 0
        while True:
            n_it += 1
            eps = np.array([[exx, lat, lat, 0.0, 0.0, 0.0]])
            s, ep1, al1, _ = radial_return(eps, ep, al, E, NU, Y, H)
            if abs(s[0, 1]) < 1e-7 * Y:
                break
            assert n_it < 30, "lateral Newton did not converge"
            C = consistent_tangent(eps, ep, al, E, NU, Y, H)[0]
            lat -= s[0, 1] / (C[1, 1] + C[1, 2])
        iters.append(n_it)
        ep, al = ep1, al1
        out.append((s[0].copy(), lat, ep.copy(), al.copy()))
    return out, ep, al, max(iters)


def analytic_uniaxial(eps: np.ndarray) -> np.ndarray:
    ey = Y / E
    return np.where(eps <= ey, E * eps, Y + E_T * (eps - ey))


# -- material point ------------------------------------------------------------------------


def test_uniaxial_path_matches_bilinear_law():
    # Truth: sigma = Y + E_t (eps - Y/E). Radial return is exact for proportional
    # stress paths whatever the increment, so the only error is the lateral
    # Newton tolerance (|sigma_yy| < 1e-7 Y -> sigma_xx off by ~1e-7 Y at most).
    eps = np.linspace(0.0, 6 * Y / E, 8)[1:]   # the first plastic step crosses Y/E
    out, ep, al, iters = uniaxial_path(eps)
    sxx = np.array([o[0][0] for o in out])
    np.testing.assert_allclose(sxx, analytic_uniaxial(eps), rtol=0, atol=1e-6 * Y)
    for o in out:   # uniaxial stress state
        np.testing.assert_allclose(o[0][1:], 0.0, atol=1e-6 * Y)
    # plastic strain: axial eps - sigma/E, lateral half of it (incompressible)
    ep_xx = eps[-1] - sxx[-1] / E
    np.testing.assert_allclose(ep[0], [ep_xx, -ep_xx / 2, -ep_xx / 2, 0, 0, 0],
                               rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(al[0], ep_xx, rtol=1e-6)
    assert iters <= 4   # quadratic convergence of Newton: the tangent is consistent


def test_elastic_unloading_and_reverse_yield():
    eps_max = 4 * Y / E
    _, ep, al, _ = uniaxial_path(np.array([eps_max]))
    s_max = Y + E_T * (eps_max - Y / E)
    # unloading by less than 2 (Y + H alpha) / E stays elastic with slope E
    d = np.array([0.5, 1.0, 1.9]) * (s_max / E)
    out, ep2, al2, _ = uniaxial_path(eps_max - d, ep, al)
    np.testing.assert_allclose([o[0][0] for o in out], s_max - E * d, rtol=1e-9,
                               atol=1e-6 * Y)
    np.testing.assert_array_equal(ep2, ep)
    np.testing.assert_array_equal(al2, al)
    # general multiaxial unloading: stress change C : d eps, state unchanged
    rng = np.random.default_rng(1)
    eps = np.array([[eps_max, -0.3 * eps_max, -0.3 * eps_max, 0.0, 0.0, 0.0]])
    s1, ep1, al1, y1 = radial_return(eps, ep, al, E, NU, Y, H)
    de = -0.2 * (eps - ep) + 1e-5 * rng.standard_normal((1, 6)) * Y / E
    s2, ep2, al2, y2 = radial_return(eps + de, ep1, al1, E, NU, Y, H)
    assert not y2[0]
    np.testing.assert_allclose(s2 - s1, de @ elastic_voigt().T, rtol=1e-10, atol=1e-6)
    np.testing.assert_array_equal(ep2, ep1)
    # reverse loading yields at -(Y + H alpha): isotropic hardening
    ey = Y + H * al[0]
    eps_rev = eps_max - (s_max + ey) / E     # elastic unloading down to -(Y + H alpha)
    out, *_ = uniaxial_path(np.array([eps_rev + 1e-9, eps_rev - Y / E]), ep, al)
    np.testing.assert_allclose(out[0][0][0], -ey, rtol=1e-6)
    np.testing.assert_allclose(out[1][0][0], -ey - E_T * Y / E, rtol=1e-6)


def random_states(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    eps = rng.standard_normal((n, 6)) * rng.uniform(0.1, 4.0, (n, 1)) * Y / E
    ep = rng.standard_normal((n, 6)) * Y / E
    ep[:, :3] -= ep[:, :3].mean(axis=1, keepdims=True)    # plastic strain is deviatoric
    al = np.abs(rng.standard_normal(n)) * Y / E
    return eps, ep, al


def deviatoric_norm(s: np.ndarray) -> np.ndarray:
    dev = s.copy()
    dev[:, :3] -= s[:, :3].mean(axis=1, keepdims=True)
    return np.sqrt((dev[:, :3] ** 2).sum(axis=1) + 2 * (dev[:, 3:] ** 2).sum(axis=1))


def test_return_lands_on_the_yield_surface():
    eps, ep, al = random_states(400)
    s, ep1, al1, yld = radial_return(eps, ep, al, E, NU, Y, H)
    assert 50 < yld.sum() < 400
    R = math.sqrt(2 / 3) * (Y + H * al1)
    q = deviatoric_norm(s)
    np.testing.assert_allclose(q[yld], R[yld], rtol=1e-12)       # consistency
    assert np.all(q[~yld] <= R[~yld])
    # associative flow: the plastic increment is along the returned deviator
    dep = (ep1 - ep) * [1, 1, 1, 0.5, 0.5, 0.5]
    dev = s.copy()
    dev[:, :3] -= s[:, :3].mean(axis=1, keepdims=True)
    cross = np.abs(dep[yld, :, None] * dev[yld, None, :] - dep[yld, None, :] * dev[yld, :, None])
    assert cross.max() <= 1e-9 * np.abs(dep[yld]).max() * np.abs(dev[yld]).max()
    np.testing.assert_allclose(ep1[:, :3].sum(axis=1), 0.0, atol=1e-14 * np.abs(ep1).max())
    # alpha grows by sqrt(2/3) |d eps_p| (tensor norm)
    dnorm = np.sqrt((dep[:, :3] ** 2).sum(axis=1) + 2 * (dep[:, 3:] ** 2).sum(axis=1))
    np.testing.assert_allclose(al1 - al, math.sqrt(2 / 3) * dnorm, rtol=1e-12, atol=1e-20)
    # stress is C : (eps - eps_p)
    np.testing.assert_allclose(s, (eps - ep1) @ elastic_voigt().T, rtol=1e-9, atol=1e-3)
    # the tensor form gives the same
    sT, epT, alT, yT = radial_return(voigt_to_tensor(eps), voigt_to_tensor(ep), al, E, NU, Y, H)
    np.testing.assert_allclose(tensor_to_voigt(sT, strain=False), s, rtol=1e-12, atol=1e-3)
    np.testing.assert_allclose(tensor_to_voigt(epT), ep1, rtol=1e-12, atol=1e-20)
    np.testing.assert_array_equal(yT, yld)


def test_consistent_tangent_against_finite_differences():
    eps, ep, al = random_states(60, seed=3)
    C = consistent_tangent(eps, ep, al, E, NU, Y, H)
    h = 1e-7 * Y / E
    fd = np.empty_like(C)
    for j in range(6):
        d = np.zeros(6)
        d[j] = h
        sp_, *_ = radial_return(eps + d, ep, al, E, NU, Y, H)
        sm, *_ = radial_return(eps - d, ep, al, E, NU, Y, H)
        fd[:, :, j] = (sp_ - sm) / (2 * h)
    # central differences: truncation ~ h^2 |d3 sigma| and round-off ~ 1e-16 sigma / h,
    # both below 1e-7 of |C| here (no point lies within h of the yield surface)
    np.testing.assert_allclose(fd, C, rtol=0, atol=1e-6 * E)
    yld = radial_return(eps, ep, al, E, NU, Y, H)[3]
    assert yld.sum() > 10 and np.abs(C[yld] - elastic_voigt()).max() > 0.1 * MU
    np.testing.assert_allclose(C[~yld], np.broadcast_to(elastic_voigt(), C[~yld].shape),
                               rtol=1e-14, atol=0)
    np.testing.assert_allclose(C, np.swapaxes(C, 1, 2), rtol=0, atol=1e-6 * E)
    # tensor form: C_ijkl with minor symmetries, equal to the Voigt entries
    CT = consistent_tangent(voigt_to_tensor(eps), voigt_to_tensor(ep), al, E, NU, Y, H)
    assert CT.shape == (60, 3, 3, 3, 3)
    np.testing.assert_allclose(CT, np.swapaxes(CT, 1, 2), atol=1e-6 * E)
    np.testing.assert_allclose(CT, np.swapaxes(CT, 3, 4), atol=1e-6 * E)
    np.testing.assert_allclose(CT[:, 0, 1, 1, 2], C[:, 5, 3], rtol=1e-12, atol=1e-3)
    # under uniaxial stress the condensed algorithmic tangent is E_t
    _, ep1, al1, _ = uniaxial_path(np.array([3 * Y / E]))
    eps_u = np.array([[3 * Y / E, 0.0, 0.0, 0, 0, 0]])
    out, *_ = uniaxial_path(np.array([3.2 * Y / E]), ep1, al1)
    eps_u[0, 1:3] = out[0][1]
    Cu = consistent_tangent(eps_u, ep1, al1, E, NU, Y, H)[0]
    i, o = [0], [1, 2, 3, 4, 5]
    cond = Cu[np.ix_(i, i)] - Cu[np.ix_(i, o)] @ np.linalg.solve(Cu[np.ix_(o, o)],
                                                                  Cu[np.ix_(o, i)])
    np.testing.assert_allclose(cond[0, 0], E_T, rtol=1e-9)


# -- the zone --------------------------------------------------------------------------


@pytest.fixture(scope="module", params=[1, 2], ids=["P1", "P2"])
def cube_model(request):
    return build_model(box_mesh(2, request.param), (STEEL,))


@pytest.fixture
def cube(cube_model):
    """Unit cube model and a fresh zone over all its elements."""
    return cube_model, PlasticZone(cube_model, np.arange(len(cube_model.mesh.cells)))


def test_zone_quadrature_and_zero_plastic_strain(cube):
    model, zone = cube
    assert zone.nq == (4 if model.mesh.order == 2 else 1)   # intorder 2: 4-point rule
    np.testing.assert_allclose(zone.weights.sum(), 1.0, rtol=1e-13)
    u = linear_field(model, np.full((3, 3), 0.3 * Y / E))   # elastic
    u += np.random.default_rng(0).standard_normal(model.n_dofs) * 0.01 * Y / E
    np.testing.assert_allclose(zone.von_mises(u), von_mises(model, u), rtol=1e-12)
    F = zone.update(u)
    assert zone.n_yielded == 0
    np.testing.assert_array_equal(F, 0.0)
    zone.commit()
    np.testing.assert_array_equal(zone.plastic_strain, 0.0)
    assert zone.dissipation() == 0.0


def test_homogeneous_plastic_strain_force(cube):
    model, zone = cube
    A = np.array([[2.0, 0.3, -0.2], [0.5, -1.2, 0.4], [0.1, 0.0, -0.8]]) * 1e-3
    ep_t = 0.5 * (A + A.T)
    ep = tensor_to_voigt(ep_t[None])[0]
    F = zone.plastic_force(ep)
    # truth 1: a linear field u_p with strain eps_p: K u_p = int B^T C eps_p (assembled
    # by scikit-fem's own forms); exact up to round-off.
    Ku = model.K @ linear_field(model, A)
    np.testing.assert_allclose(F, Ku, rtol=0, atol=1e-12 * np.abs(Ku).max())
    # truth 2: F_a = int grad N_a . sigma_p = surface integral of N_a sigma_p n: zero at
    # interior nodes; the x forces at x = 1 add up to sigma_xx * area for diagonal eps_p
    sig_d = LAM * np.trace(np.diag([2e-3, -1e-3, -1e-3])) + 2 * MU * np.array([2e-3, -1e-3,
                                                                                -1e-3])
    Fd = zone.plastic_force(np.array([2e-3, -1e-3, -1e-3, 0, 0, 0])).reshape(-1, 3)
    x = model.basis.doflocs[:, ::3].T
    inner = np.all((x > 1e-9) & (x < 1 - 1e-9), axis=1)
    assert inner.any()
    np.testing.assert_allclose(Fd[inner], 0.0, atol=1e-12 * np.abs(Fd).max())
    for k in range(3):
        np.testing.assert_allclose(Fd[np.abs(x[:, k] - 1) < 1e-9, k].sum(), sig_d[k],
                                   rtol=1e-12)
    # as committed state: the displacement u_p is stress free (f_int = K u_p - F_p = 0),
    # and the stored energy is eps_p : C : eps_p / 2 times the volume
    ep_dev = ep - np.r_[np.full(3, ep[:3].mean()), 0, 0, 0]
    zone.set_state(ep_dev, 1e-3)
    u_p = linear_field(model, A - np.eye(3) * ep[:3].mean())
    np.testing.assert_allclose(zone.plastic_force(), model.K @ u_p, rtol=0,
                               atol=1e-12 * np.abs(Ku).max())
    F = zone.update(u_p)
    assert zone.n_yielded == 0
    np.testing.assert_allclose(model.K @ u_p - F, 0.0, atol=1e-12 * np.abs(Ku).max())
    w_p = 0.5 * ep_dev @ elastic_voigt() @ ep_dev
    np.testing.assert_allclose(zone.energy_correction(np.zeros(model.n_dofs)), w_p, rtol=1e-12)
    np.testing.assert_allclose(0.5 * u_p @ (model.K @ u_p) + zone.energy_correction(u_p), 0.0,
                               atol=1e-9 * w_p)


def test_zone_kernel_matches_material_point(cube):
    model, zone = cube
    rng = np.random.default_rng(5)
    u = linear_field(model, np.diag([1.0, -0.3, -0.3]) * Y / E)
    u += rng.standard_normal(model.n_dofs) * 0.1 * Y / E
    F = zone.update(u)
    ec_trial = zone.energy_correction(u)
    eps = zone.strains(u).reshape(-1, 6)
    n = len(eps)
    s, ep1, al1, yld = radial_return(eps, np.zeros((n, 6)), np.zeros(n), E, NU, Y, H)
    assert 0 < yld.sum() < n and zone.n_yielded == yld.sum()
    np.testing.assert_array_equal(zone.yielded().ravel(), yld)
    zone.commit()
    np.testing.assert_allclose(zone.plastic_strain.reshape(-1, 6), ep1, rtol=1e-10,
                               atol=1e-12 * np.abs(ep1).max())
    np.testing.assert_allclose(zone.alpha.ravel(), al1, rtol=1e-10, atol=1e-20)
    np.testing.assert_allclose(F, zone.plastic_force(), rtol=0, atol=1e-12 * np.abs(F).max())
    # stresses: C : (eps - eps_p) = the returned stress
    np.testing.assert_allclose(zone.stresses(u).reshape(-1, 6), s, rtol=0, atol=1e-9 * Y)
    # internal force K u - F_p is the integral of B^T sigma (virtual work)
    B_sig = np.sum(zone.stresses(u).reshape(-1, 6) * eps * zone.weights.reshape(-1, 1))
    np.testing.assert_allclose(u @ (model.K @ u - F), B_sig, rtol=1e-10)
    # energy correction: int (eps - eps_p) C (eps - eps_p) / 2
    ee = eps - ep1
    W = 0.5 * np.sum(np.einsum("pi,ij,pj->p", ee, elastic_voigt(), ee) * zone.weights.ravel())
    np.testing.assert_allclose(0.5 * u @ (model.K @ u) + zone.energy_correction(u), W,
                               rtol=1e-10)
    assert zone.energy_correction(u) == ec_trial
    epe = zone.equivalent_plastic_strain("max")
    np.testing.assert_allclose(epe, zone.alpha.max(axis=1))
    assert np.all(zone.equivalent_plastic_strain("mean") <= epe + 1e-18)


def test_screening_skips_elements_and_changes_nothing(cube_model):
    """The update skips elements whose stress bound stays below yield; it must give
    exactly the results of evaluating every point (a second zone whose references
    are cleared before each update), through loading past yield, unloading and
    Newton-like trial updates that are not committed."""
    model = cube_model
    cells = np.arange(len(model.mesh.cells))
    screened, full = PlasticZone(model, cells), PlasticZone(model, cells)
    rng = np.random.default_rng(11)
    # a bending-like field graded along x: the elements near x = 1 yield first
    x = model.basis.doflocs
    shape = rng.standard_normal(model.n_dofs) * 0.02 + np.where(np.arange(model.n_dofs) % 3
                                                                == 0, x[2] * x[0] ** 3, 0.0)
    shape *= 3.0 * Y / E
    skipped = 0
    for scale in np.r_[np.linspace(0.0, 1.2, 25), np.linspace(1.2, 0.8, 5)]:
        for trial in (0.97, 1.0):                      # an uncommitted trial, then the step
            u = trial * scale * shape
            full._sref[:] = 1e300                      # every element evaluated
            F1, F2 = screened.update(u), full.update(u)
            assert full.evaluated == full.n_elements
            skipped += screened.n_elements - screened.evaluated
            np.testing.assert_array_equal(F1, F2)
            assert screened.n_yielded == full.n_yielded
            assert screened.energy_correction(u) == full.energy_correction(u)
        screened.commit()
        full.commit()
        np.testing.assert_array_equal(screened.plastic_strain, full.plastic_strain)
        assert screened.dissipation() == full.dissipation()
    assert full.n_yielded == 0 and screened.alpha.max() > 0      # it yielded, then unloaded
    assert skipped > 0


def test_tangent_correction_against_finite_differences(cube):
    model, zone = cube
    rng = np.random.default_rng(7)
    u = linear_field(model, np.array([[4.0, 1.0, 0], [0, -2.0, 0.5], [0, 0, -1.0]]) * Y / E)
    u += rng.standard_normal(model.n_dofs) * 0.3 * Y / E
    D = zone.tangent_correction(u)
    assert zone.n_yielded == zone.n_points
    du = rng.standard_normal(model.n_dofs) * Y / E
    # the matrix-free product is the same operator (round-off)
    np.testing.assert_allclose(zone.tangent_product(du), D @ du, rtol=0,
                               atol=1e-10 * np.abs(D @ du).max())
    h = 1e-6
    fd = (zone.update(u + h * du) - zone.update(u - h * du)) / (2 * h)
    np.testing.assert_allclose(fd, D @ du, rtol=0, atol=1e-6 * np.abs(D @ du).max())
    np.testing.assert_allclose((D - D.T).toarray(), 0.0, atol=1e-9 * abs(D).max())
    assert np.linalg.eigvalsh(D.toarray()).min() > -1e-9 * abs(D).max()   # K_ep <= K
    # from a committed plastic state, loading further in a turned direction: the
    # flow direction is the trial one, not the committed strain's
    zone.update(u)
    zone.commit()
    u2 = u + linear_field(model, np.array([[0.5, 2.0, 0], [2.0, 0.3, 0], [0, 0, -0.2]]) * Y / E)
    D2 = zone.tangent_correction(u2)
    assert zone.n_yielded > 0
    np.testing.assert_allclose(zone.tangent_product(du), D2 @ du, rtol=0,
                               atol=1e-10 * np.abs(D2 @ du).max())
    fd = (zone.update(u2 + h * du) - zone.update(u2 - h * du)) / (2 * h)
    np.testing.assert_allclose(fd, D2 @ du, rtol=0, atol=1e-6 * np.abs(D2 @ du).max())


def drive_homogeneous(zone, model, path):
    """Impose uniaxial-stress strain states (lateral strains from the material point)."""
    out, *_ = uniaxial_path(path)
    for (_, lat, _, _), exx in zip(out, path, strict=True):
        zone.update(linear_field(model, np.diag([exx, lat, lat])))
        zone.commit()
    return out


def test_dissipation_on_a_uniaxial_cycle(cube):
    model, zone = cube
    e1, e2 = 4 * Y / E, -5 * Y / E
    # load, reverse into compressive yield, unload (elastically) by Y / E
    path = np.concatenate([np.linspace(0, e1, 6)[1:], np.linspace(e1, e2, 10)[1:],
                           np.linspace(e2, e2 + Y / E, 4)[1:]])
    drive_homogeneous(zone, model, path)
    # closed form: loading to e1, then reverse yield at -(Y + H a1) with isotropic hardening
    s1 = Y + E_T * (e1 - Y / E)
    a1 = e1 - s1 / E                    # = plastic axial strain ep1
    a2 = (a1 + a1 - e2 - Y / E) / (1 + H / E)
    w = Y * a2 + 0.5 * H * a2 ** 2      # int sigma d eps_p = int (Y + H a) da per volume
    np.testing.assert_allclose(zone.dissipation(), w, rtol=1e-9)
    np.testing.assert_allclose(zone.alpha, a2, rtol=1e-9)


def test_transform_and_subset():
    mesh = box_mesh(3, 2)
    model = build_model(mesh, (STEEL,))
    els = elements_near(mesh, [0.0, 0.0, 0.0], 0.4)
    # truth: brute-force distances
    d = np.linalg.norm(mesh.points, axis=1)
    np.testing.assert_array_equal(els, np.flatnonzero((d[mesh.cells] <= 0.4).any(axis=1)))
    assert 0 < len(els) < len(mesh.cells)
    zone = PlasticZone(model, els)
    rng = np.random.default_rng(2)
    T = sp.random(model.n_dofs, 40, density=0.2, random_state=3, format="csr")
    zt = PlasticZone(model, els, transform=T)
    z = rng.standard_normal(40) * 20 * Y / E
    np.testing.assert_allclose(zt.update(z), T.T @ zone.update(T @ z), rtol=1e-12, atol=1e-6)
    Dt, Dz = zt.tangent_correction(z), zone.tangent_correction(T @ z)
    np.testing.assert_allclose(Dt.toarray(), (T.T @ Dz @ T).toarray(), rtol=1e-10,
                               atol=1e-9 * abs(Dz).max())
    zone.commit()
    assert zone.boundary_yielded()          # plastic strain reaches the zone's edge
    # elements without a yield strength stay out of the zone
    mixed = build_model(mesh, (ELASTIC,))
    assert PlasticZone(mixed, els).n_elements == 0
    assert not PlasticZone(mixed, els).update(np.zeros(mixed.n_dofs)).any()


class PulledBar:
    """A bar pulled to 3 yield strains with symmetry supports, seen through its free DOFs.

    Homogeneous uniaxial stress, so the discrete solution is exact and the
    reaction is A * sigma(eps) from the bilinear law.
    """

    strain = 3 * Y / E

    def __init__(self):
        mesh = box_mesh(2, 1, size=(2.0, 1.0, 1.0))
        self.model = build_model(mesh, (STEEL,))
        n = self.model.n_dofs
        x = self.model.basis.doflocs
        c = np.arange(n) % 3
        fixed = np.isclose(x[c, np.arange(n)], 0.0)                # symmetry planes
        self.pulled = (c == 0) & np.isclose(x[0], 2.0)
        self.free = ~fixed & ~self.pulled
        self.u = np.zeros(n)
        self.u[self.pulled] = 2.0 * self.strain
        self.K = self.model.K.tocsr()
        self.lu = splu(self.K[self.free][:, self.free].tocsc())
        self.rhs = -self.K[self.free][:, self.pulled] @ self.u[self.pulled]
        self.zone = PlasticZone(self.model, np.arange(len(mesh.cells)))

    def full(self, zf):
        v = self.u.copy()
        v[self.free] = zf
        return v

    def step(self, Fp):
        return self.lu.solve(self.rhs + Fp)

    # the zone's interface on the free DOFs
    def update(self, zf):
        return self.zone.update(self.full(zf))[self.free]

    def tangent_product(self, xf):
        v = np.zeros(self.model.n_dofs)
        v[self.free] = xf
        return self.zone.tangent_product(v)[self.free]

    def reaction_error(self, zf):
        v = self.full(zf)
        reaction = (self.K @ v - self.zone.update(v))[self.pulled].sum()
        return reaction / (Y + E_T * (self.strain - Y / E)) - 1.0


def test_static_bar_by_accelerated_modified_newton():
    bar = PulledBar()
    results = {}
    for memory in (0, 5):
        z, it = solve_fixed_point(bar.step, bar, np.zeros(bar.free.sum()), tol=1e-10,
                                  max_iter=400, memory=memory)
        results[memory] = it
        assert abs(bar.reaction_error(z)) < 1e-7
    # plain modified Newton contracts slowly on a fully plastic body (77 iterations
    # measured); Anderson mixing cuts that by a factor of about 3
    assert results[5] < results[0] / 2


def test_static_bar_by_newton_with_the_consistent_tangent():
    # The same bar by Newton's method with the consistent tangent: quadratic
    # convergence, r_k+1 / r_1 ~ (r_k / r_1)^2 once every point yields (measured
    # orders 2.1 and 2.0; the elastic tangent of modified Newton gives order 1 and
    # 77 iterations). Order above 1.8 is asked: a tangent off by a few percent
    # would already fall to order 1.
    bar = PulledBar()
    res: list[float] = []
    z, it, products = solve_newton(bar.step, bar.lu.solve, bar, np.zeros(bar.free.sum()),
                                   tol=1e-10, krylov_tol=1e-12, residuals=res)
    assert abs(bar.reaction_error(z)) < 1e-7
    assert it <= 6
    rel = np.array(res) / res[0]
    orders = np.log(rel[3:it - 1]) / np.log(rel[2:it - 2])
    assert len(orders) >= 1 and orders.min() > 1.8, rel
    assert products > 0
