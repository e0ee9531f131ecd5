"""Joint fit of the ADAMS ``IMPACT`` law ``(k, exponent, cmax, d)`` to an FE tooth impact.

An FE single-tooth impact gives a history (time,
total normal contact force, approach) with the effective mass ``m``, the
impact speed ``v`` and the measured restitution ``e``. `fit_impact_law`
finds the IMPACT law whose one-degree-of-freedom impact
``m delta'' = -F_IMPACT(delta, delta')`` from ``delta'(0) = v`` reproduces
both, in named steps:

1. `fe_impact.calibration.history.prepare_history`: check the history,
   find first touch and the end of contact, resample on a common
   normalised time;
2. `_starts`: starting points from the power law of the samples in contact
   and, for a few ``d``, the ``cmax`` that gives the restitution;
3. `_Residual`: the least-squares residual (force history, optionally
   approach, restitution) on the fast model of
   `fe_impact.calibration.impact_model`;
4. `_refine`: trust-region least squares from each start, the lowest cost wins;
5. `_quality`: the quality figures from the reference integrator
   `fe_impact.physics.laws.simulate_impact`.

Input problems raise `fe_impact.errors.CalibrationError`. SI units throughout.
"""

from __future__ import annotations

import logging
import math
import time as _time
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import OptimizeResult, brentq, least_squares

from fe_impact.calibration.history import (
    POSITIVE,
    RESTITUTION,
    ImpactHistory,
    last_crossing,
    prepare_history,
)
from fe_impact.calibration.impact_model import dimensionless_restitution, run_scaled
from fe_impact.calibration.stiffness import fit_power_law
from fe_impact.errors import CalibrationError, FeImpactError
from fe_impact.inputs import check_number
from fe_impact.physics import laws

logger = logging.getLogger(__name__)

__all__ = ["ImpactFit", "fit_impact_law"]

#: Names of the optimiser's variables, for the notes on active bounds.
_VARIABLES = ("F_ref", "exponent", "cmax", "d")


# -- the fitted law -----------------------------------------------------------------------
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
        Residual evaluations of the optimisations from all starts (the root
        solves for the starting ``cmax`` not counted).
    start : tuple of float
        Starting ``(k, exponent, cmax, d)`` of the winning optimisation.
    cmax_range, d_range : tuple of float
        Smallest and largest ``cmax`` [N s/m] and ``d`` [m] of the laws that fit
        the history as well as the winner (:data:`EQUAL_FIT`, :func:`_damping_ranges`):
        a wide range says the history does not determine the damping.
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
    cmax_range: tuple[float, float] | None = None
    d_range: tuple[float, float] | None = None
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


# -- the optimiser's variables ------------------------------------------------------------
@dataclass(frozen=True)
class _Scales:
    """The optimiser's variables ``q`` and the parameters ``(k, exponent, cmax, d)``.

    ``q = (log(F_ref / F_peak), exponent, log(cmax v / F_peak), log(d / delta_max))``
    with ``F_ref = k delta_max^exponent``: all of order one, and ``F_ref``
    removes most of the strong correlation between ``log k`` and the exponent.
    """

    force_max: float  # FE peak force F_peak [N]
    delta_max: float  # FE largest approach [m]
    speed: float  # impact speed v [m/s]

    def unpack(self, q: np.ndarray) -> tuple[float, float, float, float]:
        """``(k, exponent, cmax, d)`` of the variables ``q``."""
        f_pk, d_pk = self.force_max, self.delta_max
        n = float(q[1])
        return (
            f_pk * math.exp(q[0]) / d_pk**n,
            n,
            f_pk * math.exp(q[2]) / self.speed,
            d_pk * math.exp(q[3]),
        )

    def pack(self, k: float, n: float, cmax: float, d: float) -> np.ndarray:
        """The variables ``q`` of ``(k, exponent, cmax, d)``."""
        f_pk, d_pk = self.force_max, self.delta_max
        return np.array(
            [
                math.log(k * d_pk**n / f_pk),
                n,
                math.log(cmax * self.speed / f_pk),
                math.log(d / d_pk),
            ]
        )


