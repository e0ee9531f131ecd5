"""The readers of the input files, the seed's presets and the built-in gear set."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from fe_impact.api.common import PathLike

if TYPE_CHECKING:
    from fe_impact.calibration.records import Calibration
    from fe_impact.fe.case import Case
    from fe_impact.gears.gearset import GearSet
    from fe_impact.switching.presets import Preset
    from fe_impact.switching.schedule import DutyCycle

__all__ = ["as_gearset", "cores", "default_gearset", "presets", "read_calibration", "read_case",
           "read_gearset", "read_schedule", "seed_load_torque"]


def read_gearset(path: PathLike | None = None) -> GearSet:
    """Read a gear-set TOML file.

    Parameters
    ----------
    path : str or path-like, optional
        The file (its keys are described in the gear-set guide); None: the
        built-in seed gear set (``fe_impact/gears/seed.toml``, packaged).

    Returns
    -------
    GearSet
        The validated gear set, in SI units.

    Raises
    ------
    GeometryError
        A missing file, a bad key or value (one line naming the file's key).
    """
    from fe_impact.gears.gearset import default_gearset as seed
    from fe_impact.gears.gearset import load_gearset

    return seed() if path is None else load_gearset(path)


def default_gearset() -> GearSet:
    """The built-in seed gear set (three face-gear stages, one pinion)."""
    return read_gearset(None)


def read_case(path: PathLike) -> Case:
    """Read a case file (TOML): mesh, materials, contacts, supports and analysis.

    Parameters
    ----------
    path : str or path-like
        The case file; its ``mesh`` is taken relative to the file's folder.

    Returns
    -------
    Case
        The validated case (``case.analysis.dynamic`` tells a transient one).

    Raises
    ------
    CaseError
        A missing file, a bad key or value (one line naming the key).
    """
    from fe_impact.fe.case import load_case

    return load_case(path)


def read_calibration(path: PathLike) -> Calibration:
    """Read a ``calibration.json`` written by :func:`calibrate`.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Calibration
        Its records (one per FE impact: stage, kind, impact speed, the fitted
        IMPACT parameters ``k``, ``exponent``, ``cmax``, ``d`` and the FE
        measurements), the run's settings and the mesh cycle's
        position-dependent law.

    Raises
    ------
    CalibrationError
        A file of another schema, a missing or malformed field.
    """
    from fe_impact.calibration.records import read_calibration as read

    return read(path)


def presets() -> dict[str, Preset]:
    """The seed's operating conditions for :func:`run_switching`, by name.

    ``table1`` .. ``table3`` (one stage, no load, 100 / 300 / 1000 r/min),
    ``table4`` (stage 2, 300 r/min, four loads), ``variable-speed`` and
    ``variable-load`` (switching 1 -> 2 -> 3), and each of their cases alone
    (``table1-100rpm``, ``table4-500Nmm``, ...).
    """
    from fe_impact.switching.presets import PRESETS

    return dict(PRESETS)


def read_schedule(path: PathLike) -> DutyCycle:
    """Read a schedule file (TOML): the drive's duty cycle, segment by segment.

    Parameters
    ----------
    path : str or path-like
        The file: per segment the engaged stage, the pinion speed (constant or
        ramped), the output load (constant, ramped or a CSV series) and the
        duration; a segment on another stage is a ratio switch.

    Returns
    -------
    DutyCycle
        ``name``, ``description`` and ``schedule`` (the segments as the model
        runs them), for :func:`run_switching` and :func:`simulate_switching`.

    Raises
    ------
    CaseError
        One line naming the file, the key (with the segment's index), the value
        and what is allowed.
    """
    from fe_impact.switching.schedule import read_schedule as read

    return read(path)


def seed_load_torque() -> float:
    """The largest load torque of the seed's presets on the output [N m] (1 N m): the
    default load of :func:`geometry_report`."""
    from fe_impact.switching.presets import seed_load_torque as largest

    return largest()


def cores() -> int:
    """The cores this process may use (the default number of local workers)."""
    from fe_impact.calibration import cluster

    return cluster.cores()


def as_gearset(gearset: GearSet | PathLike | None) -> GearSet:
    """A gear set given as itself, as its TOML file, or None (the seed set)."""
    if gearset is None or isinstance(gearset, (str, os.PathLike)):
        return read_gearset(gearset)
    return gearset
