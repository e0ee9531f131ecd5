"""Fitting of lumped contact laws to an FE tooth impact: the calibration step.

An FE single-tooth impact (DESIGN.md section 4) gives a history: time ``t``,
total normal contact force ``F(t)``, approach ``delta(t)``, together with the
effective mass ``m``, the impact speed ``v`` and the measured restitution
``e``. This module turns it into the parameters of the lumped laws of
`fe_impact.physics.laws` (DESIGN.md section 5):

- `fit_power_law`: stiffness law ``F = K delta^xi`` on the loading branch;
- `mesh_stiffness`: linearised stiffness ``dF/d delta`` at a nominal load;
- `fit_impact_law`: ADAMS ``IMPACT`` parameters ``(k, exponent, cmax, d)``
  fitted jointly so that the one-degree-of-freedom impact
  ``m delta'' = -F_IMPACT(delta, delta')`` from ``delta'(0) = v`` reproduces
  the FE force history and restitution;
- `hysteresis_chis`: the hysteresis factors of the five models of
  `fe_impact.physics.laws.CHI_MODELS` and the restitution each actually produces;
- `closed_form_parameters` and `compare`: the seed's eq. 12-17 values and
  their relative difference from a fit.

Input problems (non-monotonic time, no contact, non-positive mass, ...)
raise `fe_impact.errors.CalibrationError`. SI units throughout.

Fast impact model
-----------------
With ``L = (m v^2 / k)^(1/(n+1))``, ``delta = L x`` and ``t = (L/v) tau``
the IMPACT impact becomes
``x'' = -max(0, x^n + STEP(x, 0, 0, d/L, 1) c x')``, ``x(0) = 0``,
``x'(0) = 1``, with ``c = cmax L / (m v)``; forces scale with
``k L^n = m v^2 / L``. So ``k`` only scales time and force, and the shape of
the history depends on ``(n, c, d/L)`` alone. The fit integrates this
problem, with the force of `fe_impact.physics.impact_law.impact_force_scalar`
at ``k = 1``, by fixed-step classical Runge-Kutta (numba, about 0.2 ms per
history), which keeps the residual a smooth function of the parameters for
finite-difference Jacobians, and reads it at the sample times with cubic
Hermite interpolation. The final quality figures are recomputed with
`fe_impact.physics.laws.simulate_impact` (adaptive DOP853), independently of the
fast integrator.
"""

from __future__ import annotations

import logging
import math
import time as _time
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from numba import njit
from numpy.typing import ArrayLike
from scipy.optimize import brentq, least_squares

from fe_impact.errors import CalibrationError, FeImpactError
from fe_impact.physics import hertz, laws, seed
from fe_impact.physics.impact_law import impact_force_scalar

logger = logging.getLogger(__name__)

__all__ = [
    "HYSTERESIS_MODELS",
    "ClosedFormParameters",
    "ImpactFit",
    "MeshStiffness",
    "ModelChi",
    "PowerFit",
    "closed_form_parameters",
    "compare",
    "fit_impact_law",
    "fit_power_law",
    "hysteresis_chis",
    "mesh_stiffness",
]

#: The five hysteresis-damping models of `fe_impact.physics.laws.CHI_MODELS` (without
#: the undamped ``"hertz"`` entry), in the order of DESIGN.md section 5.
HYSTERESIS_MODELS: tuple[str, ...] = tuple(m for m in laws.CHI_MODELS if m != "hertz")

_BRANCHES = ("loading", "unloading", "all")

# Dimensionless step of the fast integrator, in units of L / v. A Hertz
# contact lasts about 4.2 of them, so about 2000 steps per impact; the global
# error of RK4 is ~1e-10 on smooth stretches, and the kinks of the clamped
# force (C0) and of STEP (C1) cost O(dt^2) ~ 1e-6 locally at worst.
_DT = 2e-3
# Longest dimensionless history before the model is declared stuck.
_MAX_TAU = 400.0


# -- checks -----------------------------------------------------------------------------
def _positive(name: str, value: float) -> float:
    """``value`` as a float; CalibrationError naming it unless finite and > 0."""
    try:
        value = float(value)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"{name} must be a positive number, got {value!r}") from exc
    if not math.isfinite(value) or value <= 0.0:
        raise CalibrationError(f"{name} must be a positive finite number, got {value!r}")
    return value


def _restitution(value: float) -> float:
    value = float(value)
    if not 0.0 < value <= 1.0:
        raise CalibrationError(f"restitution must lie in (0, 1], got {value!r}")
    return value


def _series(name: str, values: ArrayLike, size: int | None = None) -> np.ndarray:
    """A finite 1-D float array, of length ``size`` when given."""
    array = np.asarray(values, dtype=float)
    if array.ndim != 1:
        raise CalibrationError(f"{name} must be one-dimensional, got shape {array.shape}")
    if size is not None and array.size != size:
        raise CalibrationError(f"{name} has {array.size} samples, expected {size}")
    if not np.all(np.isfinite(array)):
        raise CalibrationError(f"{name} contains NaN or infinite values")
    return array


def _check_time(time: np.ndarray) -> None:
    steps = np.diff(time)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0])
        raise CalibrationError(
            f"time must increase strictly: sample {i + 1} ({time[i + 1]:.6g} s) does not "
            f"come after sample {i} ({time[i]:.6g} s)"
        )