class _Bounds(NamedTuple):
    """Bounds of the exponent and of ``d / delta_max``."""

    exponent: tuple[float, float]
    d: tuple[float, float]

    @classmethod
    def checked(cls, exponent_bounds: tuple[float, float],
                d_bounds: tuple[float, float]) -> _Bounds:
        """The bounds as floats; CalibrationError unless ``0 < low < high`` for both."""
        lo_n, hi_n = (float(b) for b in exponent_bounds)
        lo_d, hi_d = (float(b) for b in d_bounds)
        if not 0.0 < lo_n < hi_n:
            raise CalibrationError(
                f"exponent_bounds must satisfy 0 < low < high, got {exponent_bounds}"
            )
        if not 0.0 < lo_d < hi_d:
            raise CalibrationError(f"d_bounds must satisfy 0 < low < high, got {d_bounds}")
        return cls((lo_n, hi_n), (lo_d, hi_d))


# -- residual -----------------------------------------------------------------------------
@dataclass
class _Residual:
    """Least-squares residual of the variables ``q``; counts its evaluations.

    Force (and with ``delta_weight > 0`` approach) on the common normalised
    time, relative to the FE peaks and divided by ``sqrt(n_samples)`` so
    that the cost is their mean square; then ``restitution_weight`` times the
    restitution error (0 restitution when the model's bodies never part).
    """

    hist: ImpactHistory
    scales: _Scales
    mass: float
    speed: float
    restitution: float
    restitution_weight: float
    delta_weight: float
    evaluations: int = 0

    def __call__(self, q: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        hist = self.hist
        norm = 1.0 / math.sqrt(hist.t_rel.size)
        k, n, cmax, d = self.scales.unpack(q)
        f_model, d_model, e_model, ok = run_scaled(k, n, cmax, d, self.mass, self.speed,
                                                   hist.t_rel)
        parts = [norm * (f_model - hist.force) / hist.force_max]
        if self.delta_weight > 0.0:
            parts.append(norm * self.delta_weight * (d_model - hist.delta) / hist.delta_max)
        e_model = e_model if ok else 0.0
        parts.append(np.array([self.restitution_weight * (e_model - self.restitution)]))
        return np.concatenate(parts)


# -- starts -------------------------------------------------------------------------------
def _power_start(hist: ImpactHistory, bounds: _Bounds) -> tuple[float, float]:
    """``(k, exponent)`` of the power law of the samples in contact, exponent within bounds."""
    power = fit_power_law(hist.load_delta, hist.load_force, "all")
    lo_n, hi_n = bounds.exponent
    n0 = min(max(power.exponent, lo_n + 1e-6), hi_n - 1e-6)
    k0 = power.K if n0 == power.exponent else hist.force_max / hist.delta_max**n0
    return k0, n0


def _cmax_for_restitution(n0: float, dd: float, restitution: float,
                          log_c_range: tuple[float, float]) -> float:
    """Dimensionless damping ``c`` whose fast-model restitution is ``restitution``
    (clipped to ``exp(log_c_range)``), at exponent ``n0`` and ``d / L = dd``."""

    def miss(log_c: float) -> float:
        return dimensionless_restitution(n0, math.exp(log_c), dd) - restitution

    a, b = log_c_range
    if miss(a) <= 0.0:
        log_c = a
    elif miss(b) >= 0.0:
        log_c = b
    else:
        log_c = brentq(miss, a, b, xtol=1e-6)
    return math.exp(log_c)


def _starts(hist: ImpactHistory, scales: _Scales, bounds: _Bounds, mass: float,
            restitution: float,
            d_starts: tuple[float, ...]) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Starting variables, one per ``d_starts``, and the lower and upper bounds of ``q``."""
    f_pk, d_pk, speed = hist.force_max, hist.delta_max, scales.speed
    k0, n0 = _power_start(hist, bounds)
    (lo_n, hi_n), (lo_d, hi_d) = bounds
    length = (mass * speed**2 / k0) ** (1.0 / (n0 + 1.0))
    c_lo, c_hi = 1e-9 * f_pk / speed, 1e3 * f_pk / speed  # cmax range of the start
    lower = np.array([-np.inf, lo_n, math.log(c_lo * speed / f_pk) - 1.0, math.log(lo_d)])
    upper = np.array([np.inf, hi_n, np.inf, math.log(hi_d)])
    log_c_range = (math.log(c_lo * length / (mass * speed)),
                   math.log(c_hi * length / (mass * speed)))
    starts = []
    for frac in d_starts:
        d0 = min(max(frac, lo_d), hi_d) * d_pk
        c0 = _cmax_for_restitution(n0, d0 / length, restitution, log_c_range)
        cmax0 = c0 * mass * speed / length
        starts.append(np.clip(scales.pack(k0, n0, cmax0, d0), lower + 1e-9, upper - 1e-9))
    return starts, lower, upper


# -- refinement ---------------------------------------------------------------------------
def _refine(residual: _Residual, starts: list[np.ndarray], lower: np.ndarray,
            upper: np.ndarray) -> tuple[OptimizeResult, np.ndarray, list[OptimizeResult]]:
    """The lowest-cost least-squares optimum over the starts, with its start, and the
    optima of every start that could be evaluated."""
    best, optima = None, []
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
        optima.append(result)
        if best is None or result.cost < best[0].cost:
            best = (result, q0)
    if best is None:  # pragma: no cover - defensive
        raise CalibrationError("the impact-law fit could not evaluate any start")
    return best[0], best[1], optima


#: Laws whose residual (the root of the least-squares cost) is within this
#: fraction of the best one's fit the history equally well. On the tooth
#: impacts the residual is what no IMPACT law follows (the teeth's vibration
#: and the FE contact's discrete onset: 1.5-2.2% of the peak force on the
#: default impacts when the sectors started at rest behind their hubs,
#: 0.08-0.26% since they start in rigid motion), and a thousandth of it
#: separates no two laws; the ranges of ``cmax`` and ``d`` over such laws
#: (:attr:`ImpactFit.cmax_range`, ``d_range``) say how far the history
#: determines the damping. Seen on the nearly elastic stage-2 impact at
#: 100 r/min (e = 0.9998): two starts 1e-5 apart in residual, cmax 0.50 and
#: 2.88 N s/m, and which won depended on the history's last digits.
EQUAL_FIT = 1e-3


def _damping_ranges(optima: list[OptimizeResult], best: OptimizeResult, scales: _Scales,
                    lower: np.ndarray, upper: np.ndarray
                    ) -> tuple[tuple[float, float], tuple[float, float]]:
    """``(cmax_lo, cmax_hi), (d_lo, d_hi)`` of the laws that fit as well as ``best``
    (:data:`EQUAL_FIT`): the other starts' optima within it, and how far ``log cmax``
    and ``log d`` reach before the cost's quadratic model about ``best`` (``J^T J``,
    the other variables following) crosses it, within the variables' bounds and
    ``cmax`` within the starts' search range (a direction the history does not see
    reaches a bound)."""
    limit = best.cost * (1.0 + EQUAL_FIT) ** 2
    qs = [r.x for r in optima if r.cost <= limit]
    H = best.jac.T @ best.jac
    lam, V = np.linalg.eigh(H)
    flat = lam <= 1e-14 * max(float(lam.max(initial=0.0)), 1e-300)
    with np.errstate(divide="ignore"):
        cov = (V ** 2 / np.where(flat, 0.0, lam)).sum(axis=1)     # diag(H^-1), inf if flat
    cov[np.any((V ** 2 > 1e-16) & flat, axis=1)] = np.inf
    reach = np.sqrt(2.0 * (limit - best.cost) * cov)
    top = upper.copy()
    top[2] = min(top[2], math.log(1e3))     # cmax v / F_peak at most 1e3: the starts' range
    for i in (2, 3):
        for side in (-1.0, 1.0):
            q = best.x.copy()
            q[i] = float(np.clip(best.x[i] + side * reach[i], lower[i], top[i]))
            qs.append(q)
    laws_ = [scales.unpack(q) for q in qs]
    cmax, d = [q[2] for q in laws_], [q[3] for q in laws_]
    return (min(cmax), max(cmax)), (min(d), max(d))


def _notes(result: OptimizeResult) -> list[str]:
    """The optimiser's status, then each variable stopped at a bound."""
    notes = [str(result.message)]
    for i in np.flatnonzero(result.active_mask != 0):
        side = "lower" if result.active_mask[i] < 0 else "upper"
        notes.append(f"{_VARIABLES[i]} at its {side} bound")
    return notes


