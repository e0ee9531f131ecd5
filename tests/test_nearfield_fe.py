"""Combined near field (half-space layer over a coarse FE far field).

Truths: P2 interpolation reproduces a quadratic field exactly; Hertz's sphere
on a block through the local approach at depth (Johnson 1985, section 4.2,
plus the half-space's axial displacement under the Hertz pressure).
"""

from pathlib import Path

import numpy as np
import pytest

from fe_impact.contact import nearfield as nf
from fe_impact.contact import nearfield_fe as nff
from fe_impact.fe.mesh import load_mesh
from fe_impact.physics import hertz
from validation import nearfield_hertz as study

MESHES = Path(__file__).resolve().parents[1] / "meshes"


def test_probe_reproduces_a_quadratic_field():
    # any quadratic displacement is in the P2 space: exact up to rounding
    mesh = load_mesh(MESHES / "hertz_coarse.msh")
    x = mesh.points
    u = np.zeros(3 * (mesh.point_dof.max() + 1))
    u[3 * mesh.point_dof + 2] = x[:, 0] ** 2 + 2 * x[:, 1] * x[:, 2] + 3e-3 * x[:, 0] + 1e-6
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(0, 5e-3, 50), rng.uniform(0, 5e-3, 50),
                           rng.uniform(-5e-3, 0, 50)])
    P = nff.probe_matrix(mesh, pts, "block", 2)
    exact = pts[:, 0] ** 2 + 2 * pts[:, 1] * pts[:, 2] + 3e-3 * pts[:, 0] + 1e-6
    assert np.allclose(P @ u, exact, rtol=1e-9, atol=1e-18)


def test_coarse_sphere_on_block_is_hertz(tmp_path):
    # The tolerances (force 1%, p0 and contact radius 2%) on the mesh
    # five times coarser than hertz_medium, at one displacement (15 um).
    far, _ = study.near_field_model(study.coarse_mesh(tmp_path))
    step, _ = study.solve_step(far, 15e-6, 500.0)
    c = hertz.sphere_contact(step.force, study.R, hertz.effective_modulus(study.E, study.NU))
    assert step.force == pytest.approx(step.hertz_local_force, rel=0.01)
    assert step.p0 == pytest.approx(c.p0, rel=0.02)
    assert step.radius == pytest.approx(c.a, rel=0.02)


def test_grid_coarser_than_patch_is_refused():
    g = nf.Grid.centred(1e-3, 1e-3, 16, 16)
    with pytest.raises(ValueError, match="cells across the patch"):
        nff.check_grid(g, 0.5e-3)
    with pytest.raises(ValueError, match="inside the patch"):
        nff.check_grid(nf.Grid.centred(0.4e-3, 0.4e-3, 64, 64), 0.5e-3)


def test_too_curved_or_too_shallow_is_refused():
    with pytest.raises(ValueError, match="radius of curvature = 0.14"):
        nff.check_half_space(14e-6, 0.1e-3, 20e-6, 5e-6)
    with pytest.raises(ValueError, match="coarse elements"):
        nff.check_half_space(0.2e-3, 10e-3, 1e-3, 0.5e-3)
    with pytest.raises(ValueError, match="face edge"):
        nff.check_half_space(0.2e-3, 10e-3, 2e-3, 0.5e-3, edge_distance=1e-3)


def test_hats_split_force_and_moments_exactly():
    # bilinear hats form a partition of unity and reproduce linear functions:
    # the gathered loads keep the total force and its first moments
    hb = nff.HatBasis(2e-3, 0.3e-3, 9, 4)
    rng = np.random.default_rng(2)
    x, y = rng.uniform(-2e-3, 2e-3, 200), rng.uniform(-0.3e-3, 0.3e-3, 200)
    f = rng.random(200)
    W = hb.weights(x, y)
    F = W.T @ f
    hx = np.repeat(np.linspace(-2e-3, 2e-3, 9), 4)
    hy = np.tile(np.linspace(-0.3e-3, 0.3e-3, 4), 9)
    assert F.sum() == pytest.approx(f.sum(), rel=1e-12)
    assert hx @ F == pytest.approx(x @ f, rel=1e-12)
    assert hy @ F == pytest.approx(y @ f, rel=1e-12)


