"""Hertz closed forms: the analytic references the FE contact is checked against.

Every formula is for frictionless, linear-elastic, non-conforming bodies and
comes from K. L. Johnson, *Contact Mechanics*, Cambridge University Press,
1985 (chapters 3, 4 and 11) unless the docstring says otherwise. SI units
throughout: m, N, Pa, kg, s.

The two bodies are reduced to one effective modulus ``E_star`` and one
effective radius ``R`` (``1/R = 1/R1 + 1/R2``); impact uses the effective
mass ``m = m1 m2 / (m1 + m2)``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq
from scipy.special import beta, elliprd, elliprf

from fe_impact.physics.checks import require_poisson, require_positive

logger = logging.getLogger(__name__)

#: ``t_c v / delta_max`` for a Hertz impact: ``2 * (2/5) B(2/5, 1/2) = 2.94328``.
#: From energy conservation, ``t_c = 2 (delta_max / v) int_0^1 dx / sqrt(1 - x^(5/2))``;
#: the substitution ``u = x^(5/2)`` turns the integral into a Beta function.
HERTZ_CONTACT_TIME_FACTOR: float = float(2.0 * 0.4 * beta(0.4, 0.5))

# Beyond z/a = 2 the closed form of the axial displacement loses digits to
# cancellation; its asymptotic series then converges like (a/z)^2 <= 1/4 per term.
_SERIES_FROM = 2.0
_SERIES_TERMS = 30


def effective_modulus(
    E1: float, nu1: float, E2: float | None = None, nu2: float | None = None
) -> float:
    """Effective (contact) modulus of two elastic bodies.

    ``E* = 1 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2)`` (Johnson 1985, section 4.2).

    Parameters
    ----------
    E1, nu1 : float
        Young's modulus [Pa] and Poisson's ratio [-] of the first body.
    E2, nu2 : float, optional
        Same for the second body; each defaults to the first body's value.

    Returns
    -------
    float
        E* [Pa].

    Examples
    --------
    >>> round(effective_modulus(212e9, 0.289) / 1e9, 2)  # two 20CrMnTi bodies
    115.66
    """
    E1 = require_positive("E1", E1)
    nu1 = require_poisson("nu1", nu1)
    E2 = E1 if E2 is None else require_positive("E2", E2)
    nu2 = nu1 if nu2 is None else require_poisson("nu2", nu2)
    return 1.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)


@dataclass(frozen=True)
class HertzContact:
    """Static Hertz contact patch.

    Attributes
    ----------
    a : float
        Semi-axis of the contact ellipse along the direction of the larger
        relative radius of curvature (the major semi-axis) [m].
    b : float
        Minor semi-axis [m]; ``b == a`` for a circular contact.
    p0 : float
        Peak (central) pressure [Pa].
    delta : float
        Approach of distant points of the two bodies [m].
    force : float
        Normal load [N].
    """

    a: float
    b: float
    p0: float
    delta: float
    force: float


def sphere_contact(force: float, R: float, E_star: float) -> HertzContact:
    """Circular Hertz contact of two spheres (or a sphere on a flat).

    ``a = (3 P R / (4 E*))^(1/3)``, ``p0 = 3 P / (2 pi a^2)``,
    ``delta = a^2 / R`` (Johnson 1985, section 4.2(a)).

    Parameters
    ----------
    force : float
        Normal load P [N].
    R : float
        Effective radius, ``1/R = 1/R1 + 1/R2`` [m].
    E_star : float
        Effective modulus [Pa], see `effective_modulus`.

    Returns
    -------
    HertzContact
        With ``b == a``.

    Examples
    --------
    >>> c = sphere_contact(1000.0, 0.01, 115.66e9)
    >>> round(c.a * 1e6, 2), round(c.p0 / 1e6), round(c.delta * 1e6, 3)
    (401.75, 2958, 16.141)
    """
    force = require_positive("force", force)
    R = require_positive("R", R)
    E_star = require_positive("E_star", E_star)
    a = (3.0 * force * R / (4.0 * E_star)) ** (1.0 / 3.0)
    p0 = 3.0 * force / (2.0 * np.pi * a**2)
    return HertzContact(a=a, b=a, p0=p0, delta=sphere_approach(force, R, E_star), force=force)


def sphere_approach(force: float, R: float, E_star: float) -> float:
    """Hertz approach of two spheres, ``delta = a^2 / R = (9 P^2 / (16 R E*^2))^(1/3)`` [m].

    Johnson 1985, section 4.2(a); the seed's eq. 17 (its penetration depth
    ``d`` at the force ``F_n``).

    Parameters
    ----------
    force : float
        Normal load P [N].
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].
    """
    force = require_positive("force", force)
    R = require_positive("R", R)
    E_star = require_positive("E_star", E_star)
    return (9.0 * force**2 / (16.0 * R * E_star**2)) ** (1.0 / 3.0)


def sphere_stiffness(R: float, E_star: float) -> float:
    """Hertz stiffness coefficient ``K = (4/3) E* sqrt(R)`` [N/m^1.5].

    Such that ``P = K delta^1.5`` (Johnson 1985, section 4.2(a); seed eq. 12).

    Parameters
    ----------
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].
    """
    R = require_positive("R", R)
    E_star = require_positive("E_star", E_star)
    return 4.0 / 3.0 * E_star * float(np.sqrt(R))


def sphere_force(delta: ArrayLike, R: float, E_star: float) -> np.ndarray | float:
    """Hertz force ``P = (4/3) E* sqrt(R) delta^1.5`` for an approach ``delta``.

    Parameters
    ----------
    delta : float or array_like
        Approach [m]; any shape. Non-positive values (no contact) give 0.
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].

    Returns
    -------
    float or ndarray
        Force [N], same shape as ``delta``.
    """
    k = sphere_stiffness(R, E_star)
    force = k * np.maximum(np.asarray(delta, dtype=float), 0.0) ** 1.5
    return float(force) if force.ndim == 0 else force


def sphere_pressure(r: ArrayLike, force: float, R: float, E_star: float) -> np.ndarray | float:
    """Hertz pressure ``p0 sqrt(1 - r^2/a^2)`` inside the contact circle, 0 outside.

    Parameters
    ----------
    r : float or array_like
        Radial distance from the contact centre [m]; any shape.
    force, R, E_star : float
        As in `sphere_contact`.

    Returns
    -------
    float or ndarray
        Pressure [Pa], same shape as ``r`` (Johnson 1985, section 4.2(a)).
    """
    contact = sphere_contact(force, R, E_star)
    rho2 = (np.asarray(r, dtype=float) / contact.a) ** 2
    pressure = contact.p0 * np.sqrt(np.maximum(1.0 - rho2, 0.0))
    return float(pressure) if pressure.ndim == 0 else pressure


def _ellipse_axis_ratio_squared(curvature_ratio: float) -> float:
    """Solve the Hertz eccentricity relation for ``k'^2 = (b/a)^2``.

    Johnson writes ``B/A = (E(e)/(1-e^2) - K(e)) / (K(e) - E(e))``. With
    Carlson's integrals, ``K - E = (e^2/3) R_D(0, k'^2, 1)`` and
    ``E - k'^2 K = (e^2 k'^2/3) R_D(0, 1, k'^2)`` (DLMF 19.25.1), so
    ``B/A = R_D(0, 1, k'^2) / R_D(0, k'^2, 1)`` with no cancellation at
    either end (near-circular or very slender ellipses). The ratio falls
    monotonically from infinity at ``k'^2 -> 0`` to 1 at ``k'^2 = 1``; the
    root is bracketed in ``log k'^2``.
    """

    def residual(log_p: float) -> float:
        p = np.exp(log_p)
        return float(elliprd(0.0, 1.0, p) / elliprd(0.0, p, 1.0)) - curvature_ratio

    low = -1.0
    while residual(low) < 0.0:
        low *= 2.0
        if low < -2000.0:  # k'^2 < 1e-868: no float ellipse is that slender
            raise ValueError(f"curvature ratio B/A = {curvature_ratio!r} is too large")
    log_p = brentq(residual, low, 0.0, xtol=1e-15, rtol=4.0 * np.finfo(float).eps)
    return float(np.exp(log_p))


def ellipse_contact(force: float, Rx: float, Ry: float, E_star: float) -> HertzContact:
    """Exact elliptical Hertz contact (complete elliptic integrals).

    The initial gap is ``h = A x^2 + B y^2`` with ``A = 1/(2 Rx)``,
    ``B = 1/(2 Ry)``, Rx and Ry being the relative (effective) principal
    radii. The eccentricity ``e^2 = 1 - b^2/a^2`` solves
    ``B/A = (E/(1-e^2) - K)/(K - E)``; then ``A = p0 b (K - E)/(E* a^2 e^2)``,
    ``P = (2/3) pi a b p0`` and ``delta = p0 b K / E*`` (Johnson 1985,
    sections 3.6 and 4.2(b)). Elliptic integrals are evaluated in
    Carlson's form so that any ratio ``Rx/Ry`` (tested up to 1000) and the
    circular limit are accurate.

    Parameters
    ----------
    force : float
        Normal load P [N].
    Rx, Ry : float
        Principal relative radii of curvature [m], in either order.
    E_star : float
        Effective modulus [Pa].

    Returns
    -------
    HertzContact
        ``a`` is the semi-axis along the direction of the *larger* radius
        (the major axis), ``b`` the one along the smaller radius. ``Rx == Ry``
        gives `sphere_contact` with ``R = Rx``.

    Examples
    --------
    >>> c = ellipse_contact(1000.0, 0.1, 0.01, 115.66e9)
    >>> round(c.a * 1e6, 1), round(c.b * 1e6, 1), round(c.p0 / 1e6, 1)
    (1172.2, 260.5, 1563.6)
    """
    force = require_positive("force", force)
    Rx = require_positive("Rx", Rx)
    Ry = require_positive("Ry", Ry)
    E_star = require_positive("E_star", E_star)
    if Rx == Ry:
        return sphere_contact(force, Rx, E_star)
    A = 0.5 / max(Rx, Ry)
    B = 0.5 / min(Rx, Ry)
    p = _ellipse_axis_ratio_squared(B / A)
    # A = 3 P (K - E) / (2 pi E* a^3 e^2) with K - E = (e^2/3) R_D(0, p, 1).
    a = (force * float(elliprd(0.0, p, 1.0)) / (2.0 * np.pi * E_star * A)) ** (1.0 / 3.0)
    b = a * float(np.sqrt(p))
    p0 = 3.0 * force / (2.0 * np.pi * a * b)
    delta = p0 * b * float(elliprf(0.0, p, 1.0)) / E_star  # K(e) = R_F(0, k'^2, 1)
    return HertzContact(a=a, b=b, p0=p0, delta=delta, force=force)


def ellipse_layer_compression(z: float, a: float, b: float, p0: float, E: float,
                              nu: float) -> float:
    """Compression of the layer between the surface and depth ``z`` on the axis of a
    Hertz ellipse: ``u(0) - u(z)`` of one half-space [m].

    The displacement along the load at depth ``z`` below the centre of the
    pressure ``p = p0 sqrt(1 - x^2/a^2 - y^2/b^2)`` is the integral of
    Boussinesq's point-load solution ``(1 + nu)/(2 pi E) (2 (1 - nu)/R + z^2/R^3)``
    (Johnson 1985, section 3.2) over it; at the surface its kernel is
    ``(1 - nu^2)/(pi E r)``. Their difference falls off like ``z^2 / r^3``,
    so the compression of a layer of depth ``z`` is set by the pressure within
    a few ``z`` of the axis: unlike the approach (``u(0)`` of both bodies),
    it does not depend on the bodies' shape at distances beyond that, which
    makes it the quantity to compare with a finite body whose contact is
    long against its size. Integrated in polar coordinates about the centre,
    the radius scaled to the ellipse's (adaptive quadrature, relative
    accuracy about 1e-8). For ``a = b`` it is
    ``axial_displacement(0) - axial_displacement(z)``.
    """
    from scipy.integrate import quad

    z = float(z)
    if not (np.isfinite(z) and z > 0.0):
        raise ValueError(f"z must be finite and > 0, got {z!r}")
    a, b = require_positive("a", a), require_positive("b", b)
    p0, E = require_positive("p0", p0), require_positive("E", E)
    nu = require_poisson("nu", nu)
    surface = (1.0 - nu**2) / (np.pi * E)
    depth = (1.0 + nu) / (2.0 * np.pi * E)

    def along(theta: float) -> float:
        rmax = 1.0 / np.sqrt((np.cos(theta) / a) ** 2 + (np.sin(theta) / b) ** 2)

        def f(s: float) -> float:
            r = s * rmax
            big_r = np.hypot(r, z)
            kernel = surface - depth * (2.0 * (1.0 - nu) * r / big_r + z * z * r / big_r**3)
            return np.sqrt(max(1.0 - s * s, 0.0)) * kernel * rmax

        knee = min(1.0, z / rmax)
        return (quad(f, 0.0, knee, epsabs=0.0, epsrel=1e-10, limit=200)[0]
                + quad(f, knee, 1.0, epsabs=0.0, epsrel=1e-10, limit=200)[0])

    # four quadrants alike; the ellipse's radius falls from a to b about tan(theta) = b/a
    kink = float(np.arctan2(b, a))
    total = (quad(along, 0.0, kink, epsabs=0.0, epsrel=1e-9, limit=200)[0]
             + quad(along, kink, 0.5 * np.pi, epsabs=0.0, epsrel=1e-9, limit=200)[0])
    return 4.0 * p0 * total


def _arccot_remainder(zeta: np.ndarray) -> np.ndarray:
    """``(1 + zeta^2) arccot(zeta) - zeta`` for ``zeta >= 0``, without cancellation.

    Direct formula below ``_SERIES_FROM``; above it the alternating series
    ``sum_k (-1)^(k+1) 2 / ((2k-1)(2k+1) zeta^(2k-1))``.
    """
    direct = (1.0 + zeta**2) * np.arctan2(1.0, zeta) - zeta
    far = zeta > _SERIES_FROM
    inv = 1.0 / np.where(far, zeta, _SERIES_FROM)
    k = np.arange(1, _SERIES_TERMS + 1)[:, None]
    terms = (-1.0) ** (k + 1) * 2.0 / ((2 * k - 1) * (2 * k + 1)) * inv ** (2 * k - 1)
    return np.where(far, terms.sum(axis=0), direct)


def axial_displacement(
    z: ArrayLike, a: float, p0: float, E: float, nu: float
) -> np.ndarray | float:
    """Normal displacement on the axis of a half-space under Hertz pressure.

    For ``p = p0 sqrt(1 - r^2/a^2)`` on the surface of a half-space, the
    displacement along the load direction at depth ``z`` on the axis,
    relative to the far field (``u -> 0`` at infinity), is

    ``u(z) = a p0 (1 + nu)/E [arccot(z/a) - nu ((1 + z^2/a^2) arccot(z/a) - z/a)]``.

    Derived by integrating ``eps_z = (sigma_z - 2 nu sigma_r)/E`` from ``z`` to
    infinity with the axial stresses of Johnson 1985, section 3.4; it matches the
    integral of Boussinesq's point-load solution over the pressure. Limits:
    ``u(0) = pi p0 a (1 - nu^2)/(2 E)`` (half the Hertz approach for two
    identical bodies) and ``u -> P (1 + nu)(3 - 2 nu)/(2 pi E z)`` for
    ``z >> a`` (Boussinesq), with ``P = (2/3) pi a^2 p0``.

    Parameters
    ----------
    z : float or array_like
        Depth below the surface, ``z >= 0`` [m]; any shape.
    a : float
        Contact radius [m].
    p0 : float
        Peak pressure [Pa].
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio of *this* body (not E*).

    Returns
    -------
    float or ndarray
        Displacement into the body [m], positive, same shape as ``z``.
    """
    a = require_positive("a", a)
    p0 = require_positive("p0", p0)
    E = require_positive("E", E)
    nu = require_poisson("nu", nu)
    zeta = np.asarray(z, dtype=float) / a
    if np.any(zeta < 0.0) or not np.all(np.isfinite(zeta)):
        raise ValueError(f"z must be finite and >= 0, got min {np.min(zeta) * a!r}")
    arccot = np.arctan2(1.0, zeta)
    u = a * p0 * (1.0 + nu) / E * (arccot - nu * _arccot_remainder(zeta))
    u = np.reshape(u, zeta.shape)  # the remainder helper works on 1-D arrays
    return float(u) if u.ndim == 0 else u


@dataclass(frozen=True)
class HertzImpact:
    """Quasi-static Hertz impact of two elastic bodies.

    Fields are floats, or arrays when `impact_from_stiffness` is given an
    array of speeds.

    Attributes
    ----------
    delta_max : float
        Maximum approach [m] (seed eq. 16).
    force_max : float
        Peak force [N].
    contact_time : float
        Duration of contact [s].
    """

    delta_max: float
    force_max: float
    contact_time: float


def impact(mass: float, speed: float, R: float, E_star: float) -> HertzImpact:
    """Hertz impact: ``m delta'' = -K delta^1.5`` from ``delta'(0) = v``.

    ``delta_max = (5 m v^2 / (4 K))^(2/5)``, ``F_max = K delta_max^1.5`` and
    ``t_c = 2.94328 delta_max / v`` (Johnson 1985, section 11.4; the factor
    is `HERTZ_CONTACT_TIME_FACTOR`), ``K = (4/3) E* sqrt(R)``.

    Parameters
    ----------
    mass : float
        Effective mass ``m1 m2 / (m1 + m2)`` [kg].
    speed : float
        Normal approach speed at first contact [m/s].
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].

    Returns
    -------
    HertzImpact

    Examples
    --------
    >>> hit = impact(0.5, 0.1, 0.01, 115.66e9)
    >>> round(hit.delta_max * 1e6, 2), round(hit.force_max), round(hit.contact_time * 1e6)
    (11.04, 566, 325)
    """
    return impact_from_stiffness(mass, speed, sphere_stiffness(R, E_star))


def impact_from_stiffness(mass: float, speed: ArrayLike, k: float) -> HertzImpact:
    """Hertz impact on a contact ``F = k delta^1.5`` of any shape (see `impact`).

    ``delta_max = (5 m v^2 / (4 k))^(2/5)`` from the energy balance
    ``m v^2 / 2 = (2/5) k delta_max^(5/2)``, ``F_max = k delta_max^1.5`` and
    ``t_c = 2.94328 delta_max / v`` (Johnson 1985, section 11.4; seed eq. 16).
    For an elliptical contact ``k`` is ``P / delta^1.5`` of `ellipse_contact`,
    which does not depend on P.

    Parameters
    ----------
    mass : float
        Effective mass [kg].
    speed : float or array_like
        Normal approach speed at first contact [m/s], > 0; any shape.
    k : float
        Hertz stiffness [N/m^1.5].

    Returns
    -------
    HertzImpact
        Fields are floats for a scalar speed, arrays shaped like ``speed``
        otherwise (one impact per speed).
    """
    mass = require_positive("mass", mass)
    k = require_positive("k", k)
    speed = np.asarray(speed, dtype=float)
    if not np.all(np.isfinite(speed)) or np.any(speed <= 0.0):
        raise ValueError(f"speed must be a positive finite number, got {speed!r}")
    delta_max = (5.0 * mass * speed**2 / (4.0 * k)) ** 0.4
    force_max = k * delta_max**1.5
    contact_time = HERTZ_CONTACT_TIME_FACTOR * delta_max / speed
    if speed.ndim == 0:
        return HertzImpact(float(delta_max), float(force_max), float(contact_time))
    return HertzImpact(delta_max, force_max, contact_time)


def hunter_wave_loss(speed: ArrayLike, E: float, rho: float) -> np.ndarray | float:
    """Fraction of the impact energy radiated as elastic waves (Hunter 1957).

    ``1.04 (v / c0)^0.6`` with ``c0 = sqrt(E / rho)``, for a sphere striking
    a half-space (S. C. Hunter, J. Mech. Phys. Solids 5, 1957; Johnson 1985,
    section 11.4). For 20CrMnTi (c0 = 5193 m/s): 0.0015 at 0.1 m/s, 0.0061
    at 1 m/s.

    Parameters
    ----------
    speed : float or array_like
        Impact speed [m/s], >= 0.
    E : float
        Young's modulus [Pa].
    rho : float
        Density [kg/m^3].

    Returns
    -------
    float or ndarray
        Energy fraction [-].
    """
    c0 = np.sqrt(require_positive("E", E) / require_positive("rho", rho))
    speed = np.asarray(speed, dtype=float)
    if np.any(speed < 0.0):
        raise ValueError(f"speed must be >= 0, got min {np.min(speed)!r}")
    loss = 1.04 * (speed / c0) ** 0.6
    return float(loss) if loss.ndim == 0 else loss


def yield_onset_speed(Y: float, rho: float, E_star: float) -> float:
    """Impact speed at which a sphere starts to yield (Johnson 1985, section 11.4).

    ``v_y = sqrt(26 Y^5 / (rho E*^4))`` (seed eq. 15): first yield when the
    Hertz peak pressure reaches ``1.6 Y``; independent of the sphere's size.
    For 20CrMnTi (Y = 835 MPa, rho = 7860 kg/m^3, E* = 115.66 GPa) this gives
    0.0866 m/s.

    Parameters
    ----------
    Y : float
        Yield strength in simple tension [Pa].
    rho : float
        Density of the striking sphere [kg/m^3].
    E_star : float
        Effective modulus [Pa].

    Returns
    -------
    float
        Speed [m/s].
    """
    Y = require_positive("Y", Y)
    rho = require_positive("rho", rho)
    E_star = require_positive("E_star", E_star)
    return float(np.sqrt(26.0 * Y**5 / (rho * E_star**4)))


def ellipse_yield_speed(mass: float, Rx: float, Ry: float, E_star: float, Y: float,
                        pressure: float = 1.6) -> float:
    """Impact speed at which an elliptical Hertz contact starts to yield [m/s].

    A mass ``m`` closing at ``v`` on the contact of relative radii ``Rx``, ``Ry``
    (`ellipse_contact`) peaks at ``F_max`` from ``m v^2 / 2 = (2/5) k
    delta^(5/2)`` (`impact_from_stiffness`); first yield when its peak pressure
    reaches ``pressure * Y`` (1.6 Y for nu = 0.3, Johnson 1985, section 6.2).
    The ellipse's shape does not change with the load, so ``p0 ~ F^(1/3)``:
    ``F_y = F_1 (pressure Y / p0_1)^3`` from the contact at ``F_1 = 1 N``, and
    ``v_y = sqrt(4 k delta_y^(5/2) / (5 m))`` with ``delta_y = (F_y / k)^(2/3)``.
    For a sphere of density ``rho`` and its own mass this is `yield_onset_speed`;
    a tooth pair's effective mass is not its contact's sphere, so its yield
    onset depends on the geometry.
    """
    mass = require_positive("mass", mass)
    Y = require_positive("Y", Y)
    unit = ellipse_contact(1.0, Rx, Ry, E_star)
    k = 1.0 / unit.delta**1.5
    force = (pressure * Y / unit.p0) ** 3
    delta = (force / k) ** (2.0 / 3.0)
    return float(np.sqrt(4.0 * k * delta**2.5 / (5.0 * mass)))


def thornton_restitution(yield_ratio: ArrayLike) -> np.ndarray | float:
    """Restitution of Thornton's elastic-perfectly plastic sphere model (1997).

    Thornton (J. Appl. Mech. 64, 1997) loads along Hertz until the centre
    pressure reaches the limiting pressure ``p_y``, then linearly,
    ``F = F_y + pi p_y R (delta - delta_y)`` (the pressure is capped at
    ``p_y``), and unloads along Hertz with the enlarged radius
    ``R_p = (4 E* / 3 F_max) ((2 F_max + F_y) / (2 pi p_y))^1.5``. The
    energies of the two branches give, with ``r = v_y / v``,

        e = sqrt(6 sqrt(3) / 5) sqrt(1 - r^2 / 6) (r / (r + 2 sqrt(6/5 - r^2/5)))^(1/4)

    for ``v >= v_y`` and ``e = 1`` below: 0.93, 0.77, 0.66, 0.50, 0.37 at
    ``v / v_y`` = 2, 5, 10, 30, 100 (docs/references.md), and
    ``1.185 (v / v_y)^(-1/4)`` at high speed. ``v_y`` is the speed at which
    the Hertz centre pressure reaches ``p_y`` (1.6 Y: Johnson's eq. 15).
    """
    j = np.asarray(yield_ratio, dtype=float)
    if np.any(~np.isfinite(j)) or np.any(j < 0.0):
        raise ValueError(f"yield_ratio must be finite and >= 0, got {yield_ratio!r}")
    r = 1.0 / np.maximum(j, 1.0)
    e = (np.sqrt(6.0 * np.sqrt(3.0) / 5.0) * np.sqrt(1.0 - r ** 2 / 6.0)
         * (r / (r + 2.0 * np.sqrt(6.0 / 5.0 - r ** 2 / 5.0))) ** 0.25)
    e = np.where(j <= 1.0, 1.0, e)
    return float(e) if e.ndim == 0 else e


@dataclass(frozen=True)
class ThorntonImpact:
    """Thornton's (1997) elastic-perfectly plastic impact of a sphere.

    Attributes
    ----------
    yield_speed : float
        Speed at which the Hertz centre pressure reaches ``p_y`` [m/s].
    delta_max : float
        Maximum approach [m].
    force_max : float
        Peak force [N].
    residual : float
        Permanent approach after unloading (the residual indentation of both
        bodies together) [m].
    restitution : float
        Coefficient of restitution (equals :func:`thornton_restitution`).
    """

    yield_speed: float
    delta_max: float
    force_max: float
    residual: float
    restitution: float


def thornton_impact(mass: float, speed: float, R: float, E_star: float,
                    p_y: float) -> ThorntonImpact:
    """Thornton's impact, branch by branch (see :func:`thornton_restitution`).

    Hertz loading to ``delta_y = R (pi p_y / 2 E*)^2``, then
    ``F = F_y + pi p_y R (delta - delta_y)`` until the kinetic energy
    ``m v^2 / 2`` is spent; unloading along Hertz with the radius ``R_p``
    from ``delta_max`` to the residual approach ``delta_max - (F_max/k_p)^(2/3)``,
    ``k_p = 4/3 E* sqrt(R_p)``; ``e^2`` is the unloading work over the
    impact energy. ``mass`` and ``R`` are the effective mass and radius of
    the pair (as in :func:`impact`), ``E_star`` the effective modulus;
    ``p_y`` is the limiting contact pressure (Thornton takes the pressure of
    first yield, 1.6 Y for Y the tensile yield strength).
    """
    mass = require_positive("mass", mass)
    speed = require_positive("speed", speed)
    R = require_positive("R", R)
    E_star = require_positive("E_star", E_star)
    p_y = require_positive("p_y", p_y)
    k = sphere_stiffness(R, E_star)
    d_y = R * (np.pi * p_y / (2.0 * E_star)) ** 2
    F_y = k * d_y ** 1.5
    W_y = 0.4 * k * d_y ** 2.5
    v_y = float(np.sqrt(2.0 * W_y / mass))
    W = 0.5 * mass * speed ** 2
    if W <= W_y:
        hit = impact(mass, speed, R, E_star)
        return ThorntonImpact(v_y, hit.delta_max, hit.force_max, 0.0, 1.0)
    s = np.pi * p_y * R
    x = (-F_y + np.sqrt(F_y ** 2 + 2.0 * s * (W - W_y))) / s
    F_max = F_y + s * x
    R_p = 4.0 * E_star / (3.0 * F_max) * ((2.0 * F_max + F_y) / (2.0 * np.pi * p_y)) ** 1.5
    k_p = sphere_stiffness(R_p, E_star)
    w = (F_max / k_p) ** (2.0 / 3.0)
    return ThorntonImpact(v_y, float(d_y + x), float(F_max), float(d_y + x - w),
                          float(np.sqrt(0.4 * k_p * w ** 2.5 / W)))


def jackson_green_factor(poisson: float) -> float:
    """Jackson and Green's yield factor ``C = 1.295 exp(0.736 nu)`` [-].

    The Hertz centre pressure at first yield is ``C S_y`` (1.61 at nu = 0.3,
    close to Johnson's 1.6 Y); R. L. Jackson and I. Green, J. Tribol. 127,
    2005, 343-354, with their critical interference
    ``delta_c = (pi C S_y / (2 E'))^2 R``.
    """
    return 1.295 * float(np.exp(0.736 * require_poisson("poisson", poisson)))


def jgm_restitution(
    yield_ratio: ArrayLike,
    yield_strength: float,
    E_star: float,
    poisson: float | None = None,
) -> np.ndarray | float:
    """Restitution of an elastic-perfectly plastic sphere, Jackson-Green-Marghitu fit.

    ``e = 1 - 0.0361 (S_y/E')^-0.114 ln(V*) (V* - 1)^(9.5 S_y/E')`` for
    ``V* = V / V_y > 1`` and ``e = 1`` at or below yield (R. L. Jackson,
    I. Green and D. B. Marghitu, "Predicting the coefficient of restitution
    of impacting elastic-perfectly plastic spheres", Nonlinear Dynamics 60,
    2010, 217-229; a fit to finite-element impacts). ``V_y`` is the speed of
    first yield; JGM take it from Jackson and Green's critical interference
    (centre pressure ``C S_y``), which differs from the seed's eq. 15 (1.6 Y)
    by the factor ``(C/1.6)^(5/2)`` (1.003 at nu = 0.289).

    Sources write the material group ``S_y/E'`` in two ways:

    - ``S_y / E'`` with ``E'`` the effective modulus of the pair, i.e. E*
      (``1/E' = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``). This is the default.
    - ``C S_y / E'`` with ``C = 1.295 exp(0.736 nu)`` (`jackson_green_factor`),
      the yield pressure over E'; pass ``poisson`` to use it.

    For 20CrMnTi (S_y = 835 MPa, E* = 115.66 GPa, nu = 0.289) the default gives
    0.956, 0.888, 0.830, 0.729 at V* = 2, 5, 10, 30; the C form moves these
    by +0.2%, -0.05%, -0.8%, -3.3%.

    Parameters
    ----------
    yield_ratio : float or array_like
        ``V* = V / V_y`` [-], >= 0; any shape.
    yield_strength : float
        Yield strength in simple tension S_y [Pa].
    E_star : float
        Effective modulus of the pair E' = E* [Pa].
    poisson : float, optional
        Poisson's ratio; when given, the material group is ``C S_y / E*``.

    Returns
    -------
    float or ndarray
        Coefficient of restitution [-], same shape as ``yield_ratio``.

    Examples
    --------
    >>> round(jgm_restitution(5.0, 835e6, 115.66e9), 3)
    0.888
    """
    group = require_positive("yield_strength", yield_strength) / require_positive(
        "E_star", E_star)
    if poisson is not None:
        group *= jackson_green_factor(poisson)
    j = np.asarray(yield_ratio, dtype=float)
    if np.any(~np.isfinite(j)) or np.any(j < 0.0):
        raise ValueError(f"yield_ratio must be finite and >= 0, got {yield_ratio!r}")
    jj = np.maximum(j, 1.0)
    loss = 0.0361 * group ** -0.114 * np.log(jj) * (jj - 1.0) ** (9.5 * group)
    e = np.where(j <= 1.0, 1.0, 1.0 - loss)
    return float(e) if e.ndim == 0 else e
