"""The one-degree-of-freedom IMPACT-law impact, fast enough to sit inside a least-squares fit.

With ``L = (m v^2 / k)^(1/(n+1))``, ``delta = L x`` and ``t = (L/v) tau``
the IMPACT impact ``m delta'' = -F_IMPACT(delta, delta')``,
``delta(0) = 0``, ``delta'(0) = v`` becomes
``x'' = -max(0, x^n + STEP(x, 0, 0, d/L, 1) c x')``, ``x(0) = 0``,
``x'(0) = 1``, with ``c = cmax L / (m v)``; forces scale with
``k L^n = m v^2 / L``. So ``k`` only scales time and force, and the shape of
the history depends on ``(n, c, d/L)`` alone.

`run_scaled` integrates this problem, with the force of
`fe_impact.physics.impact_law.impact_force_scalar` at ``k = 1``, by
fixed-step classical Runge-Kutta (numba, about 0.2 ms per history), which
keeps the residual of `fe_impact.calibration.impact_fit.fit_impact_law` a
smooth function of the parameters for finite-difference Jacobians, and
reads it at the sample times with cubic Hermite interpolation.
`dimensionless_restitution` gives the restitution of ``(n, c, d/L)`` alone.
The fit's final quality figures come from
`fe_impact.physics.laws.simulate_impact` (adaptive DOP853) instead,
independently of this integrator.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fe_impact.physics.impact_law import impact_force_scalar

__all__ = ["DT", "MAX_TAU", "dimensionless_restitution", "run_scaled"]

#: Dimensionless step of the fast integrator, in units of L / v. A Hertz
#: contact lasts about 4.2 of them, so about 2000 steps per impact; the global
#: error of RK4 is ~1e-10 on smooth stretches, and the kinks of the clamped
#: force (C0) and of STEP (C1) cost O(dt^2) ~ 1e-6 locally at worst.
DT = 2e-3
#: Longest dimensionless history before the model is declared stuck.
MAX_TAU = 400.0


@njit(cache=True)
def _force(x: float, u: float, n: float, c: float, dd: float) -> float:
    """Dimensionless IMPACT force ``max(0, x^n + STEP(x, 0, 0, dd, c) u)``: k = 1."""
    return impact_force_scalar(x, u, 1.0, n, c, dd)


@njit(cache=True)
def _hermite(x0: float, x1: float, v0: float, v1: float, h: float, th: float) -> float:
    """Cubic Hermite interpolant on a step of length h at fraction th."""
    th2 = th * th
    th3 = th2 * th
    return (
        (2.0 * th3 - 3.0 * th2 + 1.0) * x0
        + (th3 - 2.0 * th2 + th) * h * v0
        + (-2.0 * th3 + 3.0 * th2) * x1
        + (th3 - th2) * h * v1
    )


@njit(cache=True)
def _rk4_step(x, u, n, c, dd, dt):  # pragma: no cover - compiled
    """Approach and rate after one classical Runge-Kutta step of ``x'' = -F(x, x')``."""
    k1x, k1u = u, -_force(x, u, n, c, dd)
    x2, u2 = x + 0.5 * dt * k1x, u + 0.5 * dt * k1u
    k2x, k2u = u2, -_force(x2, u2, n, c, dd)
    x3, u3 = x + 0.5 * dt * k2x, u + 0.5 * dt * k2u
    k3x, k3u = u3, -_force(x3, u3, n, c, dd)
    x4, u4 = x + dt * k3x, u + dt * k3u
    k4x, k4u = u4, -_force(x4, u4, n, c, dd)
    xn = x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
    un = u + dt / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
    return xn, un


@njit(cache=True)
def _separation(x, xn, u, un, a, an, dt):  # pragma: no cover - compiled
    """Fraction of the step where ``x`` returns to 0: Newton on the Hermite cubic of x."""
    th = x / (x - xn)
    for _it in range(30):
        g = _hermite(x, xn, u, un, dt, th)
        dg = _hermite(u, un, a, an, dt, th)
        if dg == 0.0:
            break
        step = g / (dg * dt)
        th = min(max(th - step, 0.0), 1.0)
        if abs(step) < 1e-15:
            break
    return th


@njit(cache=True)
def _simulate(n, c, dd, dt, samples, max_steps):  # pragma: no cover - compiled
    """Dimensionless impact ``x'' = -F(x, x')`` from ``x = 0``, ``x' = 1``.

    Returns the approach, rate and force at the sorted ``samples`` times, the
    exit rate ``x'`` at separation (``x`` back to 0 while opening), the
    separation time, and 1 if the bodies parted within ``max_steps`` (else
    0). Samples after separation are free flight.
    """
    m = samples.size
    xs = np.zeros(m)
    us = np.zeros(m)
    fs = np.zeros(m)
    j = 0
    while j < m and samples[j] <= 0.0:  # approach before first touch
        xs[j] = samples[j]
        us[j] = 1.0
        j += 1
    x, u, t = 0.0, 1.0, 0.0
    a = 0.0
    for _ in range(max_steps):
        xn, un = _rk4_step(x, u, n, c, dd, dt)
        an = -_force(xn, un, n, c, dd)
        tn = t + dt
        parted = xn < 0.0 and un < 0.0
        t_sep, u_sep = tn, un
        if parted:
            th = _separation(x, xn, u, un, a, an, dt)
            t_sep = t + th * dt
            u_sep = _hermite(u, un, a, an, dt, th)
        while j < m and samples[j] <= tn:
            if parted and samples[j] >= t_sep:
                break
            th = (samples[j] - t) / dt
            xs[j] = _hermite(x, xn, u, un, dt, th)
            us[j] = _hermite(u, un, a, an, dt, th)
            fs[j] = _force(xs[j], us[j], n, c, dd)
            j += 1
        if parted:
            while j < m:  # free flight after separation
                xs[j] = u_sep * (samples[j] - t_sep)
                us[j] = u_sep
                j += 1
            return xs, us, fs, u_sep, t_sep, 1
        x, u, a, t = xn, un, an, tn
    return xs, us, fs, u, t, 0


def run_scaled(
    k: float, n: float, cmax: float, d: float, mass: float, speed: float, t_rel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """Force [N] and approach [m] at times ``t_rel`` [s] after first touch; restitution.

    The last value is False when the bodies had not parted after
    ``max(MAX_TAU, 2 tau[-1])`` dimensionless times (the restitution is then
    meaningless).
    """
    length = (mass * speed**2 / k) ** (1.0 / (n + 1.0))
    force_scale = mass * speed**2 / length
    tau = t_rel * (speed / length)
    c = cmax * length / (mass * speed)
    max_steps = int(max(MAX_TAU, 2.0 * tau[-1]) / DT) + 1
    xs, _, fs, u_sep, _, ok = _simulate(n, c, d / length, DT, tau, max_steps)
    return fs * force_scale, xs * length, -u_sep, bool(ok)


def dimensionless_restitution(n: float, c: float, dd: float) -> float:
    """Restitution of ``x'' = -F(x, x')`` with ``c = cmax L / (m v)`` and
    ``dd = d / L``; 0 if the bodies have not parted by ``MAX_TAU``.

    >>> round(dimensionless_restitution(1.5, 0.0, 0.5), 6)  # undamped: elastic
    1.0
    """
    _, _, _, u_sep, _, ok = _simulate(n, c, dd, DT, np.zeros(1), int(MAX_TAU / DT) + 1)
    return -u_sep if ok else 0.0
