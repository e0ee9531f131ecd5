"""Lumped multistage ratio-switching dynamics with the calibrated impact law.

Stage of the data flow after calibration: a torsional model of the
multistage face-gear drive (pinions, face-gear rings, output), with backlash
on both flanks, the ADAMS IMPACT law per tooth pair from the calibration
(or closed forms), mesh stiffness following the tooth pairs in contact,
optional Coulomb friction, and scheduled ratio switches; the seed study's
conditions as presets and its Tables 1-4 for comparison.

- :mod:`~fe_impact.switching.geometry`: line-of-action kinematics, contact
  path, tip-corner gaps, backlash, switching speed (and the seed's eq. 5);
- :mod:`~fe_impact.switching.calibration`: IMPACT-law tables per stage and
  impact speed from a calibration file or closed forms;
- :mod:`~fe_impact.switching.model`: `DriveModel`, `Segment`, `StageSchedule`;
- :mod:`~fe_impact.switching.simulation`: `simulate` (compiled kernel in
  ``_kernel``), `SwitchingRun`, `ImpactEvents`;
- :mod:`~fe_impact.switching.presets`, :mod:`~fe_impact.switching.seed_tables`:
  the seed's conditions and values;
- :mod:`~fe_impact.switching.statistics`: statistics in the seed's layout;
- :mod:`~fe_impact.switching.report`, :mod:`~fe_impact.cli.switching`:
  result files and the ``fe-impact switching`` subcommand (leaves).
"""

from fe_impact.switching.calibration import (
    LawSet,
    LawTable,
    closed_form_laws,
    laws_for,
    load_calibration,
)
from fe_impact.switching.geometry import (
    MeshGeometry,
    default_backlash,
    mesh_geometry,
    seed_switching_speed,
    switching_speed,
)
from fe_impact.switching.model import DriveModel, Friction, Segment, StageSchedule
from fe_impact.switching.presets import PRESETS, Preset, get_preset
from fe_impact.switching.simulation import ImpactEvents, SwitchingRun, mechanical_energy, simulate
from fe_impact.switching.statistics import comparison_rows, impact_statistics, series_statistics

__all__ = [
    "PRESETS",
    "DriveModel",
    "Friction",
    "ImpactEvents",
    "LawSet",
    "LawTable",
    "MeshGeometry",
    "Preset",
    "Segment",
    "StageSchedule",
    "SwitchingRun",
    "closed_form_laws",
    "comparison_rows",
    "default_backlash",
    "get_preset",
    "impact_statistics",
    "laws_for",
    "load_calibration",
    "mechanical_energy",
    "mesh_geometry",
    "seed_switching_speed",
    "series_statistics",
    "simulate",
    "switching_speed",
]
