"""The seed's closed forms for the IMPACT parameters, eqs. 12-17, one function each.

The seed is "Study on Impact Characteristics of Multistage Double Crown Face
Gear Pairs considering Ratio Switching under Variable Conditions", *Shock and
Vibration* 2020, article 8880093, section 3.3 (``/work/shared/seed``). Its
eq. 11 is the ADAMS ``IMPACT`` law (`fe_impact.physics.impact_law`); eqs.
12-17 give that law's parameters for one impact of effective mass ``m_k`` at
the closing speed ``v_k``:

====  ===========================  ===============================================
eq.   quantity                     here
====  ===========================  ===============================================
12    stiffness ``K_cf``           `stiffness` (Johnson's Hertz stiffness)
13    damping ``C_max``            `damping` (Zhiying-Qishao hysteresis at delta)
14    restitution ``e(j)``         `restitution`
15    yield-onset speed ``v_y``    `yield_speed` (Johnson's first-yield speed)
16    approach ``delta``           `max_approach` (Hertz impact, Johnson)
17    penetration depth ``d``      `penetration_depth` (Hertz approach under F)
====  ===========================  ===============================================

Eqs. 12, 15, 16 and 17 are Hertz closed forms from K. L. Johnson, *Contact
Mechanics*, 1985: they are written once, in `fe_impact.physics.hertz`, and
the functions here only name them by the seed's numbers. Eqs. 13 and 14
are the seed's own and are written here. SI units throughout.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from fe_impact.physics import hertz, laws
from fe_impact.physics.checks import require_positive

__all__ = [
    "RESTITUTION_FLOOR",
    "damping",
    "max_approach",
    "penetration_depth",
    "restitution",
    "stiffness",
    "yield_speed",
]

#: Smallest restitution eq. 14 returns (see `restitution`).
RESTITUTION_FLOOR = 1e-3


def stiffness(R: float, E_star: float) -> float:
    """Seed eq. 12: ``K_cf = (4/3) E* R^0.5`` [N/m^1.5] (`hertz.sphere_stiffness`).

    The seed writes E* in a form that is not the effective modulus; this is
    Johnson's ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Johnson 1985, section 4.2).
    """
    return hertz.sphere_stiffness(R, E_star)


def damping(k: float, e: float, impact_speed: float, delta: float,
            exponent: float = 1.5) -> float:
    """Seed eq. 13: ``C_max = 3 K (1 - e^2) exp(2 (1 - e)) delta^a / (4 v_k)`` [N s/m].

    The Zhiying-Qishao hysteresis damping ``chi(e) K delta^a / v_k``
    (`fe_impact.physics.laws.CHI_MODELS`) evaluated at the relative
    deformation ``delta`` (eq. 16). The seed leaves the power ``a``
    undefined; it is taken equal to the force exponent so that
    ``C_max hdot`` is a force. The seed's ``e ~ 1`` branch (without the
    exponential) is the limit of this one.

    Parameters
    ----------
    k : float
        Contact stiffness [N/m^exponent], > 0.
    e : float
        Target restitution, ``0 < e <= 1``.
    impact_speed : float
        Meshing impact speed v_k [m/s], > 0.
    delta : float
        Relative deformation [m], > 0.
    exponent : float, optional
        Power ``a`` of ``delta``.
    """
    k = require_positive("k", k)
    impact_speed = require_positive("impact_speed", impact_speed)
    delta = require_positive("delta", delta)
    chi = laws.hysteresis_factor("zhiying-qishao", e)
    return chi * k * delta**exponent / impact_speed


def restitution(yield_ratio: ArrayLike) -> np.ndarray | float:
    """Seed eq. 14: ``e = 1`` for ``j <= 1``, ``1 - 0.035 ln(j) j^0.1645`` above.

    ``j = v_k / v_y`` is the impact speed over the yield-onset speed (eq. 15).
    It gives 0.97, 0.93, 0.88, 0.79, 0.66 at j = 2, 5, 10, 30, 100. The seed
    states it up to the shallow-indentation limit ``j_ly = v_l / v_y`` with
    ``v_l ~ 100 m/s`` (j_ly = 1150 and e = 0.21 there for 20CrMnTi); the
    expression itself reaches 0 at j = 2571 and turns negative beyond.

    Clamping, for every caller: the result is ``max(e, RESTITUTION_FLOOR)``,
    so that it stays a restitution that eq. 13 accepts (``0 < e <= 1``) at
    any speed. Below j = 2.5e3, which covers the seed's range, the floor
    never acts.

    Parameters
    ----------
    yield_ratio : float or array_like
        ``j`` [-], finite and >= 0; any shape.

    Returns
    -------
    float or ndarray
        ``e`` [-], same shape as ``yield_ratio``.

    Examples
    --------
    >>> round(restitution(10.0), 3)
    0.882
    """
    j = np.asarray(yield_ratio, dtype=float)
    if np.any(~np.isfinite(j)) or np.any(j < 0.0):
        raise ValueError(f"yield_ratio must be finite and >= 0, got {yield_ratio!r}")
    jj = np.maximum(j, 1.0)
    e = np.where(j <= 1.0, 1.0, 1.0 - 0.035 * np.log(jj) * jj ** 0.1645)
    e = np.maximum(e, RESTITUTION_FLOOR)
    return float(e) if e.ndim == 0 else e


def yield_speed(Y: float, rho: float, E_star: float) -> float:
    """Seed eq. 15: ``v_y = (26 Y^5 / (rho E*^4))^(1/2)`` [m/s] (`hertz.yield_onset_speed`)."""
    return hertz.yield_onset_speed(Y, rho, E_star)


def max_approach(mass: float, speed: ArrayLike, k: float) -> np.ndarray | float:
    """Seed eq. 16: ``delta = (5 m_k v_k^2 / (4 K))^(2/5)`` [m] (`hertz.impact_from_stiffness`).

    The maximum approach of an undamped Hertz impact of the effective mass
    ``m_k`` at ``v_k`` (float or array) on the stiffness ``K`` [N/m^1.5].
    """
    return hertz.impact_from_stiffness(mass, speed, k).delta_max


def penetration_depth(force: float, R: float, E_star: float) -> float:
    """Seed eq. 17: ``d = (9 F^2 / (16 R E*^2))^(1/3)`` [m] (`hertz.sphere_approach`).

    The Hertz approach of two spheres of effective radius ``R`` under the
    normal force ``F``.
    """
    return hertz.sphere_approach(force, R, E_star)
