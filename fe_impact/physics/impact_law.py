"""ADAMS ``STEP`` and ``IMPACT`` as scalar functions: the one definition of the lumped law.

Plain scalar functions compiled with numba (``njit``, cached on disk), so
that compiled code can call them directly: the one-degree-of-freedom
integrator of `fe_impact.calibration.impact_model` and the torsional kernel of
`fe_impact.switching._kernel`. `fe_impact.physics.laws` applies them to
arrays through the ufuncs `step_ufunc` and `impact_force_ufunc`.

``IMPACT`` is written in penetration form: penetration ``h`` (positive in
contact) and its rate ``hd`` (positive while closing). The ADAMS arguments
map as ``h = x1 - x``, ``hd = -xdot`` (seed eq. 11).
"""

from __future__ import annotations

from numba import njit, vectorize

__all__ = [
    "impact_force_energy",
    "impact_force_scalar",
    "impact_force_ufunc",
    "step_scalar",
    "step_ufunc",
    "unit_step",
]


@njit(cache=True)
def unit_step(z: float) -> float:
    """``STEP(z, 0, 0, 1, 1)``: 0 for ``z <= 0``, 1 for ``z >= 1``, ``z^2 (3 - 2 z)`` between.

    The cubic has zero slope at both ends (C1); its second derivative jumps
    from 0 to 6 at ``z = 0`` and from -6 to 0 at ``z = 1``.
    """
    if z <= 0.0:
        return 0.0
    if z >= 1.0:
        return 1.0
    return z * z * (3.0 - 2.0 * z)


@njit(cache=True)
def step_scalar(x: float, x0: float, h0: float, x1: float, h1: float) -> float:
    """ADAMS ``STEP(x, x0, h0, x1, h1)``: ``h0`` up to ``x0``, ``h1`` from ``x1``, cubic between.

    ``h0 + (h1 - h0) D^2 (3 - 2 D)`` with ``D = (x - x0) / (x1 - x0)``; needs
    ``x0 < x1`` (not checked here: the callers validate once).
    """
    return h0 + (h1 - h0) * unit_step((x - x0) / (x1 - x0))


@njit(cache=True)
def impact_force_energy(h: float, hd: float, k: float, n: float, cmax: float,
                        d: float) -> tuple[float, float]:
    """ADAMS ``IMPACT`` force [N] and stored elastic energy [J] of one contact.

    ``F = max(0, k h^n + STEP(h, 0, 0, d, cmax) hd)`` for ``h > 0``, 0 otherwise;
    the damping ramps from 0 at first touch to ``cmax`` at penetration ``d``
    and the force is clamped at zero (contact only pushes). The energy is
    that of the elastic part, ``int_0^h k s^n ds = k h^(n+1) / (n + 1)``.

    Parameters
    ----------
    h, hd : float
        Penetration [m] and its rate [m/s], positive while closing.
    k : float
        Stiffness [N/m^n].
    n : float
        Force exponent [-] (1.5 for Hertz).
    cmax : float
        Full damping coefficient [N s/m].
    d : float
        Penetration at which the damping reaches ``cmax`` [m], > 0.
    """
    if h <= 0.0:
        return 0.0, 0.0
    hn = h**n
    force = k * hn + cmax * unit_step(h / d) * hd
    return max(force, 0.0), k * hn * h / (n + 1.0)


@njit(cache=True)
def impact_force_scalar(h: float, hd: float, k: float, n: float, cmax: float,
                        d: float) -> float:
    """ADAMS ``IMPACT`` force [N] in penetration form (see `impact_force_energy`)."""
    return impact_force_energy(h, hd, k, n, cmax, d)[0]


@vectorize(cache=True)
def step_ufunc(x, x0, h0, x1, h1):  # pragma: no cover - compiled
    """`step_scalar` on broadcast arrays."""
    return step_scalar(x, x0, h0, x1, h1)


@vectorize(cache=True)
def impact_force_ufunc(h, hd, k, n, cmax, d):  # pragma: no cover - compiled
    """`impact_force_scalar` on broadcast arrays."""
    return impact_force_scalar(h, hd, k, n, cmax, d)
