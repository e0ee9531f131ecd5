"""fe-impact: finite-element tooth impact for face-gear transmissions.

The package follows the data flow of a calibration: gear set -> tooth
surfaces -> mesh -> assembly -> contact -> time integration -> calibration
-> lumped model -> results.

The public API is :mod:`fe_impact.api`, re-exported here: readers
(:func:`read_gearset`, :func:`read_case`, :func:`read_calibration`), the
main job (:func:`calibrate`), a case's solution (:func:`solve`), switching
studies (:func:`run_switching`, :func:`simulate_switching`) and the gear
set's checks (:func:`geometry_report`). Importing the package is cheap: each
function imports the numerical modules it needs when called.
"""

from fe_impact.api import (
    ExportResult,
    calibrate,
    calibration_summary,
    default_gearset,
    export_calibration,
    geometry_report,
    mesh_pair,
    pair_picture,
    presets,
    read_calibration,
    read_case,
    read_gearset,
    read_schedule,
    run_switching,
    seed_studies,
    simulate_switching,
    solve,
    study_preset,
)
from fe_impact.version import __version__

__all__ = [
    "__version__",
    "ExportResult",
    "calibrate",
    "calibration_summary",
    "default_gearset",
    "export_calibration",
    "geometry_report",
    "mesh_pair",
    "pair_picture",
    "presets",
    "read_calibration",
    "read_case",
    "read_gearset",
    "read_schedule",
    "run_switching",
    "seed_studies",
    "simulate_switching",
    "solve",
    "study_preset",
]