def test_hat_far_field_matches_dof_far_field(tmp_path):
    # Gathering the loads on hats at half the matching depth changes the
    # depth response at second order in spacing / depth: the force at 15 um
    # within 0.5% of the far field loaded DOF by DOF.
    mesh_file = study.coarse_mesh(tmp_path)
    far, _ = study.near_field_model(mesh_file)
    exact, _ = study.solve_step(far, 15e-6, 500.0)
    hats = nff.HatBasis(0.5e-3, 0.5e-3, 3, 3)   # the quarter: spacing 0.5 mm = DEPTH / 4
    far_h = nff.FarField(far.mesh, far.free, far.solve, far.sides, fold=True, hats=hats)
    hat, _ = study.solve_step(far_h, 15e-6, 500.0)
    assert hat.force == pytest.approx(exact.force, rel=5e-3)


def test_rounding_smaller_than_grid_is_refused():
    g = nf.Grid.centred(0.5e-3, 0.05e-3, 64, 64)     # 15.6 um cells along x
    with pytest.raises(ValueError, match="tip_edge_radius = 0.0001 m"):
        nff.check_rounding(0.1e-3, g)
    nff.check_rounding(0.5e-3, g)


def test_hat_half_space_is_boussinesq_far_from_the_hat():
    # Far from a hat (40 hat spacings) its spread unit force acts as a point
    # force: Boussinesq at depth (Johnson eq. 3.21a) and at the surface
    # (1 - nu^2) / (pi E r). The spread's second moment changes the value by
    # (s / r)^2 ~ 1e-3, hence 0.5%.
    hats = nff.HatBasis(1e-3, 0.2e-3, 3, 2)
    E, nu = 206e9, 0.3
    r = np.array([40e-3, 0.0])
    y = np.array([0.0, 40e-3])
    for depth in (0.0, 1e-3):
        g = nff.hat_half_space(hats, r, y, depth, E, nu)
        if depth == 0.0:
            point = (1 - nu ** 2) / (np.pi * E * 40e-3)
        else:
            point = nf.depth_displacement(40e-3, depth, E, nu)
        assert g.shape == (2, 6)
        assert np.allclose(g, point, rtol=5e-3)


def test_hat_half_space_at_surface_is_love_for_a_uniform_spread():
    # The hats sum to one at every sample, so a uniform load gathered on
    # them (each hat's share its samples' count) and spread back puts the
    # same force on every sample cell: a uniform pressure on the rectangle
    # those cells tile (the lattice widened by half a cell). Love's closed
    # form for it (Johnson eq. 3.25) must come back to rounding, at the
    # centre and off the rectangle.
    hats = nff.HatBasis(1e-3, 0.5e-3, 3, 3)
    E, nu = 206e9, 0.3
    x, _, _ = nff.hat_samples(hats)
    W = hats.weights(*nff.hat_samples(hats)[:2])
    share = np.asarray(W.sum(axis=0)).ravel() / len(x)
    hx, hy = 2e-3 / 16, 1e-3 / 8
    ax, ay = 1e-3 + hx / 2, 0.5e-3 + hy / 2
    px, py = np.array([0.0, 0.4e-3, 3e-3]), np.array([0.0, 0.1e-3, -1e-3])
    w = nff.hat_half_space(hats, px, py, 0.0, E, nu) @ share
    love = (nf.love_rectangle(px, py, ax, ay) / (4 * ax * ay) * (1 - nu ** 2) / (np.pi * E))
    assert np.allclose(w, love, rtol=1e-9)


def test_same_load_needs_unfolded_hats():
    with pytest.raises(ValueError, match="same_load"):
        nff.FarField(load_mesh(MESHES / "hertz_coarse.msh"), np.arange(3), lambda b: b,
                     study.sides(), fold=True, same_load=True)


