"""Half-space influence coefficients and the near-field pressure solve.

Truths: Love's centre displacement of a square cell (Johnson 1985, section 3.4),
a direct numerical quadrature of 1/r over the cell, Boussinesq's point load
far from it, and Hertz's sphere on a half-space (Johnson 1985, section 4.2).
"""

import numpy as np
import pytest
from scipy import integrate

from fe_impact.contact import nearfield as nf
from fe_impact.physics import hertz

E, NU, R = 212e9, 0.289, 10e-3


def test_square_cell_centre_matches_love_closed_form():
    # 8 (1 - nu^2) p a ln(1 + sqrt 2) / (pi E), a the half-side: exact, so
    # only rounding separates the two (1e-12).
    a, p = 37e-6, 1.3e9
    w = p * (1 - NU ** 2) / (np.pi * E) * nf.love_rectangle(0.0, 0.0, a, a)
    assert w == pytest.approx(8 * (1 - NU ** 2) * p * a * np.log(1 + np.sqrt(2)) / (np.pi * E),
                              rel=1e-12)


@pytest.mark.parametrize("x, y", [(0.3, 1.7), (0.2, 0.1), (-2.5, 0.4)])
def test_rectangle_matches_quadrature(x, y):
    # adaptive quadrature of the integrable 1/r over the cell (points inside
    # and outside it); quad's own tolerance is 1e-10
    a, b = 1.0, 0.5
    v, _ = integrate.dblquad(lambda t, s: 1 / np.hypot(x - s, y - t), -a, a, -b, b,
                             epsabs=1e-11, epsrel=1e-11)
    assert nf.love_rectangle(x, y, a, b) == pytest.approx(v, rel=1e-7)


def test_rectangle_far_field_is_boussinesq():
    # at r = 50 half-sides the multipole correction to P / r is below
    # a^2 / (2 r^2) = 2e-4: tolerance 5e-4
    a, b = 1.0, 0.7
    x, y = 40.0, 30.0
    assert nf.love_rectangle(x, y, a, b) == pytest.approx(4 * a * b / np.hypot(x, y), rel=5e-4)


def test_fft_convolution_equals_dense_sum():
    g = nf.Grid.centred(1e-3, 0.6e-3, 9, 7)
    conv = nf.Convolution(g, nf.surface_kernel(g, 1e11))
    X, Y = g.centres()
    dense = np.array([[nf.love_rectangle(X.ravel()[i] - X.ravel()[j], Y.ravel()[i] - Y.ravel()[j],
                                         g.dx / 2, g.dy / 2) for j in range(X.size)]
                      for i in range(X.size)]) / (np.pi * 1e11)
    p = np.random.default_rng(1).random(g.shape) * 1e9
    assert np.allclose(conv.apply(p).ravel(), dense @ p.ravel(), rtol=1e-10, atol=0)
    assert np.allclose(conv.dense(), dense, rtol=1e-12, atol=0)


@pytest.fixture(scope="module")
def hertz_1kn():
    e_star = nf.effective_modulus(E, NU, E, NU)
    c = hertz.sphere_contact(1000.0, R, e_star)
    g = nf.Grid.centred(1.3 * c.a, 1.3 * c.a, 128, 128)
    X, Y = g.centres()
    conv = nf.Convolution(g, nf.surface_kernel(g, e_star))
    return c, g, (X ** 2 + Y ** 2) / (2 * R), conv


def test_sphere_on_half_space_is_hertz(hertz_1kn):
    # 128 cells across 2.6 a (a / h = 49): the approach and p0 converge as
    # (h/a)^2 (1e-3 scale), the counted contact radius to half a cell
    # (h / 2a = 1%): tolerances 0.5%, 1% and 2% set from these orders.
    c, g, h, conv = hertz_1kn
    s = nf.solve_pressure(h, conv.apply, 1000.0, g.cell_area)
    assert s.approach == pytest.approx(c.a ** 2 / R, rel=5e-3)
    assert s.pressure.max() == pytest.approx(c.p0, rel=1e-2)
    assert s.contact_radius(g) == pytest.approx(c.a, rel=2e-2)
    assert s.pressure.min() >= 0.0
    assert s.pressure.sum() * g.cell_area == pytest.approx(1000.0, rel=1e-12)


def test_given_approach_gives_hertz_force(hertz_1kn):
    c, g, h, conv = hertz_1kn
    s = nf.solve_approach(h, conv.apply, c.a ** 2 / R, g.cell_area, force_guess=300.0)
    assert s.approach == pytest.approx(c.a ** 2 / R, rel=1e-8)
    assert s.force == pytest.approx(1000.0, rel=5e-3)
