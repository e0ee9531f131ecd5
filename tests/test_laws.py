"""Lumped contact laws: ADAMS STEP/IMPACT, hysteresis models, 1-DOF impacts, seed eqs."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from fe_impact.physics import hertz, laws, seed
from fe_impact.physics.impact_law import impact_force_energy, unit_step

E_STAR = hertz.effective_modulus(212e9, 0.289)
R = 0.01
K = hertz.sphere_stiffness(R, E_STAR)
MASS = 0.5

MODELS = ["hunt-crossley", "lankarani-nikravesh", "flores", "gonthier", "zhiying-qishao"]
TARGETS = [0.3, 0.5, 0.7, 0.9]
# Restitution each model produces for the target e, to three digits as usually quoted;
# docs/references.md ("Lumped impact laws") gives them from the exact phase-plane relation.
THREE_DIGIT_TABLE = {
    "hunt-crossley": [0.581, 0.663, 0.768, 0.909],
    "lankarani-nikravesh": [0.684, 0.725, 0.796, 0.913],
    "flores": [0.256, 0.470, 0.683, 0.894],
    "gonthier": [0.304, 0.488, 0.670, 0.876],
    "zhiying-qishao": [0.327, 0.483, 0.680, 0.896],
}
# chi(e) of each model evaluated by hand from its paper's formula
# (docs/references.md, "Lumped impact laws"),
# at e = 0.7: 3(0.3)/2; 3(0.51)/4; 8(0.3)/(5*0.7); 0.51/0.7; 3(0.51) exp(0.6)/4.
CHI_AT_07 = {"hunt-crossley": 0.45, "lankarani-nikravesh": 0.3825,
             "flores": 0.6857142857, "gonthier": 0.7285714286, "zhiying-qishao": 0.6969604411}


def exact_restitution(chi):
    """Restitution of ``F = K x^n (1 + chi x' / v0)`` from the phase-plane relation.

    ``m v dv/dx = -K x^n (1 + chi v / v0)`` integrates over the closed contact
    (x back to 0) to ``-chi e - ln(1 - chi e) = chi - ln(1 + chi)`` whatever
    n, K, m and v0 (docs/references.md: Marhefka and Orin 1999). Solved here
    by bisection-safe root finding, independently of any integrator.
    """
    if chi == 0.0:
        return 1.0
    rhs = chi - math.log1p(chi)
    upper = min(1.0, (1.0 - 1e-15) / chi)
    return brentq(lambda e: -chi * e - math.log1p(-chi * e) - rhs, 0.0, upper, xtol=1e-15)


def test_step_endpoints_and_midpoint():
    x = np.array([-1.0, 0.0, 0.5, 1.0, 2.0])
    # A cubic with exactly representable coefficients: exact in floating point.
    np.testing.assert_array_equal(laws.step(x, 0.0, 1.0, 1.0, 3.0), [1.0, 1.0, 2.0, 3.0, 3.0])
    assert laws.step(0.25, 0.0, 0.0, 1.0, 1.0) == pytest.approx(0.15625, rel=1e-15)


def test_step_is_c1_and_its_second_derivative_jumps():
    x0, x1, h0, h1, h = 0.2, 1.4, -1.0, 2.0, 1e-5
    span = x1 - x0
    for end in (x0, x1):
        left = (laws.step(end, x0, h0, x1, h1) - laws.step(end - h, x0, h0, x1, h1)) / h
        right = (laws.step(end + h, x0, h0, x1, h1) - laws.step(end, x0, h0, x1, h1)) / h
        # One-sided slopes vanish up to the cubic's curvature, 3 |h1 - h0| h / span^2.
        assert abs(left) <= 3 * abs(h1 - h0) * h / span**2 + 1e-9
        assert abs(right) <= 3 * abs(h1 - h0) * h / span**2 + 1e-9
    inside = laws.step(np.array([x0, x0 + h, x0 + 2 * h]), x0, h0, x1, h1)
    curvature = (inside[2] - 2 * inside[1] + inside[0]) / h**2
    # 6 (h1 - h0)/span^2 just inside, 0 just outside; FD error O(h) plus
    # round-off ~ eps / h^2 = 2e-6.
    assert curvature == pytest.approx(6 * (h1 - h0) / span**2, rel=1e-3)


def test_unit_step_is_the_symmetric_cubic():
    # STEP(z) + STEP(1 - z) = 1 and the end values are exact (the cubic's coefficients
    # are exactly representable; only the sum's rounding is left: 2 ulp).
    z = np.linspace(-0.5, 1.5, 401)
    values = np.array([unit_step(v) for v in z])
    mirrored = np.array([unit_step(1.0 - v) for v in z])
    np.testing.assert_allclose(values + mirrored, 1.0, rtol=0, atol=4.5e-16)
    assert unit_step(0.0) == 0.0 and unit_step(1.0) == 1.0
    assert np.all(values[z <= 0.0] == 0.0) and np.all(values[z >= 1.0] == 1.0)
    assert np.all(np.diff(values) >= 0.0)


def test_step_rejects_a_reversed_interval():
    with pytest.raises(ValueError, match="x0 < x1"):
        laws.step(0.5, 1.0, 0.0, 0.0, 1.0)


def test_impact_force_is_zero_outside_contact():
    force = laws.impact_force(
        np.array([1.0, 1.5, 2.0]), np.array([-5.0, 5.0, 0.0]), 1.0, 1e9, 1.5, 1e3, 1e-3
    )
    np.testing.assert_array_equal(force, 0.0)


def test_impact_force_damping_ramps_in_over_d():
    k, n, cmax, d, x1 = 1e9, 1.5, 2e4, 1e-4, 0.0
    closing = -0.1  # xdot < 0: the distance shrinks
    for penetration, weight in [(0.25 * d, 0.15625), (0.5 * d, 0.5), (d, 1.0), (3 * d, 1.0)]:
        force = laws.impact_force(x1 - penetration, closing, x1, k, n, cmax, d)
        expected = k * penetration**n - weight * cmax * closing
        # Closed-form STEP weights: round-off only.
        assert force == pytest.approx(expected, rel=1e-13)


def test_impact_force_is_clamped_while_opening_fast():
    assert laws.impact_force(-1e-6, 1e3, 0.0, 1e9, 1.5, 1e6, 1e-6) == 0.0


@pytest.mark.parametrize(
    ("h", "hdot", "expected"),
    [
        # k h^1.5 with k = 1e10: 1e10 (5e-5)^1.5 = 3535.5339; STEP weight 1/2 at h = d/2
        (5e-5, 0.2, 3535.5339059 + 0.5 * 5e4 * 0.2),
        (5e-5, -0.1, 3535.5339059 - 0.5 * 5e4 * 0.1),  # opening: damping pulls
        # beyond d the full cmax: 1e10 (2e-4)^1.5 = 28284.271247
        (2e-4, -0.3, 28284.271247 - 5e4 * 0.3),
        (2e-4, -1.0, 0.0),  # 28284 - 50000 < 0: clamped
        (-1e-5, 0.5, 0.0),  # apart
    ],
)
def test_impact_law_in_both_conventions(h, hdot, expected):
    # Penetration form and ADAMS form (distance x = x1 - h, rate xdot = -hdot) against the
    # force worked by hand; the hand values carry 8 significant digits.
    law = laws.ImpactLaw(k=1e10, exponent=1.5, cmax=5e4, d=1e-4)
    x1 = 0.002
    assert law.force(h, hdot) == pytest.approx(expected, rel=1e-8, abs=1e-6)
    adams = laws.impact_force(x1 - h, -hdot, x1, law.k, law.exponent, law.cmax, law.d)
    # x1 - h loses a few ulps of x1 relative to h: ~1e-12 relative in h.
    assert adams == pytest.approx(expected, rel=1e-8, abs=1e-6)


@pytest.mark.parametrize("exponent", [1.0, 1.5, 2.2])
def test_stored_energy_is_the_work_of_the_elastic_force(exponent):
    # impact_force_energy's energy against adaptive quadrature of its own force at rest
    # (hd = 0 leaves the elastic part only): quad is good to ~1e-14 here.
    k, h = 3e10, 4e-5
    _, energy = impact_force_energy(h, 0.0, k, exponent, 2e4, 1e-5)
    work, _ = quad(lambda s: impact_force_energy(s, 0.0, k, exponent, 2e4, 1e-5)[0], 0.0, h,
                   epsabs=0.0, epsrel=1e-13)
    assert energy == pytest.approx(work, rel=1e-12)
    assert impact_force_energy(-h, 0.3, k, exponent, 2e4, 1e-5) == (0.0, 0.0)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"k": -1.0, "exponent": 1.5, "cmax": 1.0, "d": 1e-4}, "k"),
        ({"k": 1.0, "exponent": 1.5, "cmax": -1.0, "d": 1e-4}, "cmax"),
        ({"k": 1.0, "exponent": 1.5, "cmax": 1.0, "d": 0.0}, "d"),
    ],
)
def test_impact_law_validates(kwargs, name):
    with pytest.raises(ValueError, match=name):
        laws.ImpactLaw(**kwargs)


def test_unknown_model_lists_the_choices():
    with pytest.raises(ValueError, match="hunt-crossley"):
        laws.hysteresis_factor("kelvin-voigt", 0.5)


@pytest.mark.parametrize("e", [0.0, -0.2, 1.2])
def test_restitution_out_of_range_is_rejected(e):
    with pytest.raises(ValueError, match="restitution"):
        laws.hysteresis_factor("flores", e)


@pytest.mark.parametrize("model", [*MODELS, "hertz"])
def test_every_model_is_undamped_at_e_equal_one(model):
    assert laws.hysteresis_factor(model, 1.0) == 0.0


def test_hysteresis_law_is_clamped_and_zero_out_of_contact():
    law = laws.HysteresisLaw(k=1e10, exponent=1.5, chi=2.0, impact_speed=0.1)
    force = law.force(np.array([-1e-6, 1e-6, 1e-6]), np.array([0.0, -0.1, 0.1]))
    assert force[0] == 0.0
    assert force[1] == 0.0  # 1 + chi hdot / v = -1: clamped
    assert force[2] == pytest.approx(3 * 1e10 * 1e-9, rel=1e-13)


def test_hysteresis_factors_are_the_published_formulas():
    # Hand-evaluated chi(e) at e = 0.7 (CHI_AT_07), 10 digits: 1e-9.
    for model, chi in CHI_AT_07.items():
        assert laws.hysteresis_factor(model, 0.7) == pytest.approx(chi, rel=1e-9), model


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("index", range(len(TARGETS)))
def test_restitution_table_of_the_hysteresis_models(model, index):
    # The 1-DOF integration (DOP853, rtol 1e-11) against the exact phase-plane relation:
    # they agree to ~1e-11, checked at 1e-8. The three-digit table is that relation
    # rounded: within half a unit of the third digit.
    exact = exact_restitution(laws.hysteresis_factor(model, TARGETS[index]))
    assert laws.restitution_of(model, TARGETS[index]) == pytest.approx(exact, abs=1e-8)
    assert abs(THREE_DIGIT_TABLE[model][index] - exact) <= 5e-4 + 1e-12


@pytest.mark.parametrize("exponent", [1.0, 1.5, 2.5])
def test_produced_restitution_does_not_depend_on_the_exponent(exponent):
    # The phase-plane relation holds for any n: Flores at e = 0.5 gives 0.47044 for all.
    produced = laws.restitution_of("flores", 0.5, exponent=exponent)
    assert produced == pytest.approx(exact_restitution(1.6), abs=1e-8)


def _undamped(kind, speed):
    if kind == "impact":
        return laws.ImpactLaw(K, 1.5, 0.0, 1e-6)
    return laws.HysteresisLaw(K, 1.5, 0.0, speed)


@pytest.mark.parametrize("kind", ["impact", "hysteresis"])
@pytest.mark.parametrize("speed", [0.1, 1.0])
def test_undamped_law_reproduces_hertz_impact(kind, speed):
    run = laws.simulate_impact(_undamped(kind, speed), MASS, speed)
    reference = hertz.impact(MASS, speed, R, E_STAR)
    # Johnson's closed forms (t_c = 2.94328 delta_max / v, F_max = K delta_max^1.5)
    # against the integration at rtol 1e-11 with events: measured errors are ~1e-11.
    assert run.restitution == pytest.approx(1.0, abs=1e-6)
    assert run.force_max == pytest.approx(reference.force_max, rel=1e-4)
    assert run.delta_max == pytest.approx(reference.delta_max, rel=1e-4)
    assert run.contact_time == pytest.approx(reference.contact_time, rel=1e-4)
    assert run.separation_time == pytest.approx(run.contact_time, rel=1e-8)
    # docs/references.md ("Hertz impact") quotes the same impact (R = 10 mm,
    # m = 0.5 kg): 11.04 um, 566 N,
    # 325 us at 0.1 m/s; 69.7 um, 8970 N, 205 us at 1 m/s (half a unit of the last digit).
    quoted = {0.1: (11.04e-6, 0.005e-6, 566.0, 0.5, 325e-6, 0.5e-6),
              1.0: (69.7e-6, 0.05e-6, 8970.0, 5.0, 205e-6, 0.5e-6)}[speed]
    assert run.delta_max == pytest.approx(quoted[0], abs=quoted[1])
    assert run.force_max == pytest.approx(quoted[2], abs=quoted[3])
    assert run.contact_time == pytest.approx(quoted[4], abs=quoted[5])


def test_undamped_impact_law_conserves_energy():
    # cmax = 0: kinetic + stored energy (impact_force_energy) is constant along the
    # trajectory; the dense output of DOP853 at rtol 1e-11 keeps it to ~1e-10.
    speed = 0.3
    law = laws.ImpactLaw(K, 1.5, 0.0, 1e-6)
    run = laws.simulate_impact(law, MASS, speed)
    stored = np.array([impact_force_energy(h, 0.0, K, 1.5, 0.0, 1e-6)[1] for h in run.delta])
    total = 0.5 * MASS * run.deltadot**2 + stored
    initial = 0.5 * MASS * speed**2
    assert np.max(np.abs(total - initial)) <= 1e-8 * initial
    assert run.restitution == pytest.approx(1.0, abs=1e-8)


@pytest.mark.parametrize(
    ("k", "mass", "speed"), [(1.0, 1.0, 1.0), (K, MASS, 0.1), (1e8, 3.0, 7.0)]
)
def test_restitution_is_independent_of_stiffness_mass_and_speed(k, mass, speed):
    law = laws.HysteresisLaw.from_model("hunt-crossley", 0.5, k=k, impact_speed=speed)
    # Same dimensionless problem each time: agreement to the integrator's
    # accuracy (~1e-9), checked at 1e-7.
    assert laws.simulate_impact(law, mass, speed).restitution == pytest.approx(
        laws.restitution_of("hunt-crossley", 0.5), rel=1e-7
    )


@pytest.mark.parametrize("model", MODELS)
def test_dissipated_energy_equals_the_kinetic_energy_lost(model):
    speed = 0.3
    law = laws.HysteresisLaw.from_model(model, 0.5, k=K, impact_speed=speed)
    run = laws.simulate_impact(law, MASS, speed, n_samples=4001)
    power = run.force * run.deltadot
    work = float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(run.time)))
    lost = 0.5 * MASS * speed**2 * (1 - run.restitution**2)
    initial = 0.5 * MASS * speed**2
    # Trapezoid rule on 4000 intervals: O(dt^2) ~ 1e-7 of the initial energy.
    assert work == pytest.approx(lost, abs=1e-5 * initial)
    assert np.all(run.force >= 0.0)


def test_strong_damping_lets_go_before_delta_returns_to_zero():
    chi = 100.0
    run = laws.simulate_impact(laws.HysteresisLaw(1.0, 1.5, chi, 1.0), 1.0, 1.0)
    # Force vanishes once hdot = -v/chi and cannot come back: the exit speed is
    # exactly v/chi, to the integrator's accuracy.
    assert run.restitution == pytest.approx(1 / chi, rel=1e-6)
    assert run.contact_time < 0.5 * run.separation_time
    assert run.time[-1] == run.separation_time
    assert run.delta[-2] > 0.0 and run.force[-2] >= 0.0


@pytest.mark.parametrize(("d_fraction", "design_e"), [(1.0, 0.61), (0.1, 0.34)])
def test_eq13_cmax_in_the_impact_form_loses_too_much(d_fraction, design_e):
    speed = 0.1
    delta_max = seed.max_approach(MASS, speed, K)
    cmax = seed.damping(K, 0.7, speed, delta_max)
    law = laws.ImpactLaw(k=K, exponent=1.5, cmax=cmax, d=d_fraction * delta_max)
    # docs/references.md ("Lumped impact laws") gives two digits; measured 0.6103 and 0.3364.
    assert laws.simulate_impact(law, MASS, speed).restitution == pytest.approx(design_e, abs=5e-3)


def test_eq13_damping_worked_by_hand():
    # K = 2e10 N/m^1.5, e = 0.7, v = 0.1 m/s, delta = 1e-5 m: chi = 0.75 (0.51) e^0.6 =
    # 0.69696044 (hand, 8 digits) and delta^1.5 = 3.1622777e-8, so
    # C_max = 0.69696044 * 2e10 * 3.1622777e-8 / 0.1 = 4407.9649 N s/m: 1e-6 for the rounding.
    assert seed.damping(2e10, 0.7, 0.1, 1e-5) == pytest.approx(4407.9649, rel=1e-6)
    assert seed.damping(2e10, 1.0, 0.1, 1e-5) == 0.0  # no loss, no damping


def test_eq16_is_the_energy_balance_of_a_hertz_impact():
    # m v^2 / 2 = (2/5) K delta^(5/2) at the turning point: the inverse relation.
    for speed in (1e-3, 0.1, 5.0):
        delta = seed.max_approach(MASS, speed, K)
        assert 0.4 * K * delta**2.5 == pytest.approx(0.5 * MASS * speed**2, rel=1e-14)
    speeds = np.array([1e-3, 0.1, 5.0])
    np.testing.assert_array_equal(seed.max_approach(MASS, speeds, K),
                                  [seed.max_approach(MASS, v, K) for v in speeds])


def test_eq17_is_the_hertz_approach():
    # docs/references.md ("Hertz contact"): R = 10 mm, P = 1000 N -> 16.141 um;
    # and delta = a^2 / R with
    # Johnson's contact radius a = (3PR/(4E*))^(1/3) (another algebraic form: 1e-13).
    depth = seed.penetration_depth(1000.0, R, 115.66e9)
    assert depth == pytest.approx(16.141e-6, abs=0.0005e-6)
    a = hertz.sphere_contact(1000.0, R, E_STAR).a
    assert seed.penetration_depth(1000.0, R, E_STAR) == pytest.approx(a**2 / R, rel=1e-13)


def test_eq12_and_eq15_are_johnsons():
    # Eq. 12 for R = 10 mm: (4/3) 115.66e9 * 0.1 = 1.54213e10 (6 digits); eq. 15 for
    # 20CrMnTi (Y = 835 MPa, rho = 7860, E* = 115.66 GPa): sqrt(26 Y^5/(rho E*^4)) =
    # 0.08662 m/s by hand (4 digits).
    assert seed.stiffness(R, 115.66e9) == pytest.approx(1.54213e10, rel=5e-6)
    assert seed.yield_speed(835e6, 7860.0, 115.66e9) == pytest.approx(0.08662, rel=1e-4)


def test_eq14_values_and_clamping():
    # Seed eq. 14 evaluated by hand: j = 10: 1 - 0.035 ln(10) 10^0.1645 = 0.8823 (4 digits).
    assert seed.restitution(10.0) == pytest.approx(0.8823, abs=5e-5)
    assert seed.restitution(np.array([0.0, 0.5, 1.0])).tolist() == [1.0, 1.0, 1.0]
    # The more the impact yields, the less it restitutes: e falls with j, from 1 at
    # j = 1 (continuous there) to the floor where the expression crosses zero, at
    # j = 2571 by hand (docs/references.md); before it the floor never acts.
    j = np.geomspace(1.0 + 1e-9, 2.5e3, 500)
    e = seed.restitution(j)
    assert e[0] == pytest.approx(1.0, abs=1e-9)
    assert np.all(np.diff(e) < 0.0)
    assert e[-1] > seed.RESTITUTION_FLOOR
    assert seed.restitution(2.6e3) == seed.restitution(1e4) == seed.RESTITUTION_FLOOR
    with pytest.raises(ValueError, match="yield_ratio"):
        seed.restitution(-1.0)


def test_simulate_impact_rejects_a_non_positive_speed():
    with pytest.raises(ValueError, match="speed"):
        laws.simulate_impact(laws.HysteresisLaw(K, 1.5, 0.0, 0.1), MASS, 0.0)
