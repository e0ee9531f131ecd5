"""The calibrated laws for the multibody tools users run: ADAMS, CSV tables, Exudyn.

A leaf of the data flow: it reads ``calibration.json``
(`fe_impact.calibration.records.read_calibration`) and, for Exudyn, the
switching model's drive (`fe_impact.switching`), and writes files.

- ``adams`` (`fe_impact.export.adams`): IMPACT statements and contacts per
  stage, kind and closing speed in mm-N-s, spline tables of the position law,
  README.txt;
- ``tables`` (`fe_impact.export.tables`): CSV of k, exponent, cmax and d
  against roll angle, closing speed and kind, README.txt;
- ``exudyn`` (`fe_impact.export.exudyn`): a runnable Exudyn model of one
  stage (`fe_impact.export.exudyn_model` is its template).

`export_calibration` is what ``fe-impact export`` runs.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from fe_impact.errors import CalibrationError, FeImpactError

logger = logging.getLogger(__name__)

__all__ = ["FORMATS", "ExportResult", "export_calibration"]

#: The formats ``--to`` takes.
FORMATS = ("adams", "tables", "exudyn")


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote: the format, the files, and notes on the laws (e.g. a
    kind of contact borrowed from another, closed-form fallbacks)."""

    to: str
    files: tuple[Path, ...]
    notes: tuple[str, ...] = field(default=())


def export_calibration(calibration: str | Path, to: str, out: str | Path, *,
                       gearset: str | Path | None = None, stage: int = 1,
                       speed_rpm: float = 300.0, load: float = 0.0,
                       duration: float = 5.0) -> ExportResult:
    """Export ``calibration`` (a ``calibration.json``) to ``out`` in format ``to``.

    Parameters
    ----------
    calibration : path
        The calibration file (schema ``fe-impact/calibration/2``, or ``/1``).
    to : {"adams", "tables", "exudyn"}
    out : path
        Output folder (made if missing).
    gearset : path, optional
        Gear-set TOML the calibration is of (exudyn only; default: the seed set).
    stage, speed_rpm, load, duration
        The Exudyn model's stage (from 1), pinion speed [r/min], output load [N m]
        and simulated time [s].

    Raises
    ------
    FeImpactError
        An unknown format; CalibrationError for a missing, unreadable or invalid
        file (one line naming it and the key).
    """
    from fe_impact.calibration.records import read_calibration

    if to not in FORMATS:
        raise FeImpactError(f"--to {to!r}: unknown format; pick one of {', '.join(FORMATS)}")
    out = Path(out)
    cal = read_calibration(calibration, law_only=True)
    notes = () if cal.mesh_cycle else (
        "no position dependence: the file has no mesh cycle, so each law holds at every "
        "position along the path of contact" + (" (pair_stiffness.csv has its header only)"
                                                if to == "tables" else
                                                " (no spline tables)"),)
    if to == "adams":
        from fe_impact.export.adams import write_adams

        return ExportResult(to, tuple(write_adams(cal, out)), notes)
    if to == "tables":
        from fe_impact.export.tables import write_tables

        return ExportResult(to, tuple(write_tables(cal, out)), notes)
    return _export_exudyn(calibration, out, gearset, stage, speed_rpm, load, duration)


def _export_exudyn(calibration, out, gearset, stage, speed_rpm, load, duration
                   ) -> ExportResult:
    from fe_impact.export.exudyn import ExudynOptions, exudyn_data, write_script
    from fe_impact.gears.gearset import default_gearset, load_gearset

    options = ExudynOptions(stage, float(speed_rpm), float(load), float(duration))
    gears = default_gearset() if gearset is None else load_gearset(gearset)
    data = exudyn_data(calibration, gears, options)
    if not data["laws"]:
        raise CalibrationError(f"{calibration}: no law for stage {stage}")
    return ExportResult("exudyn", tuple(write_script(data, out)), tuple(data["law_notes"]))