def test_surface_height_is_the_cylinder_and_nan_past_its_end():
    # a cylinder of radius R about the y axis, touching the plane z = 0 at the
    # origin, in a non-affine parametrisation (angle, t -> y = t + 50 t^2): its
    # height over the plane is R - sqrt(R^2 - x^2) (exact geometry; Newton's
    # residual 1e-9 m of 1e-3 m is the only error); the surface ends at
    # angle 0.2 rad (x = R sin 0.2), beyond which the height is NaN.
    R = 5e-3

    def cylinder(a, t):
        return np.column_stack([R * np.sin(a), t + 50 * t ** 2, R * (1 - np.cos(a))])

    frame = (np.zeros(3), np.eye(3)[0], np.eye(3)[1], np.eye(3)[2])
    h = nff.surface_height(cylinder, (0.0, 0.0), frame, (1e-6, 1e-6),
                           inside=lambda a, t: a <= 0.2)
    x = np.linspace(-0.9e-3, 0.9e-3, 7)
    y = np.linspace(-1e-3, 1e-3, 7)
    z = h(x, y)
    inside = x <= R * np.sin(0.2)
    assert np.allclose(z[inside], R - np.sqrt(R ** 2 - x[inside] ** 2), rtol=1e-8, atol=1e-15)
    assert np.all(np.isnan(z[~inside]))


def test_masked_cells_are_a_smaller_grid():
    # cells outside `allowed` (past a flank's end) must act as if the grid ended
    # there: the same sphere-on-half-space problem on a grid cut at the same
    # cell boundary (a different FFT size) gives the same pressure; cut through
    # the Hertz circle, the contact is more compliant than Hertz (less area).
    E, NU, R = 210e9, 0.3, 10e-3
    e_star = nf.effective_modulus(E, NU, E, NU)
    c = hertz.sphere_contact(200.0, R, e_star)
    n, cut = 48, 30                       # keep cells 0..29 along x (x < 0.325 a)
    g = nf.Grid.centred(1.3 * c.a, 1.3 * c.a, n, n)
    X, Y = g.centres()
    allowed = np.zeros(g.shape, dtype=bool)
    allowed[:cut] = True
    full = nf.solve_pressure((X ** 2 + Y ** 2) / (2 * R),
                             nf.Convolution(g, nf.surface_kernel(g, e_star)).apply,
                             200.0, g.cell_area, allowed=allowed)
    small = nf.Grid(cut, n, g.dx, g.dy, g.x0, g.y0)
    Xs, Ys = small.centres()
    part = nf.solve_pressure((Xs ** 2 + Ys ** 2) / (2 * R),
                             nf.Convolution(small, nf.surface_kernel(small, e_star)).apply,
                             200.0, small.cell_area)
    assert np.all(full.pressure[cut:] == 0.0)
    assert full.approach == pytest.approx(part.approach, rel=1e-6)
    assert np.allclose(full.pressure[:cut], part.pressure, rtol=0, atol=1e-6 * part.pressure.max())
    assert full.approach > 1.05 * c.a ** 2 / R


def test_hat_spread_stays_on_the_surface():
    # a surface ending at x = 0.3 mm: each hat's force is spread only where it
    # exists (the FE is loaded on its own surface), all of it (shares sum to 1)
    hats = nff.HatBasis(1e-3, 0.2e-3, 5, 2)
    x, y, phi = nff.hat_samples(hats, lambda x, y: x <= 0.3e-3)
    phi = phi.toarray()
    assert np.allclose(phi.sum(axis=0), 1.0)
    # hats with samples on the surface put nothing past its end
    on = (phi[x <= 0.3e-3] > 0).any(axis=0)
    assert np.all(phi[x > 0.3e-3][:, on] == 0.0)


def test_far_field_on_a_lattice_matches_probing_every_cell(tmp_path):
    # The far field at depth (2 mm here) varies over lengths of the depth, so
    # interpolating it bilinearly from a lattice 1/8 of the hat spacing apart
    # (62 um) errs by about (h / d)^2 / 8 = 1e-4 of its variation over the
    # patch: the force at 15 um within 0.1% of probing the FE under every cell.
    mesh_file = study.coarse_mesh(tmp_path)
    far, _ = study.near_field_model(mesh_file)
    hats = nff.HatBasis(0.5e-3, 0.5e-3, 3, 3)
    every = nff.FarField(far.mesh, far.free, far.solve, far.sides, fold=True, hats=hats)
    lattice = nff.FarField(far.mesh, far.free, far.solve, far.sides, fold=True, hats=hats,
                           lattice=8)
    a, _ = study.solve_step(every, 15e-6, 500.0)
    b, _ = study.solve_step(lattice, 15e-6, 500.0)
    assert b.force == pytest.approx(a.force, rel=1e-3)
