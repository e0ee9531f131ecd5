"""Lumped contact laws: ADAMS STEP/IMPACT, hysteresis models, 1-DOF impacts."""

import numpy as np
import pytest

from fe_impact.physics import hertz, laws

E_STAR = hertz.effective_modulus(212e9, 0.289)
R = 0.01
K = hertz.sphere_stiffness(R, E_STAR)
MASS = 0.5

MODELS = ["hunt-crossley", "lankarani-nikravesh", "flores", "gonthier", "zhiying-qishao"]
TARGETS = [0.3, 0.5, 0.7, 0.9]
# DESIGN section 5: restitution each model produces for the target e.
DESIGN_TABLE = {
    "hunt-crossley": [0.581, 0.663, 0.768, 0.909],
    "lankarani-nikravesh": [0.684, 0.725, 0.796, 0.913],
    "flores": [0.256, 0.470, 0.683, 0.894],
    "gonthier": [0.304, 0.488, 0.670, 0.876],
    "zhiying-qishao": [0.327, 0.483, 0.680, 0.896],
}


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


def test_impact_law_matches_the_adams_convention():
    rng = np.random.default_rng(0)
    h = rng.uniform(-1e-4, 3e-4, 200)
    hdot = rng.uniform(-0.5, 0.5, 200)
    law = laws.ImpactLaw(k=1e10, exponent=1.5, cmax=5e4, d=1e-4)
    x1 = 0.002
    adams = laws.impact_force(x1 - h, -hdot, x1, law.k, law.exponent, law.cmax, law.d)
    # x1 - h loses a few ulps of x1 relative to h: force agrees to ~1e-9.
    np.testing.assert_allclose(law.force(h, hdot), adams, rtol=1e-9, atol=1e-9)


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


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("index", range(len(TARGETS)))
def test_restitution_table_of_design(model, index):
    # The table is rounded to 3 digits (error <= 5e-4); simulated e is good
    # to ~1e-9, so 1e-3 only absorbs the rounding.
    produced = laws.restitution_of(model, TARGETS[index])
    assert produced == pytest.approx(DESIGN_TABLE[model][index], abs=1e-3)


@pytest.mark.parametrize("speed", [0.1, 1.0])
def test_undamped_law_reproduces_hertz_impact(speed):
    run = laws.simulate_impact(laws.HysteresisLaw(K, 1.5, 0.0, speed), MASS, speed)
    reference = hertz.impact(MASS, speed, R, E_STAR)
    # Integrated at rtol 1e-11 with events: measured errors are ~1e-11.
    assert run.restitution == pytest.approx(1.0, abs=1e-6)
    assert run.force_max == pytest.approx(reference.force_max, rel=1e-4)
    assert run.delta_max == pytest.approx(reference.delta_max, rel=1e-4)
    assert run.contact_time == pytest.approx(reference.contact_time, rel=1e-4)
    assert run.separation_time == pytest.approx(run.contact_time, rel=1e-8)


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
    delta_max = hertz.impact(MASS, speed, R, E_STAR).delta_max
    cmax = laws.closed_form_cmax(K, 0.7, speed, delta_max)
    law = laws.ImpactLaw(k=K, exponent=1.5, cmax=cmax, d=d_fraction * delta_max)
    # DESIGN gives two digits; measured 0.6103 and 0.3364.
    assert laws.simulate_impact(law, MASS, speed).restitution == pytest.approx(design_e, abs=5e-3)


def test_closed_form_cmax_is_the_zhiying_qishao_damping_at_delta():
    cmax = laws.closed_form_cmax(K, 0.7, 0.1, 1e-5)
    expected = 3 * K * (1 - 0.49) * np.exp(0.6) / (4 * 0.1) * 1e-5**1.5
    assert cmax == pytest.approx(expected, rel=1e-14)  # same formula, round-off
    assert laws.closed_form_cmax(K, 1.0, 0.1, 1e-5) == 0.0


def test_closed_form_penetration_depth_is_the_hertz_approach():
    depth = laws.closed_form_penetration_depth(1000.0, R, E_STAR)
    # Two algebraic forms of one expression: round-off only.
    assert depth == pytest.approx(hertz.sphere_contact(1000.0, R, E_STAR).delta, rel=1e-13)


def test_simulate_impact_rejects_a_non_positive_speed():
    with pytest.raises(ValueError, match="speed"):
        laws.simulate_impact(laws.HysteresisLaw(K, 1.5, 0.0, 0.1), MASS, 0.0)
