"""Tooth contact analysis: contact point, curvatures, Hertz ellipse, path, transmission error.

Truths are computed here independently of ``fe_impact.gears.tca`` where
possible: the mounting is rebuilt from the frame definitions in its module
docstring, flank points come from the tooth classes directly, curvatures are
checked against closed forms (involute, crowning parabola, spheres and
cylinders) and the Hertz numbers against docs/references.md ("Hertz contact").
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.special import ellipe, ellipk

from fe_impact.errors import GeometryError
from fe_impact.gears import GearPair, contact_ellipse, default_gearset, relative_curvature
from fe_impact.gears.tca import PrincipalCurvatures, equivalent_radius, principal_curvatures
from fe_impact.physics import hertz

E_STAR = hertz.effective_modulus(212e9, 0.289)


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


# -- Hertz ellipse and the curvature combination ---------------------------------------------
def _surface(kappa, direction, normal):
    """Principal curvatures record of a surface with curvatures ``kappa`` (ascending
    with their first direction ``direction``) and outward ``normal``."""
    d1 = np.asarray(direction, float) / np.linalg.norm(direction)
    d2 = np.cross(normal, d1)
    return PrincipalCurvatures(np.asarray(kappa, float), np.stack([d1, d2]),
                               np.asarray(normal, float))


@pytest.mark.parametrize(
    "rx, ry, a_um, b_um, p0_mpa, delta_um",
    [(0.1, 0.01, 1172.2, 260.5, 1563.6, 10.263), (1.0, 0.01, 3007.2, 165.3, 960.3, 5.889)],
)
def test_ellipse_matches_reference_values(rx, ry, a_um, b_um, p0_mpa, delta_um):
    """docs/references.md, elliptical Hertz contact (P = 1000 N, E* = 115.66 GPa): a
    sphere of radius Rx on a cylinder that adds 1/Ry - 1/Rx across, combined by
    relative_curvature."""
    sphere = _surface([1 / rx, 1 / rx], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    cylinder = _surface([0.0, 1 / ry - 1 / rx], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    rel = relative_curvature(sphere, cylinder)
    e = contact_ellipse(rel, 1000.0, 115.66e9)
    # the reference values are rounded to the last digit shown: half a unit of it (the
    # curvature combination itself adds only rounding, ~1e-15 relative)
    assert e.a * 1e6 == pytest.approx(a_um, abs=0.05)
    assert e.b * 1e6 == pytest.approx(b_um, abs=0.05)
    assert e.p0 / 1e6 == pytest.approx(p0_mpa, abs=0.05)
    assert e.approach * 1e6 == pytest.approx(delta_um, abs=5e-4)
    assert abs(e.major @ [1.0, 0.0, 0.0]) == pytest.approx(1.0, abs=1e-15)  # along 1/Rx


@pytest.mark.parametrize("angle_deg", [0.0, 17.0, 45.0, 71.0, 90.0])
def test_relative_curvature_matches_johnson_closed_form(angle_deg):
    """Two crossed cylinders-like surfaces (radii 10/40 mm and 25/inf mm, principal planes
    at angle alpha): Johnson 1985 section 4.1,
    A + B = (k1' + k1'' + k2' + k2'') / 2,
    B - A = sqrt(g1^2 + g2^2 + 2 g1 g2 cos 2 alpha) / 2, g_i = k_i' - k_i''."""
    k1, k2 = np.array([25.0, 100.0]), np.array([0.0, 40.0])
    a = np.radians(angle_deg)
    first = _surface(k1, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    second = _surface(k2, [np.cos(a), np.sin(a), 0.0], [0.0, 0.0, -1.0])
    rel = relative_curvature(first, second)
    g1, g2 = k1[0] - k1[1], k2[0] - k2[1]
    total = 0.5 * (k1.sum() + k2.sum())
    diff = 0.5 * np.sqrt(g1**2 + g2**2 + 2 * g1 * g2 * np.cos(2 * a))
    # eigenvalues of a 2x2 symmetric matrix of O(100) entries: rounding level
    assert 0.5 * (rel.lambda_min + rel.lambda_max) == pytest.approx(total, rel=1e-14)
    assert 0.5 * (rel.lambda_max - rel.lambda_min) == pytest.approx(diff, rel=1e-12, abs=1e-12)


def test_relative_curvature_rejects_non_contact_and_conformal():
    up = _surface([10.0, 10.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    with pytest.raises(GeometryError, match="opposite normals"):
        relative_curvature(up, up)
    hollow = _surface([-20.0, -20.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    with pytest.raises(GeometryError, match="not positive definite"):
        relative_curvature(up, hollow)


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_principal_curvatures_of_analytic_surfaces(shape):
    """The finite-difference routine on a sphere (R = 10 mm: 100, 100 1/m) and a
    cylinder (R = 10 mm: 0, 100 1/m), parametrised by angles, outward normals."""
    radius = 0.01

    def sphere(s, t):
        p = radius * np.stack([np.cos(t) * np.cos(s), np.cos(t) * np.sin(s), np.sin(t)], -1)
        return p, p / radius

    def cylinder(s, t):
        p = np.stack([radius * np.cos(s), radius * np.sin(s), t], -1)
        n = np.stack([np.cos(s), np.sin(s), 0 * t], -1)
        return p, n

    surface, expected = {"sphere": (sphere, [100.0, 100.0]),
                         "cylinder": (cylinder, [0.0, 100.0])}[shape]
    step = 1e-5 / radius
    k = principal_curvatures(surface, 0.3, 0.2, step, step if shape == "sphere" else 1e-5)
    # second differences with a 10 um step: truncation (h/R)^2/12 ~ 1e-7 relative,
    # rounding 4 eps R / h^2 ~ 1e-7 1/m
    np.testing.assert_allclose(k.kappa, expected, rtol=1e-6, atol=1e-5)


# -- TCA of the seed stages ----------------------------------------------------------------------
@pytest.mark.parametrize("stage", [1, 2, 3])
@pytest.mark.parametrize("roll_deg", [-6.0, 0.0, 4.0])
def test_contact_point_lies_on_both_flanks_with_equal_normals(gearset, stage, roll_deg):
    """Rebuild both flanks at the reported rotations from the frame definitions (pinion:
    Rz(pi + pi/(2 N_p) + phi_1) about (0, r_p, z0); face gear: Ry(phi_2)) and find the
    surface points at the contact point's own radius and height / axial position."""
    pair = GearPair.from_gearset(gearset, stage)
    c = pair.contact(np.radians(roll_deg))
    # face gear: radius and height of the point in the face-gear frame
    local = _ry(-c.face_angle) @ c.point
    f = pair.face.flank(np.hypot(local[0], local[2]), local[1])
    # pinion: the crowned flank at the point's axial position, roll angle from the radius
    p = pair.pinion
    rot = _rz(np.pi + np.pi / (2 * p.teeth) + c.roll_angle)
    lp = rot.T @ (c.point - np.array([0.0, p.pitch_radius, pair.z0]))
    theta = np.sqrt((np.hypot(lp[0], lp[1]) / p.base_radius) ** 2 - 1.0)
    s = p.flank_surface(lp[2], theta)
    # positions: Newton stops at 3e-16 m steps; 0.1 m coordinates rotated twice carry
    # a few 1e-17 m of rounding (the crowning at u = 0 is zero, so theta from the
    # radius is exact)
    assert c.residual < 1e-13
    assert np.linalg.norm(_ry(c.face_angle) @ f.points - c.point) < 1e-13
    assert np.linalg.norm(rot @ s.points + [0.0, p.pitch_radius, pair.z0] - c.point) < 1e-12
    # normals: opposite, to the normal-equation tolerance of the Newton solve
    n_face, n_pinion = _ry(c.face_angle) @ f.normals, rot @ s.normals
    np.testing.assert_allclose(n_face, c.normal, atol=1e-12)
    np.testing.assert_allclose(n_pinion, -c.normal, atol=1e-12)
    assert c.on_flank


@pytest.mark.parametrize("roll_deg", [-8.0, 0.0, 8.0])
def test_pinion_profile_curvature_is_the_involute_curvature(gearset, roll_deg):
    """Profile curvature 1/(r_b theta), theta = sqrt((rho/r_b)^2 - 1) from the contact
    point's distance rho to the pinion axis; lengthwise curvature of the parabolic
    crowning c (2u/b)^2 at u = 0: 8 c / b^2."""
    pair = GearPair.from_gearset(gearset, 1)
    c = pair.contact(np.radians(roll_deg))
    p = pair.pinion
    rho = np.hypot(c.point[0], c.point[1] - p.pitch_radius)
    theta = np.sqrt((rho / p.base_radius) ** 2 - 1.0)
    profile = np.cross([0.0, 0.0, 1.0], c.normal)  # tangent, perpendicular to the axis
    kappa = c.pinion_curvature.normal_curvature(profile)
    # finite differences with a 10 um step: measured 3e-7 relative error
    assert kappa == pytest.approx(1.0 / (p.base_radius * theta), rel=1e-5)
    axial = c.pinion_curvature.normal_curvature([0.0, 0.0, 1.0])
    assert axial == pytest.approx(8 * p.lengthwise_crowning / p.face_width**2, rel=1e-5)


@pytest.mark.parametrize("stage", [1, 2, 3])
def test_face_gear_profile_direction_is_flat(gearset, stage):
    """Along the profile the face gear is flat like a rack (each radius L is a rack
    section generated by the shaper's involute: Litvin 2000, face-gear chapter). The
    profile direction is the tangent of the flank section at constant radius L (by
    central differences on FaceGearTooth.flank); its normal curvature must vanish
    next to the pinion's 1/(r_b theta) ~ 100 1/m (measured 2e-6 1/m: FD noise)."""
    pair = GearPair.from_gearset(gearset, stage)
    c = pair.contact(0.0)
    radius, height = c.face_parameters
    step = 1e-6
    up, down = (pair.face.flank(radius, height + d).points for d in (step, -step))
    tangent = _ry(c.face_angle) @ (up - down)
    kappa = c.face_curvature.normal_curvature(tangent)
    pinion = c.pinion_curvature.normal_curvature(tangent)
    assert abs(kappa) < 1e-4 * pinion


@pytest.mark.parametrize("stage", [1, 2, 3])
def test_ellipse_of_the_seed_stages_satisfies_johnsons_relations(gearset, stage):
    """The Hertz ellipse at the TCA's relative curvature (B/A ~ 100, a slender ellipse),
    rechecked with scipy's Legendre integrals (Johnson 1985, section 4.2(b):
    B/A = (E/(1-e^2) - K)/(K - E), A = p0 b (K - E)/(E* a^2 e^2), P = 2/3 pi a b p0),
    and the load scaling of elliptical Hertz contact: a, b ~ P^(1/3) at a fixed b/a."""
    c = GearPair.from_gearset(gearset, stage).contact(0.0)
    A, B = 0.5 * c.relative.lambda_min, 0.5 * c.relative.lambda_max
    light, heavy = (contact_ellipse(c.relative, f, E_STAR) for f in (37.0, 1000.0))
    for e in (light, heavy):
        m = 1.0 - e.slenderness**2
        K, E = ellipk(m), ellipe(m)
        # ellipk near m = 1 and the difference K - E keep ~1e-10 (as in test_hertz)
        assert (E / (1 - m) - K) / (K - E) == pytest.approx(B / A, rel=1e-9)
        assert e.p0 * e.b * (K - E) / (E_STAR * e.a**2 * m) == pytest.approx(A, rel=1e-9)
        assert 2 / 3 * np.pi * e.a * e.b * e.p0 == pytest.approx(e.force, rel=1e-12)
        assert e.p0 * e.b * K / E_STAR == pytest.approx(e.approach, rel=1e-9)
    # a, b ~ P^(1/3) and delta ~ P^(2/3) exactly: rounding of the cube roots only
    scale = (1000.0 / 37.0) ** (1.0 / 3.0)
    assert heavy.a == pytest.approx(scale * light.a, rel=1e-12)
    assert heavy.b == pytest.approx(scale * light.b, rel=1e-12)
    assert heavy.approach == pytest.approx(scale**2 * light.approach, rel=1e-12)


@pytest.mark.parametrize("stage", [1, 2, 3])
@pytest.mark.parametrize("roll_deg", [-4.0, 0.0, 3.0])
def test_relative_curvature_is_pinion_shaper_plus_a_line_contact(gearset, stage, roll_deg):
    """Uncrowned pinion: the face gear is the envelope of the shaper, so pinion-face gear
    = (pinion - shaper) + (shaper - face gear), exactly.

    - pinion and shaper are involute cylinders touching along a line of the common axis
      direction z, with the same normal: their relative curvature is
      k_p = 1/rho_p - 1/rho_s across (along e = z x n), 0 along z, where rho is the
      distance to each base circle's tangency point on the common line of action
      (pitch circles internally tangent: rho_s - rho_p = (r_s - r_p) sin alpha0);
    - shaper and face gear touch along a line (the contact line of generation): their
      relative curvature is a rank-one tensor, zero along that line. From the meshing
      equation u_s = r_bs N_2/(N_s cos g) on the shaper's involute (arc length
      r_bs theta d theta), the line leaves the axis at tan psi = theta cos^2(g)
      (N_s/N_2) / sin(g), with g = alpha0 on the path of contact (u_s = r_2).

    So the TCA's relative curvature minus k_p e e^T must be singular with its null
    direction at psi from the axis, and the relative curvature along that direction is
    k_p sin^2(psi): at roll 0 (theta = tan alpha0) the estimate (1/r_p - 1/r_s)
    sin^2(psi_c) / sin(alpha0), tan psi_c = (N_s/N_2) cos(alpha0), and an upper bound of
    lambda_min (Rayleigh quotient). Tolerances: the curvatures are central second
    differences with a 10 um step, each good to ~1e-5 1/m (tca module notes; the
    pinion's measured 3e-5 1/m in the test above): 1e-3 1/m for sums of them, against
    k_p sin^2(psi) ~ 0.5-1.5 1/m and the line-contact curvature ~ 100 1/m; the null
    direction then turns by at most 1e-3 / 100 rad, checked to 1e-3 rad.
    """
    pair = GearPair.from_gearset(gearset, stage)
    plain = GearPair(dataclasses.replace(pair.pinion, lengthwise_crowning=0.0), pair.face)
    c = plain.contact(np.radians(roll_deg))
    p, f = plain.pinion, plain.face
    a0 = np.radians(20.0)
    rho_p = np.sqrt(np.hypot(c.point[0], c.point[1] - p.pitch_radius) ** 2
                    - p.base_radius**2)
    rho_s = rho_p + (f.shaper_pitch_radius - p.pitch_radius) * np.sin(a0)
    k_p = 1.0 / rho_p - 1.0 / rho_s
    theta = rho_s / f.shaper_base_radius
    psi = np.arctan(theta * np.cos(a0) ** 2 * f.shaper_teeth / f.teeth / np.sin(a0))
    # the relative curvature tensor in the tangent basis (axis z, e = z x n)
    axis = np.array([0.0, 0.0, 1.0])
    assert abs(axis @ c.normal) < 1e-12  # an involute cylinder's normal is across its axis
    e = np.cross(axis, c.normal)
    e /= np.linalg.norm(e)
    r = c.relative
    full = (r.lambda_min * np.outer(r.major, r.major)
            + r.lambda_max * np.outer(r.minor, r.minor))
    basis = np.stack([axis, e])
    tensor = basis @ full @ basis.T
    w, v = np.linalg.eigh(tensor - np.diag([0.0, k_p]))
    assert abs(w[0]) < 1e-3
    assert w[1] > 10.0  # a real line contact across, not a second null direction
    line = v[:, 0]
    assert np.arccos(abs(line[0])) == pytest.approx(psi, abs=1e-3)
    along = line @ tensor @ line
    assert along == pytest.approx(k_p * np.sin(psi) ** 2, abs=1e-3)
    assert r.lambda_min <= along + 1e-3
    if roll_deg == 0.0:
        psi_c = np.arctan(f.shaper_teeth / f.teeth * np.cos(a0))
        estimate = ((1 / p.pitch_radius - 1 / f.shaper_pitch_radius)
                    * np.sin(psi_c) ** 2 / np.sin(a0))
        assert along == pytest.approx(estimate, abs=1e-3)


def test_transmission_error_of_unmodified_pair_is_zero(gearset):
    """Without crowning the face gear is conjugate to the shaper, and the pinion to the
    shaper (same base pitch): the pinion turns the face gear at exactly N_p/N_2.
    Tolerance: the Newton tolerance 1e-13 module of rotation ~ 4e-15 rad, times a
    hundred for the conditioning of the 5x5 system."""
    pair = GearPair.from_gearset(gearset, 1)
    plain = GearPair(dataclasses.replace(pair.pinion, lengthwise_crowning=0.0), pair.face)
    path = plain.path(n=21)
    assert len(path.points) == 21
    assert np.abs(path.transmission_error).max() < 1e-12
    assert path.on_flank.all()
    # one angular pitch, centred on the pitch-point position
    assert path.roll_angles[-1] - path.roll_angles[0] == pytest.approx(2 * np.pi / 19)


def test_path_of_contact_lies_in_the_plane_of_the_design_point(gearset):
    """The pinion touches the shaper on its line of action, where the shaper's involute
    has gamma = alpha0, and the meshing equation then gives u_s = r_bs N_2 / (N_s
    cos alpha0) = r_2 for every roll angle: the path lies in the plane z = r_2, on the
    line of action through the pitch point at alpha0 (crowning vertex at z = r_2, so
    the crowned pinion has the same path and no transmission error)."""
    pair = GearPair.from_gearset(gearset, 2)
    path = pair.path(n=11)
    pts = path.positions
    np.testing.assert_allclose(pts[:, 2], pair.face.pitch_radius, rtol=0, atol=1e-12)
    # the line of action of involutes is the fixed common normal (cos a0, sin a0, 0)
    # through the pitch point: no component across it, and the normal never turns
    a0 = np.radians(20.0)
    np.testing.assert_allclose(-pts[:, 0] * np.sin(a0) + pts[:, 1] * np.cos(a0), 0.0,
                               atol=1e-12)
    for c in path.points:
        np.testing.assert_allclose(c.normal, [np.cos(a0), np.sin(a0), 0.0], atol=1e-12)
    assert np.abs(path.transmission_error).max() < 1e-12


def test_lever_arms_and_effective_mass(gearset):
    """At the pitch point the pinion's lever arm is its base radius (the involute normal
    is tangent to the base circle) and the face gear's is r_2 cos(alpha0)."""
    pair = GearPair.from_gearset(gearset, 1)
    c = pair.contact(0.0)
    m = pair.effective_masses(c, 1.96e-4, 7.15e-3)
    assert m["pinion_lever"] == pytest.approx(pair.pinion.base_radius, rel=1e-12)
    assert m["face_lever"] == pytest.approx(0.084 * np.cos(np.radians(20)), rel=1e-12)
    m1, m2 = 1.96e-4 / m["pinion_lever"] ** 2, 7.15e-3 / m["face_lever"] ** 2
    assert m["effective_mass"] == pytest.approx(m1 * m2 / (m1 + m2), rel=1e-14)


def test_equivalent_radius_reproduces_the_ellipse_stiffness(gearset):
    """The sphere with the equivalent radius needs the same load for the approach of
    the elliptical contact, at any load (both follow P ~ delta^1.5)."""
    c = GearPair.from_gearset(gearset, 1).contact(0.0)
    radius = equivalent_radius(c.relative, E_STAR)
    for force in (37.0, 1000.0):
        delta = contact_ellipse(c.relative, force, E_STAR).approach
        assert hertz.sphere_force(delta, radius, E_STAR) == pytest.approx(force, rel=1e-10)


@pytest.mark.parametrize("stage", [0, 4, 1.5, True])
def test_invalid_stage(gearset, stage):
    with pytest.raises(GeometryError, match="stage"):
        GearPair.from_gearset(gearset, stage)