# -- power law --------------------------------------------------------------------------
@dataclass(frozen=True)
class PowerFit:
    """Stiffness law ``F = K delta^exponent`` fitted to a force-approach curve.

    Attributes
    ----------
    K : float
        Stiffness coefficient [N/m^exponent].
    exponent : float
        Exponent xi [-].
    r2 : float
        Coefficient of determination of the fit in linear space [-].
    rms_rel : float
        RMS of the force residual relative to the peak force of the fitted
        points [-].
    n_points : int
        Number of points fitted.
    delta_range : tuple of float
        Smallest and largest approach fitted [m].
    """

    K: float
    exponent: float
    r2: float
    rms_rel: float
    n_points: int
    delta_range: tuple[float, float] = (0.0, 0.0)

    def force(self, delta: ArrayLike) -> np.ndarray | float:
        """Force [N] of the law at approach ``delta`` [m] (0 for ``delta <= 0``)."""
        d = np.asarray(delta, dtype=float)
        out = self.K * np.where(d > 0.0, d, 0.0) ** self.exponent
        return float(out) if out.ndim == 0 else out

    def stiffness(self, delta: ArrayLike) -> np.ndarray | float:
        """Tangent stiffness ``K xi delta^(xi - 1)`` [N/m] at approach ``delta`` > 0 [m]."""
        d = np.asarray(delta, dtype=float)
        out = self.K * self.exponent * d ** (self.exponent - 1.0)
        return float(out) if out.ndim == 0 else out


def _branch(delta: np.ndarray, force: np.ndarray, branch: str) -> tuple[np.ndarray, np.ndarray]:
    """Samples of one branch: up to (loading) or from (unloading) the largest approach."""
    if branch not in _BRANCHES:
        raise CalibrationError(f"branch must be one of {_BRANCHES}, got {branch!r}")
    i_max = int(np.argmax(delta))
    if branch == "loading":
        return delta[: i_max + 1], force[: i_max + 1]
    if branch == "unloading":
        return delta[i_max:], force[i_max:]
    return delta, force


