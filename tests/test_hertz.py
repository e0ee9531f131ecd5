"""Hertz closed forms against docs/references.md and independent derivations."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipe, ellipk

from fe_impact.physics import hertz

E_STEEL = 212e9  # 20CrMnTi (docs/references.md: the seed paper, section 4)
NU_STEEL = 0.289
RHO_STEEL = 7860.0
E_STAR = 115.66e9  # the rounded value the reference check numbers are computed for


def test_effective_modulus_of_the_steel_pair():
    # docs/references.md: 115.66004 GPa, quoted as 115.66; half a unit of the last digit.
    assert hertz.effective_modulus(E_STEEL, NU_STEEL) == pytest.approx(115.66e9, abs=0.005e9)


def test_effective_modulus_of_two_materials_is_symmetric():
    # Same expression with the terms swapped: round-off only.
    one = hertz.effective_modulus(212e9, 0.289, 70e9, 0.33)
    assert one == pytest.approx(hertz.effective_modulus(70e9, 0.33, 212e9, 0.289), rel=1e-15)
    assert one == pytest.approx(1.0 / ((1 - 0.289**2) / 212e9 + (1 - 0.33**2) / 70e9), rel=1e-15)


def test_sphere_contact_check_values():
    # docs/references.md, sphere on flat (Johnson 1985, 4.2(a), computed): tolerances
    # half a unit of the last digit shown.
    contact = hertz.sphere_contact(1000.0, 0.01, E_STAR)
    assert contact.a * 1e6 == pytest.approx(401.75, abs=0.005)
    assert contact.b == contact.a
    assert contact.p0 / 1e6 == pytest.approx(2958.0, abs=0.5)
    assert contact.delta * 1e6 == pytest.approx(16.141, abs=0.0005)


@pytest.mark.parametrize("force", [1.0, 1000.0, 1e5])
def test_sphere_force_inverts_sphere_contact(force):
    # Two closed forms composed: only round-off separates them.
    contact = hertz.sphere_contact(force, 0.01, E_STAR)
    assert hertz.sphere_force(contact.delta, 0.01, E_STAR) == pytest.approx(force, rel=1e-12)
    stiffness = hertz.sphere_stiffness(0.01, E_STAR)
    assert stiffness * contact.delta**1.5 == pytest.approx(force, rel=1e-12)


def test_sphere_force_is_vectorised_and_zero_out_of_contact():
    force = hertz.sphere_force(np.array([[-1e-6, 0.0], [1e-6, 4e-6]]), 0.01, E_STAR)
    assert force.shape == (2, 2)
    assert force[0, 0] == 0.0 and force[0, 1] == 0.0
    assert force[1, 1] == pytest.approx(8.0 * force[1, 0], rel=1e-14)  # 4^1.5 = 8


def test_sphere_pressure_integrates_to_the_load():
    contact = hertz.sphere_contact(1000.0, 0.01, E_STAR)
    total, _ = quad(
        lambda r: 2 * np.pi * r * hertz.sphere_pressure(r, 1000.0, 0.01, E_STAR), 0, contact.a
    )
    # quad on a square-root edge singularity: converged far below 1e-8.
    assert total == pytest.approx(1000.0, rel=1e-8)
    pressure = hertz.sphere_pressure(np.array([0.0, 2 * contact.a]), 1000.0, 0.01, E_STAR)
    assert pressure[0] == pytest.approx(contact.p0, rel=1e-15)
    assert pressure[1] == 0.0


@pytest.mark.parametrize(
    ("Rx", "Ry", "a_um", "b_um", "p0_mpa", "delta_um"),
    [(0.1, 0.01, 1172.2, 260.5, 1563.6, 10.263), (1.0, 0.01, 3007.2, 165.3, 960.3, 5.889)],
)
def test_ellipse_contact_check_values(Rx, Ry, a_um, b_um, p0_mpa, delta_um):
    # docs/references.md, elliptical contact (computed): half a unit of the last digit.
    contact = hertz.ellipse_contact(1000.0, Rx, Ry, E_STAR)
    assert contact.a * 1e6 == pytest.approx(a_um, abs=0.05)
    assert contact.b * 1e6 == pytest.approx(b_um, abs=0.05)
    assert contact.p0 / 1e6 == pytest.approx(p0_mpa, abs=0.05)
    assert contact.delta * 1e6 == pytest.approx(delta_um, abs=0.0005)


@pytest.mark.parametrize("ratio", [1.5, 10.0, 100.0, 1000.0])
def test_ellipse_contact_satisfies_johnsons_legendre_relations(ratio):
    # Recheck with scipy's Legendre integrals (an independent evaluation of
    # the Carlson forms used inside); ellipk near m = 1 and the K - E
    # difference keep ~1e-10 here.
    Ry = 0.01
    Rx = ratio * Ry
    contact = hertz.ellipse_contact(1000.0, Rx, Ry, E_STAR)
    m = 1.0 - (contact.b / contact.a) ** 2
    K, E = ellipk(m), ellipe(m)
    A, B = 0.5 / Rx, 0.5 / Ry
    assert (E / (1 - m) - K) / (K - E) == pytest.approx(B / A, rel=1e-9)
    assert contact.p0 * contact.b * (K - E) / (E_STAR * contact.a**2 * m) == pytest.approx(
        A, rel=1e-9
    )
    assert 2 / 3 * np.pi * contact.a * contact.b * contact.p0 == pytest.approx(1000.0, rel=1e-12)
    assert contact.p0 * contact.b * K / E_STAR == pytest.approx(contact.delta, rel=1e-9)


def test_ellipse_contact_axis_convention_does_not_depend_on_argument_order():
    one = hertz.ellipse_contact(1000.0, 0.1, 0.01, E_STAR)
    assert one == hertz.ellipse_contact(1000.0, 0.01, 0.1, E_STAR)
    assert one.a > one.b


def test_ellipse_contact_tends_to_the_sphere():
    sphere = hertz.sphere_contact(1000.0, 0.01, E_STAR)
    assert hertz.ellipse_contact(1000.0, 0.01, 0.01, E_STAR) == sphere
    # Radii 1e-9 apart: the contact differs from the sphere's at that order
    # (the effective radius 2/(1/Rx + 1/Ry) moves by 5e-10), so 1e-8 is met
    # only if the near-circular solution has no cancellation error.
    near = hertz.ellipse_contact(1000.0, 0.01 * (1 + 1e-9), 0.01, E_STAR)
    for name in ("a", "b", "p0", "delta"):
        assert getattr(near, name) == pytest.approx(getattr(sphere, name), rel=1e-8)


def test_axial_displacement_at_the_surface_is_half_the_hertz_approach():
    contact = hertz.sphere_contact(1000.0, 0.01, hertz.effective_modulus(E_STEEL, NU_STEEL))
    u0 = hertz.axial_displacement(0.0, contact.a, contact.p0, E_STEEL, NU_STEEL)
    expected = np.pi * contact.p0 * contact.a * (1 - NU_STEEL**2) / (2 * E_STEEL)
    assert u0 == pytest.approx(expected, rel=1e-14)  # same formula at z = 0
    # Two identical bodies share the approach equally (round-off only).
    assert 2 * u0 == pytest.approx(contact.delta, rel=1e-12)


def test_axial_displacement_far_field_is_boussinesq():
    contact = hertz.sphere_contact(1000.0, 0.01, E_STAR)
    z = 1e4 * contact.a
    u = hertz.axial_displacement(z, contact.a, contact.p0, E_STEEL, NU_STEEL)
    point = 1000.0 * (1 + NU_STEEL) * (3 - 2 * NU_STEEL) / (2 * np.pi * E_STEEL * z)
    # The next term of the expansion is O((a/z)^2) = 1e-8 relative.
    assert u == pytest.approx(point, rel=1e-7)


def _boussinesq_on_axis(z, a, p0, E, nu):
    """u_z = P/(4 pi G) (z^2/rho^3 + 2 (1 - nu)/rho), integrated over the Hertz pressure."""
    G = E / (2 * (1 + nu))

    def ring(r):
        rho = np.hypot(r, z)
        kernel = (z**2 / rho**3 + 2 * (1 - nu) / rho) / (4 * np.pi * G)
        return p0 * np.sqrt(1 - (r / a) ** 2) * 2 * np.pi * r * kernel

    return quad(ring, 0.0, a, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def test_axial_displacement_matches_integrated_boussinesq():
    a, p0 = 4e-4, 3e9
    z = a * np.array([0.0, 0.1, 1.0, 1.999, 2.001, 5.0, 100.0])
    u = hertz.axial_displacement(z, a, p0, E_STEEL, NU_STEEL)
    assert u.shape == z.shape
    expected = [_boussinesq_on_axis(zi, a, p0, E_STEEL, NU_STEEL) for zi in z]
    # quad converges to ~1e-13; the closed form is exact: 1e-11 leaves margin,
    # and the points either side of z = 2a check the switch to the series.
    np.testing.assert_allclose(u, expected, rtol=1e-11)


def test_impact_contact_time_factor_is_the_energy_integral():
    integral, _ = quad(lambda x: 1 / np.sqrt(1 - x**2.5), 0, 1, epsabs=0, epsrel=1e-13)
    # quad on an inverse-square-root end singularity: good to ~1e-11.
    assert hertz.HERTZ_CONTACT_TIME_FACTOR == pytest.approx(2 * integral, rel=1e-10)
    assert hertz.HERTZ_CONTACT_TIME_FACTOR == pytest.approx(2.9433, abs=5e-5)


@pytest.mark.parametrize(
    ("speed", "delta_um", "force_n", "time_us"),
    # docs/references.md, Hertz impact: (value, half a unit of the last digit shown)
    [
        (0.1, (11.04, 0.005), (566.0, 0.5), (325.0, 0.5)),
        (1.0, (69.7, 0.05), (8970.0, 5.0), (205.0, 0.5)),
    ],
)
def test_impact_check_values(speed, delta_um, force_n, time_us):
    hit = hertz.impact(0.5, speed, 0.01, E_STAR)
    assert hit.delta_max * 1e6 == pytest.approx(delta_um[0], abs=delta_um[1])
    assert hit.force_max == pytest.approx(force_n[0], abs=force_n[1])
    assert hit.contact_time * 1e6 == pytest.approx(time_us[0], abs=time_us[1])


def test_impact_contact_time_power_law_of_design():
    m, v, R = 0.5, 0.3, 0.01
    hit = hertz.impact(m, v, R, E_STAR)
    # Johnson's 2.87 (docs/references.md) is 2.8683 rounded to 3 digits.
    assert hit.contact_time == pytest.approx(2.87 * (m**2 / (R * E_STAR**2 * v)) ** 0.2, rel=2e-3)
    assert hit.force_max == pytest.approx(hertz.sphere_force(hit.delta_max, R, E_STAR), rel=1e-14)


def test_hunter_wave_loss_values():
    loss = hertz.hunter_wave_loss(np.array([0.1, 1.0]), E_STEEL, RHO_STEEL)
    # docs/references.md (Hunter 1957): 0.00154 and 0.00613, checked to 2 significant
    # digits; the law itself is 1.04 (v/c0)^(3/5), so a decade of speed is 10^0.6.
    np.testing.assert_allclose(loss, [0.0015, 0.0061], atol=5e-5)
    assert loss[1] / loss[0] == pytest.approx(10**0.6, rel=1e-14)
    c0 = np.sqrt(E_STEEL / RHO_STEEL)
    assert loss[1] == pytest.approx(1.04 * (1.0 / c0) ** 0.6, rel=1e-14)
    assert hertz.hunter_wave_loss(0.0, E_STEEL, RHO_STEEL) == 0.0


@pytest.mark.parametrize("R", [1e-3, 0.1])
@pytest.mark.parametrize("Y", [300e6, 835e6])
def test_yield_onset_speed_is_johnsons_rounding_of_the_energy_form(R, Y):
    # Energy form for a solid sphere on a flat, first yield at p0 = 1.6 Y
    # (docs/references.md, yield onset): (1/2) m v^2 = (2/5) K delta_y^(5/2) gives
    # v^2 = 0.8^6 pi^4 Y^5 / (rho E*^4), 0.8^6 pi^4 = 25.535, where Johnson's
    # rho v_y^2 / Y = 26 (Y/E*)^4 has 26: the two differ by exactly sqrt(26/25.535),
    # at any radius and yield strength. Rounding only (1e-12).
    mass = 4 / 3 * np.pi * R**3 * RHO_STEEL
    delta_y = R * (np.pi * 1.6 * Y / (2 * E_STAR)) ** 2
    energy_form = np.sqrt(4 * hertz.sphere_stiffness(R, E_STAR) * delta_y**2.5 / (5 * mass))
    johnson = hertz.yield_onset_speed(Y, RHO_STEEL, E_STAR)
    assert johnson == pytest.approx(energy_form * np.sqrt(26 / (0.8**6 * np.pi**4)), rel=1e-12)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: hertz.effective_modulus(-1.0, 0.3), "E1"),
        (lambda: hertz.effective_modulus(1.0, 0.7), "nu1"),
        (lambda: hertz.sphere_contact(-1.0, 0.01, E_STAR), "force"),
        (lambda: hertz.sphere_contact(1.0, 0.0, E_STAR), "R"),
        (lambda: hertz.sphere_force(1e-6, 0.01, -E_STAR), "E_star"),
        (lambda: hertz.ellipse_contact(1.0, -0.1, 0.01, E_STAR), "Rx"),
        (lambda: hertz.ellipse_contact(1.0, 0.1, np.nan, E_STAR), "Ry"),
        (lambda: hertz.axial_displacement(-1e-3, 1e-3, 1e9, E_STEEL, NU_STEEL), "z"),
        (lambda: hertz.axial_displacement(1e-3, -1e-3, 1e9, E_STEEL, NU_STEEL), "a"),
        (lambda: hertz.impact(0.0, 0.1, 0.01, E_STAR), "mass"),
        (lambda: hertz.impact(0.5, -0.1, 0.01, E_STAR), "speed"),
        (lambda: hertz.hunter_wave_loss(-0.1, E_STEEL, RHO_STEEL), "speed"),
        (lambda: hertz.yield_onset_speed(835e6, -1.0, E_STAR), "rho"),
    ],
)
def test_invalid_input_names_the_parameter(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_seed_restitution_matches_the_quoted_values():
    # docs/references.md, the seed's eq. (14): 0.97, 0.93, 0.88, 0.79, 0.66 at
    # V/V_y = 2, 5, 10, 30, 100 (two decimals: half a unit of the last digit).
    from fe_impact.physics import seed

    for j, e in ((2, 0.97), (5, 0.93), (10, 0.88), (30, 0.79), (100, 0.66)):
        assert seed.restitution(j) == pytest.approx(e, abs=0.005)
    assert seed.restitution(0.5) == 1.0 and seed.restitution(1.0) == 1.0


def test_thornton_restitution_closed_form():
    # The closed form against the model integrated branch by branch for a steel
    # sphere (thornton_impact): the same model, so round-off only (1e-9).
    # docs/references.md (Thornton 1997) values are checked to two decimals.
    E_star, R, rho, p_y = 115.66e9, 0.01, 7860.0, 1.6 * 835e6
    m = 4.0 / 3.0 * np.pi * R ** 3 * rho
    v_y = hertz.thornton_impact(m, 1e-3, R, E_star, p_y).yield_speed
    # Thornton's v_y is the energy form, Johnson's with 0.8^6 pi^4 = 25.535 for 26
    # (p_y = 1.6 Y; docs/references.md, yield onset): exactly, to rounding
    assert v_y == pytest.approx(hertz.yield_onset_speed(835e6, rho, E_star)
                                * np.sqrt(0.8**6 * np.pi**4 / 26), rel=1e-12)
    for j in (1.5, 2.0, 5.0, 10.0, 30.0, 100.0):
        hit = hertz.thornton_impact(m, j * v_y, R, E_star, p_y)
        assert hertz.thornton_restitution(j) == pytest.approx(hit.restitution, rel=1e-9)
        assert 0.0 < hit.residual < hit.delta_max
    elastic = hertz.thornton_impact(m, 0.5 * v_y, R, E_star, p_y)
    assert elastic.restitution == 1.0 and elastic.residual == 0.0
    for j, e in ((2, 0.93), (5, 0.77), (10, 0.66), (30, 0.50), (100, 0.37)):
        assert hertz.thornton_restitution(j) == pytest.approx(e, abs=0.005)
    assert hertz.thornton_restitution(0.3) == 1.0
    # high-speed asymptote 1.185 (v/v_y)^-1/4 (Thornton 1997)
    assert hertz.thornton_restitution(1e6) == pytest.approx(1.185 * 1e6 ** -0.25, rel=1e-3)
    with pytest.raises(ValueError, match="yield_ratio"):
        hertz.thornton_restitution(-1.0)


def test_ellipse_yield_speed_is_the_spheres_for_a_sphere_and_reaches_yield():
    # A sphere of its own mass: Johnson's rho v_y^2 / Y = 26 (Y/E*)^4 (seed eq. 15),
    # whose constant is given to two digits (26 +- 0.5: 1% in v_y).
    import math

    E_star, Y, rho, R = 115.66e9, 835e6, 7860.0, 0.01
    mass = rho * 4.0 / 3.0 * math.pi * R**3
    v_y = hertz.ellipse_yield_speed(mass, R, R, E_star, Y)
    assert v_y == pytest.approx(hertz.yield_onset_speed(Y, rho, E_star), rel=0.01)
    # an ellipse: the Hertz impact at v_y peaks at 1.6 Y, to round-off
    Rx, Ry, m = 0.1e-3, 0.4, 0.25
    v_y = hertz.ellipse_yield_speed(m, Rx, Ry, E_star, Y)
    k = 1.0 / hertz.ellipse_contact(1.0, Rx, Ry, E_star).delta ** 1.5
    force = float(hertz.impact_from_stiffness(m, v_y, k).force_max)
    assert hertz.ellipse_contact(force, Rx, Ry, E_star).p0 == pytest.approx(1.6 * Y, rel=1e-9)


def test_layer_compression_of_an_ellipse():
    # Circle (a = b): the axisymmetric closed form u(0) - u(z) (Johnson 1985, 3.4,
    # hertz.axial_displacement), to the quadrature's 1e-9. A slender ellipse
    # (ellipse_contact's, b/a ~ 0.03): for z >> a the layer holds the whole surface
    # displacement u(0) = delta / 2 (two identical bodies) less Boussinesq's far
    # field P (1 + nu)(3 - 2 nu) / (2 pi E z), whose next term is O((a/z)^2) of it:
    # at z = 100 a, 1e-4 of the far field, 1e-6 of the whole.
    E, nu, p0 = 212e9, 0.289, 1e9
    for z in (1e-6, 2e-5, 1e-3):
        circle = hertz.axial_displacement(0.0, 1e-4, p0, E, nu) - \
            hertz.axial_displacement(z, 1e-4, p0, E, nu)
        assert hertz.ellipse_layer_compression(z, 1e-4, 1e-4, p0, E, nu) == \
            pytest.approx(circle, rel=1e-9)
    e_star = hertz.effective_modulus(E, nu)
    c = hertz.ellipse_contact(50.0, 1e-4, 0.4, e_star)
    a, b = max(c.a, c.b), min(c.a, c.b)
    assert b < 0.05 * a
    z = 100.0 * a
    far = 50.0 * (1.0 + nu) * (3.0 - 2.0 * nu) / (2.0 * np.pi * E * z)
    assert hertz.ellipse_layer_compression(z, a, b, c.p0, E, nu) == \
        pytest.approx(0.5 * c.delta - far, rel=1e-5)
    with pytest.raises(ValueError, match="z must be finite and > 0"):
        hertz.ellipse_layer_compression(0.0, a, b, p0, E, nu)
