"""Involute spur pinion: thickness, involute accuracy, fillet, crowned surface."""

import numpy as np
import pytest
from scipy.optimize import brentq

from fe_impact.errors import GeometryError
from fe_impact.gears import PinionTooth

M = 3e-3


@pytest.fixture
def tooth():
    """The seed pinion (z = 19, m = 3 mm, 20 deg, ha* = 1, c* = 0.25, rho_f = 0.38 m)."""
    return PinionTooth(19, M, 20.0, 1.0, 0.25, 0.38, 24e-3)


def _polar(points):
    return np.hypot(points[..., 0], points[..., 1]), np.arctan2(points[..., 0], points[..., 1])


def test_tooth_thickness_at_pitch_circle(tooth):
    """Find where each flank of the evaluated surface crosses the pitch circle and
    measure the arc between them: pi m / 2 for a standard tooth."""
    r_p = tooth.pitch_radius

    def crossing(side):
        def f(theta):
            return np.hypot(*tooth.flank_surface(0.0, theta, side).points[:2]) - r_p

        theta = brentq(f, tooth.theta_form, tooth.theta_tip, xtol=1e-15)
        return _polar(tooth.flank_surface(0.0, theta, side).points[:2])[1]

    thickness = r_p * (crossing(1) - crossing(-1))
    # brentq to 1e-15 rad of roll angle moves the crossing by < 1e-17 m
    assert abs(thickness - np.pi * M / 2) < 1e-15
    assert abs(tooth.tooth_thickness(r_p) - np.pi * M / 2) < 1e-16


def test_involute_matches_analytic_polar_form(tooth):
    """Profile points against the involute in polar form: at radius r the roll
    angle is sqrt((r/r_b)^2 - 1) and the polar angle pi/(2z) + inv(alpha0) -
    (theta - atan theta)."""
    profile = tooth.transverse_profile(n_flank=400)
    z, alpha = tooth.teeth, np.radians(20.0)
    for name, sign in (("flank_right", 1), ("flank_left", -1)):
        r, sigma = _polar(profile.segment(name).points)
        theta = np.sqrt((r / tooth.base_radius) ** 2 - 1.0)
        sigma_exact = np.pi / (2 * z) + np.tan(alpha) - alpha - (theta - np.arctan(theta))
        error = np.abs(r * (sign * sigma - sigma_exact))
        # arc-length error, rounding level: ~30 mm radii times a few ulps of
        # the angles (measured 7e-18 m); theta from the radius is the least
        # accurate step near the base circle (d theta / d r = 1 / (r_b theta))
        assert error.max() < 1e-15
    assert abs(r.min() - tooth.form_radius) < 1e-15
    assert abs(r.max() - tooth.tip_radius) < 1e-15


def test_involute_normal_and_curvature(tooth):
    theta = np.linspace(0.1, tooth.theta_tip, 9)
    step = 1e-4
    p = [tooth.involute_point(theta + k * step) for k in (-1, 0, 1)]
    d1 = (p[2] - p[0]) / (2 * step)
    d2 = (p[2] - 2 * p[1] + p[0]) / step**2
    speed = np.linalg.norm(d1, axis=1)
    curvature = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed**3
    # second differences: truncation O(step^2) ~ 1e-8 relative, rounding
    # eps * r / step^2 ~ 7e-10 m against |d2| ~ r_b ~ 0.03 m, i.e. ~2e-8; 1e-6
    # is well above both
    np.testing.assert_allclose(curvature, tooth.involute_curvature(theta), rtol=1e-6)
    # tangent by central differences with a step balancing truncation
    # (step^2 / 6 relative) and rounding (eps r / step against |d1| >= 2.7e-3 m)
    step = 1e-5
    d1 = (tooth.involute_point(theta + step) - tooth.involute_point(theta - step)) / (2 * step)
    n = tooth.involute_normal(theta)
    assert np.abs(np.sum(n * d1, axis=1) / np.linalg.norm(d1, axis=1)).max() < 1e-8
    # outward: away from the tooth's centre line x = 0 on the right flank
    assert (n[:, 0] > 0).all()


