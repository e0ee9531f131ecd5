"""Contact stiffness from a force-approach curve: a power law and the mesh stiffness.

- `fit_power_law`: stiffness law ``F = K delta^xi`` fitted to one branch
  (loading, unloading or all) of an FE force-approach history;
- `mesh_stiffness`: linearised stiffness ``dF/d delta`` at a nominal load,
  from that power law and from a local regression of the data.

Input problems (mismatched or non-finite arrays, no contact, a load outside
the data) raise `fe_impact.errors.CalibrationError`. SI units throughout.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from fe_impact.calibration.history import POSITIVE, series
from fe_impact.errors import CalibrationError
from fe_impact.inputs import check_number

logger = logging.getLogger(__name__)

__all__ = ["BRANCHES", "MeshStiffness", "PowerFit", "fit_power_law", "mesh_stiffness"]

#: Parts of a force-approach history a power law can be fitted to.
BRANCHES = ("loading", "unloading", "all")


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
    if branch not in BRANCHES:
        raise CalibrationError(f"branch must be one of {BRANCHES}, got {branch!r}")
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
    delta = series("delta", delta)
    force = series("force", force, delta.size)
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


def _points_near(d: np.ndarray, f: np.ndarray, load: float,
                 window: float) -> tuple[np.ndarray, np.ndarray]:
    """Points whose force lies within a factor ``1 +- window`` of ``load``
    (at least the 7 nearest in ``log F``)."""
    distance = np.abs(np.log(f / load))
    near = distance <= math.log1p(window)
    if np.count_nonzero(near) < 7:
        near = np.zeros(f.size, dtype=bool)
        near[np.argsort(distance)[: min(7, f.size)]] = True
    return d[near], f[near]


def _local_stiffness(d_loc: np.ndarray, f_loc: np.ndarray, load: float) -> tuple[float, float]:
    """Approach [m] and ``dF/d delta`` [N/m] at ``load`` from a regression of
    ``log F`` on ``log delta`` (quadratic from 5 points, else linear)."""
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
    return delta_load, load * float(slope(u_load)) / delta_load


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
    load = check_number("load", load, **POSITIVE)
    if not 0.0 < window < 1.0:
        raise CalibrationError(f"window must lie in (0, 1), got {window!r}")
    power = fit_power_law(delta, force, branch, threshold=threshold)
    d, f = _branch_points(delta, force, branch, 0.0)
    if not f.min() <= load <= f.max():
        raise CalibrationError(
            f"load {load:.6g} N is outside the force range {f.min():.6g}..{f.max():.6g} N of "
            f"the {branch} branch"
        )
    d_loc, f_loc = _points_near(d, f, load, window)
    delta_load, local = _local_stiffness(d_loc, f_loc, load)
    delta_power = (load / power.K) ** (1.0 / power.exponent)
    return MeshStiffness(
        load=load,
        delta=delta_load,
        from_power_law=power.exponent * load / delta_power,
        from_data=local,
        n_local=int(d_loc.size),
        power_fit=power,
    )