def _branch_points(
    delta: ArrayLike, force: ArrayLike, branch: str, threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """Validated branch points with ``delta > 0`` and ``F >= threshold * F_peak``."""
    delta = _series("delta", delta)
    force = _series("force", force, delta.size)
    if not 0.0 <= threshold < 1.0:
        raise CalibrationError(f"threshold must lie in [0, 1), got {threshold!r}")
    if not (np.any(force > 0.0) and np.any(delta > 0.0)):
        raise CalibrationError("no contact in the history: force or approach is never positive")
    d, f = _branch(delta, force, branch)
    peak = float(np.max(f)) if f.size else 0.0
    if peak <= 0.0:
        raise CalibrationError(f"no positive force on the {branch} branch")
    keep = (d > 0.0) & (f > 0.0) & (f >= threshold * peak)
    if np.count_nonzero(keep) < 3:
        raise CalibrationError(
            f"only {np.count_nonzero(keep)} point(s) of the {branch} branch have delta > 0 and "
            f"F >= {threshold:g} F_peak; a power law needs at least 3"
        )
    return d[keep], f[keep]


def fit_power_law(
    delta: ArrayLike, force: ArrayLike, branch: str = "loading", *, threshold: float = 0.05
) -> PowerFit:
    """Fit ``F = K delta^xi`` to one branch of a force-approach history.

    The loading branch is the part of the history up to the largest approach
    (``delta`` increasing); ``"unloading"`` takes the rest, ``"all"`` every
    sample. Points with ``delta <= 0`` or a force below ``threshold`` times
    the branch's peak force are dropped: near first touch force and approach
    are tiny, and a small offset ``eps`` of the approach (onset detection,
    the ramp of a penalty contact, the first few contact elements of an FE
    mesh) changes the force by ``xi eps / delta`` relative, which blows up as
    ``delta -> 0`` and dominates a logarithmic fit. With 5% of the peak force
    (``delta >= 0.136 delta_peak`` for Hertz) an offset of 0.1% of the
    largest approach moves the force by at most about 1.1%.

    The fit is a linear least-squares fit of ``log F = log K + xi log delta``,
    refined by nonlinear least squares on the force itself (residual relative
    to the peak force), which weights the high loads that matter for the
    stiffness and treats additive noise correctly.

    Parameters
    ----------
    delta : array_like
        Approach [m].
    force : array_like
        Contact force [N], same length.
    branch : {"loading", "unloading", "all"}, optional
        Part of the history to fit.
    threshold : float, optional
        Points below this fraction of the branch's peak force are dropped.

    Returns
    -------
    PowerFit

    Raises
    ------
    CalibrationError
        Mismatched or non-finite input, no contact, fewer than 3 usable points.

    Examples
    --------
    >>> d = np.linspace(0.0, 10e-6, 50)
    >>> fit = fit_power_law(d, 2e10 * d**1.5)
    >>> round(fit.K / 1e10, 6), round(fit.exponent, 6)
    (2.0, 1.5)
    """
    d, f = _branch_points(delta, force, branch, threshold)
    peak = float(np.max(f))
    log_d, log_f = np.log(d), np.log(f)
    # Reference approach at the largest point: log F_ref and xi are then
    # nearly uncorrelated, unlike log K and xi (log delta ~ -11.5).
    d_ref = float(np.max(d))
    u = log_d - math.log(d_ref)
    design = np.column_stack([np.ones_like(u), u])
    (log_fref, xi), *_ = np.linalg.lstsq(design, log_f, rcond=None)

    def residual(p: np.ndarray) -> np.ndarray:
        return np.exp(p[0] - math.log(peak) + p[1] * u) - f / peak

    def jacobian(p: np.ndarray) -> np.ndarray:
        model = np.exp(p[0] - math.log(peak) + p[1] * u)
        return np.column_stack([model, model * u])

    refined = least_squares(
        residual, [log_fref, xi], jac=jacobian, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15
    )
    log_fref, xi = (float(v) for v in refined.x)
    K = math.exp(log_fref - xi * math.log(d_ref))
    fitted = K * d**xi
    ss_res = float(np.sum((fitted - f) ** 2))
    ss_tot = float(np.sum((f - f.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0.0 else 1.0
    rms = math.sqrt(ss_res / f.size) / peak
    fit = PowerFit(K, xi, r2, rms, int(f.size), (float(d.min()), float(d.max())))
    logger.debug("power law on %s branch: %s", branch, fit)
    return fit


# -- mesh stiffness ---------------------------------------------------------------------
@dataclass(frozen=True)
class MeshStiffness:
    """Linearised contact stiffness ``dF/d delta`` at a nominal load.

    Attributes
    ----------
    load : float
        Nominal load [N].
    delta : float
        Approach at that load from the local regression [m].
    from_power_law : float
        ``xi load / delta_L`` with ``delta_L = (load / K)^(1/xi)`` of the
        fitted power law [N/m].
    from_data : float
        Slope of a local quadratic regression of ``log F`` on ``log delta``
        around the load [N/m].
    n_local : int
        Points used by the local regression.
    power_fit : PowerFit
        The power law behind ``from_power_law``.
    """

    load: float
    delta: float
    from_power_law: float
    from_data: float
    n_local: int
    power_fit: PowerFit


def mesh_stiffness(
    delta: ArrayLike,
    force: ArrayLike,
    load: float,
    *,
    branch: str = "loading",
    window: float = 0.15,
    threshold: float = 0.05,
) -> MeshStiffness:
    """Linearised stiffness ``dF/d delta`` [N/m] of a force-approach curve at ``load``.

    Two estimates:

    - from the power law of `fit_power_law`:
      ``K xi delta_L^(xi - 1) = xi load / delta_L``;
    - directly from the data: a quadratic regression of ``log F`` on
      ``log delta`` over the points whose force lies within a factor
      ``1 +- window`` of the load (at least the 7 nearest in ``log F``), then
      ``dF/d delta = F (d log F / d log delta) / delta`` where the regression
      crosses the load. This is exact for a power law and has a relative
      error of order ``window^2`` times the change of the local exponent.

    An impact's loading branch includes the damping force; for a static mesh
    stiffness use a quasi-static or lightly damped history.

    Parameters
    ----------
    delta, force : array_like
        Approach [m] and force [N].
    load : float
        Nominal load [N], within the force range of the branch.
    branch : {"loading", "unloading", "all"}, optional
    window : float, optional
        Relative half-width of the force window of the local regression.
    threshold : float, optional
        Passed to `fit_power_law`.

    Returns
    -------
    MeshStiffness

    Raises
    ------
    CalibrationError
        Bad input, or a load outside the force range of the branch.
    """
    load = _positive("load", load)
    if not 0.0 < window < 1.0:
        raise CalibrationError(f"window must lie in (0, 1), got {window!r}")
    power = fit_power_law(delta, force, branch, threshold=threshold)
    d, f = _branch_points(delta, force, branch, 0.0)
    if not f.min() <= load <= f.max():
        raise CalibrationError(
            f"load {load:.6g} N is outside the force range {f.min():.6g}..{f.max():.6g} N of "
            f"the {branch} branch"
        )
    distance = np.abs(np.log(f / load))
    near = distance <= math.log1p(window)
    if np.count_nonzero(near) < 7:
        near = np.zeros(f.size, dtype=bool)
        near[np.argsort(distance)[: min(7, f.size)]] = True
    d_loc, f_loc = d[near], f[near]
    centre = float(np.exp(np.mean(np.log(d_loc))))
    u = np.log(d_loc / centre)
    degree = 2 if d_loc.size >= 5 and np.ptp(u) > 0.0 else 1
    if np.ptp(u) == 0.0:
        raise CalibrationError("the local regression needs points at more than one approach")
    coeffs = np.polynomial.polynomial.polyfit(u, np.log(f_loc), degree)
    poly = np.polynomial.Polynomial(coeffs)
    slope = poly.deriv()
    # Approach at the load: Newton from the local power law's estimate.
    u_load = float((math.log(load) - coeffs[0]) / coeffs[1])
    for _ in range(50):
        step = (poly(u_load) - math.log(load)) / slope(u_load)
        u_load -= float(step)
        if abs(step) < 1e-14:
            break
    delta_load = centre * math.exp(u_load)
    local = load * float(slope(u_load)) / delta_load
    delta_power = (load / power.K) ** (1.0 / power.exponent)
    return MeshStiffness(
        load=load,
        delta=delta_load,
        from_power_law=power.exponent * load / delta_power,
        from_data=local,
        n_local=int(d_loc.size),
        power_fit=power,
    )


# -- fast dimensionless impact ------------------------------------------------------------
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
        k1x, k1u = u, -_force(x, u, n, c, dd)
        x2, u2 = x + 0.5 * dt * k1x, u + 0.5 * dt * k1u
        k2x, k2u = u2, -_force(x2, u2, n, c, dd)
        x3, u3 = x + 0.5 * dt * k2x, u + 0.5 * dt * k2u
        k3x, k3u = u3, -_force(x3, u3, n, c, dd)
        x4, u4 = x + dt * k3x, u + dt * k3u
        k4x, k4u = u4, -_force(x4, u4, n, c, dd)
        xn = x + dt / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x)
        un = u + dt / 6.0 * (k1u + 2.0 * k2u + 2.0 * k3u + k4u)
        an = -_force(xn, un, n, c, dd)
        tn = t + dt
        parted = xn < 0.0 and un < 0.0
        t_sep, u_sep = tn, un
        if parted:
            # Separation inside the step: Newton on the Hermite cubic of x.
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


def _run_scaled(
    k: float, n: float, cmax: float, d: float, mass: float, speed: float, t_rel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """Force [N] and approach [m] at times ``t_rel`` after first touch; restitution."""
    length = (mass * speed**2 / k) ** (1.0 / (n + 1.0))
    force_scale = mass * speed**2 / length
    tau = t_rel * (speed / length)
    c = cmax * length / (mass * speed)
    max_steps = int(max(_MAX_TAU, 2.0 * tau[-1]) / _DT) + 1
    xs, _, fs, u_sep, _, ok = _simulate(n, c, d / length, _DT, tau, max_steps)
    return fs * force_scale, xs * length, -u_sep, bool(ok)


def _dimensionless_restitution(n: float, c: float, dd: float) -> float:
    _, _, _, u_sep, _, ok = _simulate(n, c, dd, _DT, np.zeros(1), int(_MAX_TAU / _DT) + 1)
    return -u_sep if ok else 0.0


# -- impact-law fit -----------------------------------------------------------------------
class _ImpactParameters(Protocol):
    k: float
    exponent: float
    cmax: float
    d: float


@dataclass(frozen=True)
class ImpactFit:
    """ADAMS ``IMPACT`` parameters fitted to an FE impact history.

    Attributes
    ----------
    k : float
        Stiffness [N/m^exponent].
    exponent : float
        Force exponent [-].
    cmax : float
        Full damping coefficient [N s/m].
    d : float
        Penetration at which the damping reaches ``cmax`` [m].
    residual_force_rms : float
        RMS of ``F_model - F_FE`` over the common normalised time, relative
        to the FE peak force [-] (from `fe_impact.physics.laws.simulate_impact`).
    restitution_model : float
        Restitution of the fitted law in the one-DOF impact [-].
    restitution_error : float
        ``restitution_model - e_FE`` [-].
    peak_force_error : float
        Relative error of the model's peak force [-].
    contact_time_error : float
        Relative error of the model's contact time [-], both measured as the
        time from first touch until the force last drops below
        ``contact_threshold`` times the FE peak force.
    success : bool
        The optimiser converged to finite parameters.
    message : str
        Optimiser status and any warning (parameter at a bound, ...).
    n_evaluations : int
        Model evaluations of the whole fit (starts and optimisation).
    start : tuple of float
        Starting ``(k, exponent, cmax, d)`` of the winning optimisation.
    fe_force_max, fe_contact_time : float
        Peak force [N] and contact time [s] measured on the FE history.
    wall_time : float
        Duration of the fit [s].
    """

    k: float
    exponent: float
    cmax: float
    d: float
    residual_force_rms: float
    restitution_model: float
    restitution_error: float
    peak_force_error: float
    contact_time_error: float
    success: bool
    message: str
    n_evaluations: int = 0
    start: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    fe_force_max: float = 0.0
    fe_contact_time: float = 0.0
    wall_time: float = field(default=0.0, compare=False)

    @property
    def law(self) -> laws.ImpactLaw:
        """The fitted law."""
        return laws.ImpactLaw(self.k, self.exponent, self.cmax, self.d)

    def as_dict(self) -> dict[str, Any]:
        """Plain-Python summary, for JSON (the ``impact`` block of a calibration file)."""
        keys = (
            "k", "exponent", "cmax", "d", "residual_force_rms", "restitution_model",
            "restitution_error", "peak_force_error", "contact_time_error", "success",
            "message",
        )
        return {key: getattr(self, key) for key in keys}


@dataclass(frozen=True)
class _History:
    """An FE impact prepared for the fit: samples on the common normalised time."""

    t_rel: np.ndarray  # sample times after first touch [s]
    force: np.ndarray  # FE force at t_rel [N]
    delta: np.ndarray  # FE approach at t_rel [m]
    onset: float  # time of first touch in the FE clock [s]
    force_max: float  # FE peak force [N]
    delta_max: float  # FE largest approach [m]
    contact_time: float  # FE contact time [s]
    load_delta: np.ndarray  # approach of the samples in contact [m]
    load_force: np.ndarray  # force of the samples in contact [N]


def _crossing(t0: float, t1: float, y0: float, y1: float, level: float) -> float:
    """Time at which the line through (t0, y0), (t1, y1) reaches ``level``."""
    if y1 == y0:
        return float(t1)
    return float(t0 + (level - y0) / (y1 - y0) * (t1 - t0))


def _contact_end(time: np.ndarray, force: np.ndarray, level: float, start: int) -> float:
    """Last instant after ``start`` where the force drops through ``level``.

    Raises CalibrationError if the force is still above it at the last sample.
    """
    above = np.flatnonzero(force[start:] > level) + start
    last = int(above[-1])
    if last == force.size - 1:
        raise CalibrationError(
            f"contact does not end within the history: the force is still "
            f"{force[-1]:.6g} N at the last sample ({time[-1]:.6g} s); record until separation"
        )
    return _crossing(time[last], time[last + 1], force[last], force[last + 1], level)


def _prepare(
    time: ArrayLike,
    force: ArrayLike,
    delta: ArrayLike,
    contact_threshold: float,
    n_samples: int,
    margin: float,
    onset: float | None,
) -> _History:
    time = _series("time", time)
    force = _series("force", force, time.size)
    delta = _series("delta", delta, time.size)
    if time.size < 10:
        raise CalibrationError(f"an impact history needs at least 10 samples, got {time.size}")
    _check_time(time)
    peak = float(np.max(force))
    if peak <= 0.0 or float(np.max(delta)) <= 0.0:
        raise CalibrationError(
            "no contact in the history: the force (max "
            f"{peak:.6g} N) or the approach (max {float(np.max(delta)):.6g} m) is never positive"
        )
    if not 0.0 <= contact_threshold < 0.5:
        raise CalibrationError(f"contact_threshold must lie in [0, 0.5), got {contact_threshold}")
    level = contact_threshold * peak
    first = int(np.flatnonzero(force > level)[0])
    if onset is None:
        # First touch where the approach crosses 0 before the force rises:
        # the approach grows linearly there, the force only like t^xi.
        closed = np.flatnonzero(delta[: first + 1] <= 0.0)
        if closed.size == 0:
            raise CalibrationError(
                "the history starts in contact (approach > 0 at the first sample); it must "
                "start before first touch, or pass onset="
            )
        j = int(closed[-1])
        onset = float(time[j]) if delta[j] == 0.0 or j == time.size - 1 else _crossing(
            time[j], time[j + 1], delta[j], delta[j + 1], 0.0
        )
    elif not time[0] <= onset <= time[first]:
        raise CalibrationError(
            f"onset {onset!r} s must lie between the first sample ({time[0]:.6g} s) and the "
            f"first sample in contact ({time[first]:.6g} s)"
        )
    end = _contact_end(time, force, level, first)
    contact_time = end - onset
    if contact_time <= 0.0:
        raise CalibrationError("the contact has zero duration")
    in_contact = (time >= onset) & (time <= end)
    if np.count_nonzero(in_contact) < 10:
        raise CalibrationError(
            f"only {np.count_nonzero(in_contact)} samples in contact; resolve the impact with "
            "at least 10 (better 100)"
        )
    t_rel = np.linspace(0.0, 1.0 + margin, n_samples) * contact_time
    approach = np.interp(onset + t_rel, time, delta)
    after = onset + t_rel > time[-1]  # free flight past the history: last rate
    rate = (delta[-1] - delta[-2]) / (time[-1] - time[-2])
    approach[after] = delta[-1] + rate * (onset + t_rel[after] - time[-1])
    return _History(
        t_rel=t_rel,
        force=np.interp(onset + t_rel, time, force, right=0.0),
        delta=approach,
        onset=onset,
        force_max=peak,
        delta_max=float(np.max(delta)),
        contact_time=contact_time,
        load_delta=delta[in_contact],
        load_force=force[in_contact],
    )


def _model_contact_time(t_rel: np.ndarray, force: np.ndarray, level: float) -> float:
    above = np.flatnonzero(force > level)
    if above.size == 0:
        return 0.0
    last = int(above[-1])
    if last == force.size - 1:
        return float(t_rel[-1])
    return _crossing(t_rel[last], t_rel[last + 1], force[last], force[last + 1], level)


def fit_impact_law(
    time: ArrayLike,
    force: ArrayLike,
    delta: ArrayLike,
    mass: float,
    speed: float,
    restitution: float,
    *,
    restitution_weight: float = 1.0,
    delta_weight: float = 0.0,
    exponent_bounds: tuple[float, float] = (1.0, 3.0),
    d_bounds: tuple[float, float] = (1e-3, 2.0),
    n_samples: int = 400,
    margin: float = 0.25,
    contact_threshold: float = 0.01,
    onset: float | None = None,
    d_starts: tuple[float, ...] = (0.25, 0.5, 1.0),
) -> ImpactFit:
    """Fit the ADAMS ``IMPACT`` law to an FE impact history and restitution.

    Finds ``(k, exponent, cmax, d)`` such that the one-degree-of-freedom
    impact ``m delta'' = -F_IMPACT(delta, delta')``, ``delta(0) = 0``,
    ``delta'(0) = v`` reproduces

    - the FE force history on a common normalised time: ``n_samples`` times
      uniform over ``[0, 1 + margin]`` FE contact times after first touch
      (the margin penalises a model whose contact lasts too long), residual
      ``(F_model - F_FE) / F_peak``;
    - the restitution, residual ``restitution_weight (e_model - e_FE)``;
    - optionally the approach history, residual
      ``delta_weight (delta_model - delta_FE) / delta_max``. In a consistent
      one-DOF impact the force history already fixes the approach
      (``m delta'' = -F``), so this is off by default.

    Force and approach residuals are divided by ``sqrt(n_samples)``: the
    cost is then their mean square, and a restitution error of 0.01 weighs
    as much as a 1% RMS force error.

    The optimiser (`scipy.optimize.least_squares`, trust region reflective)
    works on ``log(F_ref / F_peak)`` with ``F_ref = k delta_max^exponent``,
    the exponent, ``log(cmax v / F_peak)`` and ``log(d / delta_max)``: all of
    order one, and ``F_ref`` removes most of the strong correlation between
    ``log k`` and the exponent (``log delta ~ -11.5``). Bounds: the exponent
    within ``exponent_bounds``, ``d / delta_max`` within ``d_bounds``.

    Starts: the power law of the samples in contact (`fit_power_law`, all
    points above 5% of the peak force, exponent clipped to its bounds) and,
    for each ``d = d_starts * delta_max``, the ``cmax`` that gives the
    target restitution (1-D root solve on the fast model). Each start is
    optimised and the lowest cost wins, which guards against the
    ``(k, exponent)`` and ``(cmax, d)`` trade-offs leading to a local minimum.

    Identifiability: ``d`` and ``cmax`` are only separately determined when
    the damping is significant and the ramp ends inside the contact
    (``d`` below about ``delta_max``). With ``d >> delta_max`` only
    ``cmax / d^2`` matters; with ``d << delta_max`` or a tiny damping (``e``
    near 1) ``d`` hardly changes the history. The fit then still reproduces
    the history, but the reported ``d`` (and with it ``cmax``) is arbitrary
    within a wide range.

    Parameters
    ----------
    time : array_like
        Time [s], strictly increasing, from before first touch (approach
        <= 0) to after the force has dropped back to 0.
    force : array_like
        Total normal contact force [N].
    delta : array_like
        Approach [m], 0 at first touch.
    mass : float
        Effective mass [kg], > 0.
    speed : float
        Closing speed at first touch [m/s], > 0.
    restitution : float
        Measured restitution, ``0 < e <= 1``.
    restitution_weight, delta_weight : float, optional
        Weights of the restitution and approach residuals.
    exponent_bounds : tuple of float, optional
        Bounds of the exponent.
    d_bounds : tuple of float, optional
        Bounds of ``d / delta_max``.
    n_samples : int, optional
        Samples of the common normalised time.
    margin : float, optional
        Extra fraction of the FE contact time after it ends.
    contact_threshold : float, optional
        Fraction of the FE peak force below which the force counts as out
        of contact (contact end and contact time).
    onset : float, optional
        Time of first touch [s]; by default where the approach crosses 0.
    d_starts : tuple of float, optional
        Starting values of ``d / delta_max``.

    Returns
    -------
    ImpactFit

    Raises
    ------
    CalibrationError
        Bad input (non-monotonic time, no contact, contact not ending in the
        history, non-positive mass or speed, restitution outside (0, 1]), or
        no start at all could be evaluated.
    """
    clock = _time.perf_counter()
    mass = _positive("mass", mass)
    speed = _positive("speed", speed)
    restitution = _restitution(restitution)
    lo_n, hi_n = (float(b) for b in exponent_bounds)
    lo_d, hi_d = (float(b) for b in d_bounds)
    if not 0.0 < lo_n < hi_n:
        raise CalibrationError(
            f"exponent_bounds must satisfy 0 < low < high, got {exponent_bounds}"
        )
    if not 0.0 < lo_d < hi_d:
        raise CalibrationError(f"d_bounds must satisfy 0 < low < high, got {d_bounds}")
    if n_samples < 20:
        raise CalibrationError(f"n_samples must be >= 20, got {n_samples}")
    hist = _prepare(time, force, delta, contact_threshold, n_samples, margin, onset)
    f_pk, d_pk = hist.force_max, hist.delta_max
    norm = 1.0 / math.sqrt(n_samples)
    evaluations = 0

    def unpack(q: np.ndarray) -> tuple[float, float, float, float]:
        n = float(q[1])
        return (
            f_pk * math.exp(q[0]) / d_pk**n,
            n,
            f_pk * math.exp(q[2]) / speed,
            d_pk * math.exp(q[3]),
        )

    def pack(k: float, n: float, cmax: float, d: float) -> np.ndarray:
        return np.array(
            [
                math.log(k * d_pk**n / f_pk),
                n,
                math.log(cmax * speed / f_pk),
                math.log(d / d_pk),
            ]
        )

    def residual(q: np.ndarray) -> np.ndarray:
        nonlocal evaluations
        evaluations += 1
        k, n, cmax, d = unpack(q)
        f_model, d_model, e_model, ok = _run_scaled(k, n, cmax, d, mass, speed, hist.t_rel)
        parts = [norm * (f_model - hist.force) / f_pk]
        if delta_weight > 0.0:
            parts.append(norm * delta_weight * (d_model - hist.delta) / d_pk)
        e_model = e_model if ok else 0.0
        parts.append(np.array([restitution_weight * (e_model - restitution)]))
        return np.concatenate(parts)

    # Start: power law of the contact samples, cmax for the restitution.
    power = fit_power_law(hist.load_delta, hist.load_force, "all")
    n0 = min(max(power.exponent, lo_n + 1e-6), hi_n - 1e-6)
    k0 = power.K if n0 == power.exponent else f_pk / d_pk**n0
    length = (mass * speed**2 / k0) ** (1.0 / (n0 + 1.0))
    c_lo, c_hi = 1e-9 * f_pk / speed, 1e3 * f_pk / speed  # cmax range of the start
    lower = np.array([-np.inf, lo_n, math.log(c_lo * speed / f_pk) - 1.0, math.log(lo_d)])
    upper = np.array([np.inf, hi_n, np.inf, math.log(hi_d)])

    starts = []
    for frac in d_starts:
        d0 = min(max(frac, lo_d), hi_d) * d_pk
        dd = d0 / length

        def miss(log_c: float, dd: float = dd) -> float:
            return _dimensionless_restitution(n0, math.exp(log_c), dd) - restitution

        a, b = math.log(c_lo * length / (mass * speed)), math.log(c_hi * length / (mass * speed))
        if miss(a) <= 0.0:
            log_c = a
        elif miss(b) >= 0.0:
            log_c = b
        else:
            log_c = brentq(miss, a, b, xtol=1e-6)
        cmax0 = math.exp(log_c) * mass * speed / length
        q0 = np.clip(pack(k0, n0, cmax0, d0), lower + 1e-9, upper - 1e-9)
        starts.append(q0)

    best = None
    for q0 in starts:
        try:
            result = least_squares(
                residual,
                q0,
                bounds=(lower, upper),
                method="trf",
                x_scale=1.0,
                diff_step=1e-7,
                xtol=1e-12,
                ftol=1e-14,
                gtol=1e-12,
                max_nfev=300,
            )
        except (ValueError, FeImpactError) as exc:  # pragma: no cover - defensive
            logger.debug("start %s failed: %s", q0, exc)
            continue
        if best is None or result.cost < best[0].cost:
            best = (result, q0)
    if best is None:  # pragma: no cover - defensive
        raise CalibrationError("the impact-law fit could not evaluate any start")
    result, q0 = best
    k, n, cmax, d = unpack(result.x)
    notes = [str(result.message)]
    names = ("F_ref", "exponent", "cmax", "d")
    for i in np.flatnonzero(result.active_mask != 0):
        side = "lower" if result.active_mask[i] < 0 else "upper"
        notes.append(f"{names[i]} at its {side} bound")
    success = bool(result.success) and all(math.isfinite(v) for v in (k, n, cmax, d))

    # Quality figures from the reference integrator, independent of the fast one.
    level = contact_threshold * f_pk
    try:
        run = laws.simulate_impact(laws.ImpactLaw(k, n, cmax, d), mass, speed)
        e_model = run.restitution
        f_model = np.interp(hist.t_rel, run.time, run.force, right=0.0)
        peak = run.force_max
        t_c = _model_contact_time(run.time, run.force, level)
    except FeImpactError as exc:
        notes.append(f"reference integration failed ({exc}); figures from the fast model")
        f_model, _, e_model, _ = _run_scaled(k, n, cmax, d, mass, speed, hist.t_rel)
        peak = float(np.max(f_model))
        t_c = _model_contact_time(hist.t_rel, f_model, level)
    rms = float(np.sqrt(np.mean((f_model - hist.force) ** 2))) / f_pk
    fit = ImpactFit(
        k=k,
        exponent=n,
        cmax=cmax,
        d=d,
        residual_force_rms=rms,
        restitution_model=float(e_model),
        restitution_error=float(e_model) - restitution,
        peak_force_error=peak / f_pk - 1.0,
        contact_time_error=t_c / hist.contact_time - 1.0,
        success=success,
        message="; ".join(notes),
        n_evaluations=evaluations,
        start=unpack(q0),
        fe_force_max=f_pk,
        fe_contact_time=hist.contact_time,
        wall_time=_time.perf_counter() - clock,
    )
    logger.debug("impact-law fit: %s", fit)
    return fit


# -- hysteresis models ------------------------------------------------------------------
@dataclass(frozen=True)
class ModelChi:
    """Hysteresis factor of one model for a target restitution.

    Attributes
    ----------
    chi : float
        ``chi(e)`` of the model [-] (`fe_impact.physics.laws.hysteresis_factor`).
    restitution : float
        Restitution the law ``K h^n (1 + chi hdot / v)`` actually produces in
        a one-DOF impact [-] (`fe_impact.physics.laws.restitution_of`).
    """

    chi: float
    restitution: float


def hysteresis_chis(restitution: float, exponent: float = 1.5) -> dict[str, ModelChi]:
    """Hysteresis factors of the five models for a target restitution.

    Parameters
    ----------
    restitution : float
        Target restitution, ``0 < e <= 1``.
    exponent : float, optional
        Force exponent of the law used to measure the produced restitution.

    Returns
    -------
    dict of str to ModelChi
        Keyed by model name (`HYSTERESIS_MODELS`), in that order.

    Examples
    --------
    >>> round(hysteresis_chis(0.7)["flores"].restitution, 3)
    0.683
    """
    restitution = _restitution(restitution)
    exponent = _positive("exponent", exponent)
    return {
        model: ModelChi(
            chi=laws.hysteresis_factor(model, restitution),
            restitution=laws.restitution_of(model, restitution, exponent),
        )
        for model in HYSTERESIS_MODELS
    }


# -- closed forms -----------------------------------------------------------------------
@dataclass(frozen=True)
class ClosedFormParameters:
    """IMPACT parameters from the seed's closed forms (eq. 12, 13, 16, 17).

    Attributes
    ----------
    k : float
        Hertz stiffness ``(4/3) E* sqrt(R)`` (eq. 12) or the one given [N/m^1.5].
    exponent : float
        1.5 [-].
    cmax : float
        Eq. 13 at the eq. 16 approach [N s/m].
    d : float
        Eq. 17 at the Hertz peak force [m]; for a sphere-type contact this
        equals ``delta_max``.
    delta_max : float
        Eq. 16, ``(5 m v^2 / (4 k))^(2/5)`` [m].
    force_max : float
        ``k delta_max^1.5`` [N].
    contact_time : float
        Hertz contact time ``2.94328 delta_max / v`` [s].
    restitution : float
        Target restitution used in eq. 13 [-].
    """

    #: Units of the fields, for tables and files.
    UNITS: ClassVar[dict[str, str]] = {
        "k": "N/m^1.5",
        "exponent": "-",
        "cmax": "N s/m",
        "d": "m",
        "delta_max": "m",
        "force_max": "N",
        "contact_time": "s",
        "restitution": "-",
    }

    k: float
    exponent: float
    cmax: float
    d: float
    delta_max: float
    force_max: float
    contact_time: float
    restitution: float

    @property
    def law(self) -> laws.ImpactLaw:
        """The closed-form law."""
        return laws.ImpactLaw(self.k, self.exponent, self.cmax, self.d)

    def as_dict(self) -> dict[str, float]:
        """Values keyed like `UNITS`."""
        return {key: float(getattr(self, key)) for key in self.UNITS}


def closed_form_parameters(
    R: float,
    E_star: float,
    mass: float,
    speed: float,
    restitution: float,
    *,
    k: float | None = None,
) -> ClosedFormParameters:
    """The seed's closed-form IMPACT parameters for one impact.

    - ``k = (4/3) E* sqrt(R)`` (eq. 12, `fe_impact.physics.seed.stiffness`),
      unless ``k`` is given (e.g. from an elliptical Hertz contact);
    - ``exponent = 1.5``;
    - ``delta_max = (5 m v^2 / (4 k))^(2/5)`` (eq. 16), ``F_max = k delta_max^1.5``
      and the Hertz contact time (`fe_impact.physics.hertz.impact_from_stiffness`);
    - ``cmax = 3 k (1 - e^2) exp(2 (1 - e)) delta_max^1.5 / (4 v)`` (eq. 13,
      `fe_impact.physics.seed.damping`);
    - ``d = (9 F_max^2 / (16 R E*^2))^(1/3)`` (eq. 17,
      `fe_impact.physics.seed.penetration_depth`).

    Parameters
    ----------
    R : float
        Effective radius [m].
    E_star : float
        Effective modulus [Pa].
    mass : float
        Effective mass [kg].
    speed : float
        Impact speed v_k [m/s].
    restitution : float
        Restitution e for eq. 13, ``0 < e <= 1``.
    k : float, optional
        Stiffness [N/m^1.5] overriding eq. 12.

    Returns
    -------
    ClosedFormParameters

    Examples
    --------
    >>> p = closed_form_parameters(0.01, 115.66e9, 0.5, 0.1, 0.8)
    >>> round(p.delta_max * 1e6, 2), round(p.force_max), round(p.contact_time * 1e6)
    (11.04, 566, 325)
    """
    R = _positive("R", R)
    E_star = _positive("E_star", E_star)
    mass = _positive("mass", mass)
    speed = _positive("speed", speed)
    restitution = _restitution(restitution)
    k = seed.stiffness(R, E_star) if k is None else _positive("k", k)
    hit = hertz.impact_from_stiffness(mass, speed, k)
    return ClosedFormParameters(
        k=k,
        exponent=1.5,
        cmax=seed.damping(k, restitution, speed, hit.delta_max, 1.5),
        d=seed.penetration_depth(hit.force_max, R, E_star),
        delta_max=hit.delta_max,
        force_max=hit.force_max,
        contact_time=hit.contact_time,
        restitution=restitution,
    )


def compare(fit: _ImpactParameters, closed: ClosedFormParameters) -> dict[str, dict[str, float]]:
    """Side-by-side comparison of fitted and closed-form IMPACT parameters.

    Parameters
    ----------
    fit : ImpactFit or fe_impact.physics.laws.ImpactLaw
        Anything with ``k``, ``exponent``, ``cmax`` and ``d``.
    closed : ClosedFormParameters

    Returns
    -------
    dict
        For ``k``, ``exponent``, ``cmax``, ``d`` and ``force_at_delta_max``
        (the elastic force ``k delta^exponent`` of each law at the closed-form
        ``delta_max``: comparable even when the exponents differ, unlike
        ``k`` whose units then differ), a dict with ``fit``, ``closed_form``
        and ``relative_difference = fit / closed_form - 1``.
    """
    values = {
        name: (float(getattr(fit, name)), float(getattr(closed, name)))
        for name in ("k", "exponent", "cmax", "d")
    }
    values["force_at_delta_max"] = (
        float(fit.k) * closed.delta_max ** float(fit.exponent),
        closed.k * closed.delta_max**closed.exponent,
    )
    return {
        name: {
            "fit": a,
            "closed_form": b,
            "relative_difference": a / b - 1.0 if b != 0.0 else math.inf,
        }
        for name, (a, b) in values.items()
    }