def test_fillet_joins_involute_and_reaches_root(tooth):
    points, normals = tooth.fillet(200)
    # same analytic point reached by two routes (rack flank tangency / involute)
    np.testing.assert_allclose(points[0], tooth.involute_point(tooth.theta_form), atol=1e-17)
    np.testing.assert_allclose(normals[0], tooth.involute_normal(tooth.theta_form), atol=1e-14)
    r, sigma = _polar(points)
    assert abs(r[-1] - tooth.root_radius) < 1e-17
    assert r.min() >= tooth.root_radius - 1e-17 and (np.diff(r) < 0).all()
    assert sigma[-1] < np.pi / tooth.teeth  # ends before the space centre
    # the fillet normals are perpendicular to the curve (central differences)
    tangent = points[2:] - points[:-2]
    cos = np.sum(tangent * normals[1:-1], axis=1) / np.linalg.norm(tangent, axis=1)
    assert np.abs(cos).max() < 1e-3  # chord vs tangent: O(h * curvature) with 200 points


def test_profile_is_continuous_and_symmetric(tooth):
    profile = PinionTooth(19, M, lengthwise_crowning=10e-6, profile_crowning=5e-6)
    for u in (0.0, 0.012):
        prof = profile.transverse_profile(u=u)
        segs = prof.segments
        for a, b in zip(segs[:-1], segs[1:], strict=True):
            assert np.abs(a.points[-1] - b.points[0]).max() < 1e-17
        left, right = prof.segment("flank_left").points, prof.segment("flank_right").points
        np.testing.assert_allclose(left[:, 0], -right[::-1, 0], atol=1e-17)
        r, sigma = _polar(prof.points)
        assert abs(sigma[0] + np.pi / 19) < 1e-15 and abs(sigma[-1] - np.pi / 19) < 1e-15
    with pytest.raises(GeometryError, match="pick one of"):
        prof.segment("flank")


def test_crowning_relief_and_normal():
    c_l, c_p = 10e-6, 5e-6
    plain = PinionTooth(19, M, face_width=24e-3)
    crowned = PinionTooth(19, M, face_width=24e-3, lengthwise_crowning=c_l, profile_crowning=c_p)
    u = np.array([0.0, 0.012, -0.012, 0.006])[:, None]
    theta = np.array([plain.theta_pitch, plain.theta_tip, 0.2])[None, :]
    a, b = plain.flank_surface(u, theta), crowned.flank_surface(u, theta)
    removed = np.sum((a.points - b.points) * a.normals, axis=-1)
    t_frac = (theta - plain.theta_pitch) / (plain.theta_tip - plain.theta_pitch)
    expected = c_l * (2 * u / 24e-3) ** 2 + c_p * t_frac**2
    # differences of ~0.03 m coordinates: a few ulps (7e-18 m each)
    np.testing.assert_allclose(removed, expected, rtol=0, atol=3e-17)
    assert removed[1, 1] == pytest.approx(c_l + c_p, abs=3e-17)  # face end, tip
    # exact normal of the crowned surface vs central differences (step 1e-6 in
    # u [m] and theta [rad]: truncation ~1e-9, rounding ~1e-10)
    step = 1e-6

    def pts(du, dt):
        return crowned.flank_surface(u + du, theta + dt).points

    n = np.cross(
        (pts(step, 0) - pts(-step, 0)) / (2 * step), (pts(0, step) - pts(0, -step)) / (2 * step)
    )
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    n *= np.sign(np.sum(n * b.normals, axis=-1))[..., None]
    assert np.abs(n - b.normals).max() < 1e-8
    # left flank is the mirror image
    left = crowned.flank_surface(u, theta, side=-1)
    np.testing.assert_array_equal(left.points[..., 0], -b.points[..., 0])


def test_flank_grid_shape(tooth):
    grid = tooth.flank_grid(5, 7, side=-1)
    assert grid.points.shape == (5, 7, 3) and grid.normals.shape == (5, 7, 3)
    assert grid.points[..., 2].min() == -12e-3 and (grid.points[..., 0] < 0).all()


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"teeth": 16}, "teeth"),
        ({"fillet_radius_coeff": 0.5}, "fillet_radius_coeff"),
        ({"fillet_radius_coeff": 0.0}, "fillet_radius_coeff"),
        ({"module": -1.0}, "module"),
        ({"lengthwise_crowning": 1e-3}, "lengthwise_crowning"),
        ({"pressure_angle_deg": 50.0}, "pressure_angle_deg"),
    ],
)
def test_invalid_pinion_tooth(kwargs, field):
    args = {"teeth": 19, "module": M, **kwargs}
    with pytest.raises(GeometryError, match=f"PinionTooth.{field}"):
        PinionTooth(**args)