# -- quality ------------------------------------------------------------------------------
class _Figures(NamedTuple):
    """The fitted law's impact measured like the FE one."""

    force_rms: float  # RMS force difference on the common time / FE peak force [-]
    restitution: float  # [-]
    force_max: float  # [N]
    contact_time: float  # [s]
    note: str | None  # why the fast model was used, if it was


def _quality(params: tuple[float, float, float, float], hist: ImpactHistory, mass: float,
             speed: float, contact_threshold: float) -> _Figures:
    """Figures of the fitted ``(k, exponent, cmax, d)`` from the reference integrator
    (independent of the fast one); from the fast model if that integration fails."""
    k, n, cmax, d = params
    level = contact_threshold * hist.force_max
    note = None
    try:
        run = laws.simulate_impact(laws.ImpactLaw(k, n, cmax, d), mass, speed)
        e_model = run.restitution
        f_model = np.interp(hist.t_rel, run.time, run.force, right=0.0)
        peak = run.force_max
        t_c = last_crossing(run.time, run.force, level)
    except FeImpactError as exc:
        note = f"reference integration failed ({exc}); figures from the fast model"
        f_model, _, e_model, _ = run_scaled(k, n, cmax, d, mass, speed, hist.t_rel)
        peak = float(np.max(f_model))
        t_c = last_crossing(hist.t_rel, f_model, level)
    rms = float(np.sqrt(np.mean((f_model - hist.force) ** 2))) / hist.force_max
    return _Figures(rms, float(e_model), peak, t_c, note)


