"""The Python API: everything the ``fe-impact`` command does, as functions.

The command line is a thin layer over this module (meshio's ``_cli`` calls
``meshio.read`` and ``meshio.write`` the same way): each subcommand parses its
options, calls one function here and prints what it returns. A script does
the same without the command::

    import fe_impact

    gearset = fe_impact.read_gearset("geometry/two-stage.toml")
    rows = fe_impact.geometry_report(gearset)            # fe-impact geometry
    pair = fe_impact.mesh_pair(gearset, stage=1, level="coarse", out="pair")
    result = fe_impact.solve(pair.case_path, out="impact")   # fe-impact solve
    calibration = fe_impact.calibrate("geometry/two-stage.toml", stages=[1], speeds=[300],
                                      level="coarse", out="cal")   # fe-impact calibrate
    study = fe_impact.run_switching("table1", "geometry/two-stage.toml",
                                    "cal/calibration.json", out="sw")  # fe-impact switching

(in a script, :func:`calibrate` goes under ``if __name__ == "__main__":``: its
Dask workers import the script again).

Units are SI throughout (m, s, N, kg), except where a name says otherwise
(``speeds`` in r/min, ``roll_angle_deg``). Bad input raises a subclass of
:class:`fe_impact.errors.FeImpactError` whose message is one line naming the
option, the value and what is allowed; options shared with the command are
named in the command's spelling (``--impact-speeds`` for ``impact_speeds``).

Functions that print progress take ``echo``, a callable given each line
(the command passes :func:`print`); without it the lines go to this module's
logger at INFO level.
"""

from __future__ import annotations

from fe_impact.api.calibrating import calibrate, calibration_summary, seed_studies
from fe_impact.api.common import Echo, PathLike  # noqa: F401 (types of the arguments)
from fe_impact.api.geometry import geometry_report, mesh_pair, pair_picture
from fe_impact.api.readers import (
    cores,
    default_gearset,
    presets,
    read_calibration,
    read_case,
    read_gearset,
    read_schedule,
    seed_load_torque,
)
from fe_impact.api.rolling import check_roll_inputs, roll
from fe_impact.api.solving import MAX_FRAMES, MIN_STEPS_PER_CONTACT, solve
from fe_impact.api.switching import run_switching, simulate_switching, study_preset
from fe_impact.export import FORMATS as EXPORT_FORMATS
from fe_impact.export import ExportResult, export_calibration

__all__ = [
    "EXPORT_FORMATS",
    "MAX_FRAMES",
    "MIN_STEPS_PER_CONTACT",
    "calibrate",
    "calibration_summary",
    "cores",
    "default_gearset",
    "export_calibration",
    "ExportResult",
    "geometry_report",
    "mesh_pair",
    "pair_picture",
    "presets",
    "read_calibration",
    "read_case",
    "read_gearset",
    "read_schedule",
    "roll",
    "RollInputs",
    "check_roll_inputs",
    "run_switching",
    "seed_load_torque",
    "seed_studies",
    "simulate_switching",
    "solve",
    "study_preset",
]


def __getattr__(name: str):
    """``TOP_LAND_MIN``: the narrowest top land the seed file's outer radii leave [m]
    (imported when asked: it lives with the geometry report's numerical code);
    ``RollInputs``: the rolling mesh's inputs (:mod:`fe_impact.rolling.api`)."""
    if name == "TOP_LAND_MIN":
        from fe_impact.gears.report import TOP_LAND_MIN

        return TOP_LAND_MIN
    if name == "RollInputs":
        from fe_impact.rolling.api import RollInputs

        return RollInputs
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
