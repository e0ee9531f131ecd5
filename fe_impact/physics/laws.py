"""Lumped contact-impact laws: what the calibration fits to the FE impacts.

Two families, both giving a normal force from the penetration ``h`` (approach,
positive in contact) and its rate ``hdot`` (positive while closing):

- the ADAMS ``IMPACT`` function (seed eq. 11), ``k h^n + STEP(h) cmax hdot``
  with a damping that ramps in over a penetration ``d`` (`ImpactLaw`);
- hysteresis-damping laws ``K h^n (1 + chi hdot / v_impact)`` whose factor
  ``chi(e)`` is chosen for a target restitution ``e`` (`HysteresisLaw`,
  `CHI_MODELS`).

Every force is clamped at zero: contact can only push. `simulate_impact`
runs the one-degree-of-freedom impact that defines restitution, peak force,
maximum approach and contact time of a law. SI units throughout.

``STEP`` and ``IMPACT`` are written once, as compiled scalar functions, in
`fe_impact.physics.impact_law`; `step`, `impact_force` and `ImpactLaw.force`
apply them to arrays. The seed's closed-form parameters (eqs. 12-17) are in
`fe_impact.physics.seed`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp
from scipy.optimize import OptimizeResult, minimize_scalar

from fe_impact.errors import SolverError
from fe_impact.physics.checks import require_positive
from fe_impact.physics.impact_law import impact_force_ufunc, step_ufunc

logger = logging.getLogger(__name__)

FloatOrArray = float | np.ndarray
#: Dense output of the integrator: times -> states, shape (2, ...).
DenseOutput = Callable[[ArrayLike], np.ndarray]


def _as_output(value: np.ndarray) -> FloatOrArray:
    """Return a Python float for 0-d results, the array otherwise."""
    return float(value) if value.ndim == 0 else value


def _require_non_negative(name: str, value: float) -> float:
    """Return ``value`` as a float, or raise ValueError naming it when < 0."""
    value = float(value)
    if not np.isfinite(value) or value < 0.0:
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return value


def step(x: ArrayLike, x0: float, h0: float, x1: float, h1: float) -> FloatOrArray:
    """ADAMS ``STEP``: cubic blend from ``h0`` at ``x0`` to ``h1`` at ``x1``.

    ``h0`` for ``x <= x0``, ``h1`` for ``x >= x1``, and
    ``h0 + (h1 - h0) D^2 (3 - 2 D)`` with ``D = (x - x0)/(x1 - x0)`` between:
    the first derivative is continuous (zero at both ends), the second jumps.

    Parameters
    ----------
    x : float or array_like
        Argument, any shape.
    x0, x1 : float
        Start and end of the blend, ``x0 < x1``.
    h0, h1 : float
        Values before ``x0`` and after ``x1``.

    Returns
    -------
    float or ndarray
        Same shape as ``x``.

    Examples
    --------
    >>> step(0.5, 0.0, 0.0, 1.0, 2.0)
    1.0
    """
    if not x1 > x0:
        raise ValueError(f"step needs x0 < x1, got x0={x0!r}, x1={x1!r}")
    values = step_ufunc(np.asarray(x, dtype=float), float(x0), float(h0), float(x1), float(h1))
    return _as_output(np.asarray(values))


def impact_force(
    x: ArrayLike,
    xdot: ArrayLike,
    x1: float,
    k: float,
    exponent: float,
    cmax: float,
    d: float,
) -> FloatOrArray:
    """ADAMS ``IMPACT`` force (seed eq. 11), in the ADAMS sign convention.

    ``0`` when ``x >= x1``; otherwise
    ``max(0, k (x1 - x)^exponent - STEP(x, x1 - d, cmax, x1, 0) xdot)``.
    The distance ``x`` decreases into contact, so the penetration is
    ``x1 - x`` and ``-xdot`` is the closing speed; the damping coefficient
    ramps from 0 at first touch to ``cmax`` at penetration ``d``.

    Parameters
    ----------
    x, xdot : float or array_like
        Distance [m] and its rate [m/s], broadcast together.
    x1 : float
        Distance at first touch [m].
    k : float
        Stiffness [N/m^exponent].
    exponent : float
        Force exponent (1.5 for Hertz); not a restitution coefficient.
    cmax : float
        Full damping coefficient [N s/m].
    d : float
        Penetration at which the damping reaches ``cmax`` [m], > 0.

    Returns
    -------
    float or ndarray
        Force [N], >= 0, pushing the bodies apart.

    Notes
    -----
    Evaluated in penetration form, ``h = x1 - x`` and ``hd = -xdot``, by
    `fe_impact.physics.impact_law.impact_force_scalar` (``STEP(x, x1 - d,
    cmax, x1, 0)`` equals ``STEP(h, 0, 0, d, cmax)``).
    """
    penetration = x1 - np.asarray(x, dtype=float)
    closing = -np.asarray(xdot, dtype=float)
    return _as_output(np.asarray(impact_force_ufunc(
        penetration, closing, float(k), float(exponent), float(cmax), float(d))))


class ContactLaw(Protocol):
    """A normal contact law ``F(h, hdot)`` usable by `simulate_impact`.

    ``k`` and ``exponent`` give the elastic part ``k h^exponent``, which sets
    the length and time scales of the simulated impact.
    """

    k: float
    exponent: float

    def force(self, penetration: ArrayLike, penetration_rate: ArrayLike) -> FloatOrArray:
        """Force [N] >= 0 for penetration ``h`` [m] and closing rate ``hdot`` [m/s]."""
        ...


@dataclass(frozen=True)
class ImpactLaw:
    """ADAMS ``IMPACT`` law in penetration form (seed eq. 11).

    ``F = max(0, k h^exponent + STEP(h, 0, 0, d, cmax) hdot)`` for ``h > 0``,
    0 otherwise. Penetration ``h = x1 - x`` is positive in contact and
    ``hdot = -xdot`` positive while the bodies close, so
    ``force(h, hdot) == impact_force(x1 - h, -hdot, x1, k, exponent, cmax, d)``.

    Attributes
    ----------
    k : float
        Stiffness [N/m^exponent], > 0.
    exponent : float
        Force exponent [-], > 0.
    cmax : float
        Full damping coefficient [N s/m], >= 0.
    d : float
        Penetration at which damping reaches ``cmax`` [m], > 0.
    """

    k: float
    exponent: float
    cmax: float
    d: float

    def __post_init__(self) -> None:
        require_positive("k", self.k)
        require_positive("exponent", self.exponent)
        _require_non_negative("cmax", self.cmax)
        require_positive("d", self.d)

    def force(self, penetration: ArrayLike, penetration_rate: ArrayLike) -> FloatOrArray:
        """Contact force [N] for penetration [m] and closing rate [m/s]."""
        force = impact_force_ufunc(np.asarray(penetration, dtype=float),
                                   np.asarray(penetration_rate, dtype=float),
                                   float(self.k), float(self.exponent), float(self.cmax),
                                   float(self.d))
        return _as_output(np.asarray(force))


def _check_restitution(e: float) -> float:
    e = float(e)
    if not 0.0 < e <= 1.0:
        raise ValueError(f"restitution e must lie in (0, 1], got {e!r}")
    return e


#: Hysteresis factor ``chi(e)`` of ``F = K h^n (1 + chi hdot / v_impact)`` per
#: model: Hunt & Crossley 1975; Lankarani & Nikravesh 1990; Flores et al. 2011;
#: Gonthier et al. 2004; Zhiying & Qishao 2006 (the seed's eq. 13); ``hertz``
#: is the undamped law.
CHI_MODELS: dict[str, Callable[[float], float]] = {
    "hertz": lambda e: 0.0,
    "hunt-crossley": lambda e: 1.5 * (1.0 - e),
    "lankarani-nikravesh": lambda e: 0.75 * (1.0 - e**2),
    "flores": lambda e: 8.0 * (1.0 - e) / (5.0 * e),
    "gonthier": lambda e: (1.0 - e**2) / e,
    "zhiying-qishao": lambda e: 0.75 * (1.0 - e**2) * np.exp(2.0 * (1.0 - e)),
}


def hysteresis_factor(model: str, restitution: float) -> float:
    """Hysteresis factor ``chi`` of a named model for a target restitution.

    Parameters
    ----------
    model : str
        A key of `CHI_MODELS`.
    restitution : float
        Target coefficient of restitution, ``0 < e <= 1``.

    Returns
    -------
    float
        ``chi`` [-].
    """
    if model not in CHI_MODELS:
        raise ValueError(f"Unknown hysteresis model {model!r}. Pick one of {sorted(CHI_MODELS)}")
    return float(CHI_MODELS[model](_check_restitution(restitution)))


@dataclass(frozen=True)
class HysteresisLaw:
    """Hysteresis-damping law ``F = max(0, k h^n (1 + chi hdot / v_impact))``.

    Penetration ``h`` is positive in contact, ``hdot`` positive while closing
    (same convention as `ImpactLaw.force`); 0 for ``h <= 0``.

    Attributes
    ----------
    k : float
        Stiffness [N/m^exponent], > 0.
    exponent : float
        Force exponent n [-], > 0 (1.5 for Hertz).
    chi : float
        Hysteresis factor [-], >= 0 (see `CHI_MODELS`).
    impact_speed : float
        Closing speed at first touch [m/s], > 0.
    """

    k: float
    exponent: float
    chi: float
    impact_speed: float

    def __post_init__(self) -> None:
        require_positive("k", self.k)
        require_positive("exponent", self.exponent)
        _require_non_negative("chi", self.chi)
        require_positive("impact_speed", self.impact_speed)

    @classmethod
    def from_model(
        cls,
        model: str,
        restitution: float,
        k: float,
        impact_speed: float,
        exponent: float = 1.5,
    ) -> HysteresisLaw:
        """Law of a named model (`CHI_MODELS`) aimed at a target restitution."""
        return cls(k, exponent, hysteresis_factor(model, restitution), impact_speed)

    def force(self, penetration: ArrayLike, penetration_rate: ArrayLike) -> FloatOrArray:
        """Contact force [N] for penetration [m] and closing rate [m/s]."""
        h = np.asarray(penetration, dtype=float)
        inside = h > 0.0
        elastic = self.k * np.where(inside, h, 0.0) ** self.exponent
        factor = 1.0 + self.chi * np.asarray(penetration_rate, dtype=float) / self.impact_speed
        return _as_output(np.where(inside, np.maximum(elastic * factor, 0.0), 0.0))


@dataclass(frozen=True, eq=False)
class ImpactRun:
    """A simulated one-degree-of-freedom impact on a contact law.

    Attributes
    ----------
    time, delta, deltadot, force : ndarray, shape (n_samples,)
        Samples from first touch to separation: time [s], penetration [m],
        its rate [m/s] and the contact force [N]. Uniform over the contact;
        if the force vanishes before ``delta`` does, the last sample is the
        separation instant.
    restitution : float
        ``e = -v_out / v_in`` [-].
    force_max : float
        Peak force [N].
    delta_max : float
        Maximum penetration [m].
    contact_time : float
        Duration of non-zero force [s]. With force clamping a damped law can
        let go while ``delta > 0``; the bodies then fly apart freely.
    separation_time : float
        Time at which ``delta`` returns to 0 [s], >= ``contact_time``.
    """

    time: np.ndarray
    delta: np.ndarray
    deltadot: np.ndarray
    force: np.ndarray
    restitution: float
    force_max: float
    delta_max: float
    contact_time: float
    separation_time: float


def _scales(law: ContactLaw, mass: float, speed: float) -> tuple[float, float]:
    """Length and time scales of the impact: undamped maximum penetration.

    ``delta* = ((n + 1) m v^2 / (2 k))^(1/(n+1))`` from energy balance of the
    elastic part, and ``delta* / v``; a damped law stays within a few of them.
    """
    n = law.exponent
    length = ((n + 1.0) * mass * speed**2 / (2.0 * law.k)) ** (1.0 / (n + 1.0))
    return length, length / speed


def _integrate(
    law: ContactLaw, mass: float, speed: float, max_time: float, length: float
) -> OptimizeResult:
    """Integrate ``m delta'' = -F`` until ``delta`` returns to 0 while opening."""

    def rhs(t: float, y: np.ndarray) -> list[float]:
        return [y[1], -float(law.force(y[0], y[1])) / mass]

    def separation(t: float, y: np.ndarray) -> float:
        return y[0]

    def turning(t: float, y: np.ndarray) -> float:
        return y[1]

    separation.terminal = True
    separation.direction = -1.0
    turning.direction = -1.0
    # DOP853 at rtol 1e-11: the kinks of the clamped force cost a few rejected
    # steps; restitution comes out better than 1e-9.
    solution = solve_ivp(
        rhs,
        (0.0, max_time),
        [0.0, speed],
        method="DOP853",
        rtol=1e-11,
        atol=[1e-13 * length, 1e-13 * speed],
        events=(separation, turning),
        dense_output=True,
    )
    if solution.status != 1 or len(solution.t_events[0]) == 0:
        raise SolverError(
            f"no separation within {max_time:.3g} s ({solution.message}); "
            "the damping may be too strong for the bodies to part"
        )
    return solution


def _force_at(law: ContactLaw, dense: DenseOutput, t: ArrayLike) -> FloatOrArray:
    state = dense(t)
    return law.force(state[0], state[1])


def _peak_force(law: ContactLaw, dense: DenseOutput, time: np.ndarray, force: np.ndarray) -> float:
    """Refine the sampled maximum of the force on the dense output."""
    i = int(np.argmax(force))
    lo, hi = time[max(i - 1, 0)], time[min(i + 1, time.size - 1)]
    best = minimize_scalar(
        lambda t: -float(_force_at(law, dense, t)),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12 * time[-1]},
    )
    return max(float(force[i]), -float(best.fun))


def _contact_end(
    law: ContactLaw, dense: DenseOutput, time: np.ndarray, force: np.ndarray
) -> float:
    """Last instant with a positive force, by bisection on the dense output."""
    last = int(np.flatnonzero(force > 0.0)[-1]) if np.any(force > 0.0) else 0
    if last == time.size - 1:
        return float(time[-1])
    lo, hi = float(time[last]), float(time[last + 1])
    for _ in range(60):  # halves a sampling interval down to round-off
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _force_at(law, dense, mid) > 0.0 else (lo, mid)
    return lo


def _sample_times(contact_end: float, separation: float, n_samples: int) -> np.ndarray:
    """Uniform over the contact, plus the separation instant if it comes later."""
    if separation - contact_end <= 1e-9 * separation:
        return np.linspace(0.0, separation, n_samples)
    return np.append(np.linspace(0.0, contact_end, n_samples - 1), separation)


def simulate_impact(
    law: ContactLaw, mass: float, speed: float, *, n_samples: int = 2001
) -> ImpactRun:
    """One-degree-of-freedom impact of a mass on a contact law.

    Solves ``m delta'' = -F(delta, delta')`` with ``delta(0) = 0``,
    ``delta'(0) = v`` until the bodies part (``delta`` back to 0 while
    opening), with DOP853 at tight tolerances and events for the turning
    point and separation. The force is clamped at 0, so a damped law may let
    go while ``delta > 0``; the free flight that follows is integrated too
    (an `ImpactLaw` can re-engage during it), and the exit speed is the speed
    at ``delta = 0``.

    Parameters
    ----------
    law : ContactLaw
        E.g. `ImpactLaw` or `HysteresisLaw`.
    mass : float
        Effective mass [kg].
    speed : float
        Closing speed at first touch [m/s].
    n_samples : int, optional
        Number of output samples, >= 3.

    Returns
    -------
    ImpactRun
        Samples are uniform over the contact (non-zero force) and, when the
        bodies part later, end with one sample at separation.

    Raises
    ------
    SolverError
        If the bodies have not parted after 1e6 undamped time scales.
    """
    mass = require_positive("mass", mass)
    speed = require_positive("speed", speed)
    if n_samples < 3:
        raise ValueError(f"n_samples must be >= 3, got {n_samples!r}")
    length, scale = _scales(law, mass, speed)
    # Free flight costs a handful of steps however long it is, so a generous
    # horizon only matters for a law that would never let go.
    solution = _integrate(law, mass, speed, 1e6 * scale, length)
    t_sep = float(solution.t_events[0][0])
    # The solver's own steps resolve every change of the force; the uniform
    # grid adds resolution where the steps are long.
    probe = np.union1d(solution.t, np.linspace(0.0, t_sep, n_samples))
    t_contact = _contact_end(law, solution.sol, probe, _force_at(law, solution.sol, probe))
    time = _sample_times(t_contact, t_sep, n_samples)
    state = solution.sol(time)
    force = np.asarray(law.force(state[0], state[1]), dtype=float)
    turning = solution.y_events[1]
    run = ImpactRun(
        time=time,
        delta=state[0],
        deltadot=state[1],
        force=force,
        restitution=-float(solution.y_events[0][0][1]) / speed,
        force_max=_peak_force(law, solution.sol, time, force),
        delta_max=float(turning[0][0]) if len(turning) else float(state[0].max()),
        contact_time=t_contact,
        separation_time=t_sep,
    )
    logger.debug("impact on %r: e=%.6f, F_max=%.6g N", law, run.restitution, run.force_max)
    return run


def restitution_of(model: str, target_e: float, exponent: float = 1.5) -> float:
    """Restitution a hysteresis model actually produces when asked for ``target_e``.

    With ``delta = delta* x`` and ``t = (delta*/v) tau``,
    ``delta* = (m v^2 / K)^(1/(n+1))``, the equation of motion becomes
    ``x'' = -x^n (1 + chi x')``: the result depends on ``chi`` and ``n`` only,
    not on K, m or v, so it is computed with K = m = v = 1.

    Parameters
    ----------
    model : str
        A key of `CHI_MODELS`.
    target_e : float
        Restitution the model's ``chi(e)`` is built for, ``0 < e <= 1``.
    exponent : float, optional
        Force exponent n.

    Returns
    -------
    float
        Restitution of the simulated impact.
    """
    law = HysteresisLaw.from_model(model, target_e, k=1.0, impact_speed=1.0, exponent=exponent)
    return simulate_impact(law, 1.0, 1.0).restitution

