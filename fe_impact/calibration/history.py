"""An FE impact history made ready for the calibration fits, and the checks of its inputs.

An FE single-tooth impact records time ``t``, total
normal contact force ``F(t)`` and approach ``delta(t)``. `prepare_history`
checks them, finds first touch and the end of the contact, and resamples
force and approach on the common normalised time that
`fe_impact.calibration.impact_fit` compares the model against.
`series` and `check_time` are the checks of the arrays, `POSITIVE` and
`RESTITUTION` the ranges of the scalars (for `fe_impact.inputs.check_number`),
shared by the fits. Problems raise `fe_impact.errors.CalibrationError`.
SI units throughout.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from fe_impact.errors import CalibrationError

__all__ = [
    "POSITIVE",
    "RESTITUTION",
    "ImpactHistory",
    "check_time",
    "contact_end",
    "crossing",
    "last_crossing",
    "prepare_history",
    "series",
]

#: `fe_impact.inputs.check_number` keywords of a finite value > 0 (mass, speed, load, ...).
POSITIVE: dict[str, Any] = {"low": 0, "low_open": True, "error": CalibrationError}
#: `fe_impact.inputs.check_number` keywords of a restitution, ``0 < e <= 1``.
RESTITUTION: dict[str, Any] = {"low": 0, "high": 1, "low_open": True, "error": CalibrationError}


# -- checks of the arrays ---------------------------------------------------------------
def series(name: str, values: ArrayLike, size: int | None = None) -> np.ndarray:
    """A finite 1-D float array, of length ``size`` when given."""
    array = np.asarray(values, dtype=float)
    if array.ndim != 1:
        raise CalibrationError(f"{name} must be one-dimensional, got shape {array.shape}")
    if size is not None and array.size != size:
        raise CalibrationError(f"{name} has {array.size} samples, expected {size}")
    if not np.all(np.isfinite(array)):
        raise CalibrationError(f"{name} contains NaN or infinite values")
    return array


def check_time(time: np.ndarray) -> None:
    """CalibrationError naming the first sample that does not come after the one before."""
    steps = np.diff(time)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0])
        raise CalibrationError(
            f"time must increase strictly: sample {i + 1} ({time[i + 1]:.6g} s) does not "
            f"come after sample {i} ({time[i]:.6g} s)"
        )


# -- crossings --------------------------------------------------------------------------
def crossing(t0: float, t1: float, y0: float, y1: float, level: float) -> float:
    """Time at which the line through (t0, y0), (t1, y1) reaches ``level``."""
    if y1 == y0:
        return float(t1)
    return float(t0 + (level - y0) / (y1 - y0) * (t1 - t0))


def contact_end(time: np.ndarray, force: np.ndarray, level: float, start: int) -> float:
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
    return crossing(time[last], time[last + 1], force[last], force[last + 1], level)


def last_crossing(t_rel: np.ndarray, force: np.ndarray, level: float) -> float:
    """Last instant where a model's force drops through ``level`` (0 if never above;
    the last time if still above at the end): the model's contact time."""
    above = np.flatnonzero(force > level)
    if above.size == 0:
        return 0.0
    last = int(above[-1])
    if last == force.size - 1:
        return float(t_rel[-1])
    return crossing(t_rel[last], t_rel[last + 1], force[last], force[last + 1], level)


# -- the prepared history ---------------------------------------------------------------
@dataclass(frozen=True)
class ImpactHistory:
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


def _checked_arrays(time: ArrayLike, force: ArrayLike,
                    delta: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Time, force and approach checked, with the peak force of a history in contact."""
    time = series("time", time)
    force = series("force", force, time.size)
    delta = series("delta", delta, time.size)
    if time.size < 10:
        raise CalibrationError(f"an impact history needs at least 10 samples, got {time.size}")
    check_time(time)
    peak = float(np.max(force))
    if peak <= 0.0 or float(np.max(delta)) <= 0.0:
        raise CalibrationError(
            "no contact in the history: the force (max "
            f"{peak:.6g} N) or the approach (max {float(np.max(delta)):.6g} m) is never positive"
        )
    return time, force, delta, peak


def _onset(time: np.ndarray, delta: np.ndarray, first: int, onset: float | None) -> float:
    """First touch: ``onset`` checked, or where the approach crosses 0 before sample ``first``.

    The approach grows linearly there, the force only like ``t^xi``, so the
    approach marks the touch more sharply than the force.
    """
    if onset is not None:
        if not time[0] <= onset <= time[first]:
            raise CalibrationError(
                f"onset {onset!r} s must lie between the first sample ({time[0]:.6g} s) and the "
                f"first sample in contact ({time[first]:.6g} s)"
            )
        return onset
    closed = np.flatnonzero(delta[: first + 1] <= 0.0)
    if closed.size == 0:
        raise CalibrationError(
            "the history starts in contact (approach > 0 at the first sample); it must "
            "start before first touch, or pass onset="
        )
    j = int(closed[-1])
    if delta[j] == 0.0 or j == time.size - 1:
        return float(time[j])
    return crossing(time[j], time[j + 1], delta[j], delta[j + 1], 0.0)


def _resampled_approach(time: np.ndarray, delta: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Approach at times ``at``; past the history, free flight at the last rate."""
    approach = np.interp(at, time, delta)
    after = at > time[-1]
    rate = (delta[-1] - delta[-2]) / (time[-1] - time[-2])
    approach[after] = delta[-1] + rate * (at[after] - time[-1])
    return approach


def prepare_history(
    time: ArrayLike,
    force: ArrayLike,
    delta: ArrayLike,
    contact_threshold: float,
    n_samples: int,
    margin: float,
    onset: float | None,
) -> ImpactHistory:
    """Check an FE impact history and resample it for the fit.

    The contact runs from first touch (`_onset`) until the force last drops
    below ``contact_threshold`` times its peak; force and approach are
    resampled at ``n_samples`` times uniform over ``[0, 1 + margin]`` contact
    times after first touch. Parameters as `fe_impact.calibration.impact_fit.fit_impact_law`.
    """
    time, force, delta, peak = _checked_arrays(time, force, delta)
    if not 0.0 <= contact_threshold < 0.5:
        raise CalibrationError(f"contact_threshold must lie in [0, 0.5), got {contact_threshold}")
    level = contact_threshold * peak
    first = int(np.flatnonzero(force > level)[0])
    onset = _onset(time, delta, first, onset)
    end = contact_end(time, force, level, first)
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
    return ImpactHistory(
        t_rel=t_rel,
        force=np.interp(onset + t_rel, time, force, right=0.0),
        delta=_resampled_approach(time, delta, onset + t_rel),
        onset=onset,
        force_max=peak,
        delta_max=float(np.max(delta)),
        contact_time=contact_time,
        load_delta=delta[in_contact],
        load_force=force[in_contact],
    )