# -- the fit ------------------------------------------------------------------------------
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
    mass = check_number("mass", mass, **POSITIVE)
    speed = check_number("speed", speed, **POSITIVE)
    restitution = check_number("restitution", restitution, **RESTITUTION)
    bounds = _Bounds.checked(exponent_bounds, d_bounds)
    if n_samples < 20:
        raise CalibrationError(f"n_samples must be >= 20, got {n_samples}")
    hist = prepare_history(time, force, delta, contact_threshold, n_samples, margin, onset)
    scales = _Scales(hist.force_max, hist.delta_max, speed)
    residual = _Residual(hist, scales, mass, speed, restitution, restitution_weight,
                         delta_weight)
    starts, lower, upper = _starts(hist, scales, bounds, mass, restitution, d_starts)
    result, q0, optima = _refine(residual, starts, lower, upper)
    k, n, cmax, d = scales.unpack(result.x)
    cmax_range, d_range = _damping_ranges(optima, result, scales, lower, upper)
    notes = _notes(result)
    success = bool(result.success) and all(math.isfinite(v) for v in (k, n, cmax, d))
    figures = _quality((k, n, cmax, d), hist, mass, speed, contact_threshold)
    if figures.note is not None:
        notes.append(figures.note)
    fit = ImpactFit(
        k=k,
        exponent=n,
        cmax=cmax,
        d=d,
        residual_force_rms=figures.force_rms,
        restitution_model=figures.restitution,
        restitution_error=figures.restitution - restitution,
        peak_force_error=figures.force_max / hist.force_max - 1.0,
        contact_time_error=figures.contact_time / hist.contact_time - 1.0,
        success=success,
        message="; ".join(notes),
        n_evaluations=residual.evaluations,
        start=scales.unpack(q0),
        cmax_range=cmax_range,
        d_range=d_range,
        fe_force_max=hist.force_max,
        fe_contact_time=hist.contact_time,
        wall_time=_time.perf_counter() - clock,
    )
    logger.debug("impact-law fit: %s", fit)
    return fit
