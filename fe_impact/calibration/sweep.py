"""Calibration sweep: FE tooth impacts at the operating speeds -> lumped IMPACT laws.

The sweep's public names in one place, from the three modules that do the work,
in the order the data flows:

- :mod:`~fe_impact.calibration.planning`: the run's cases (:func:`plan_cases`),
  their shared options (:class:`Settings`) and resume keys (:func:`case_hash`);
- :mod:`~fe_impact.calibration.measurement`: one case meshed, solved and
  fitted (:func:`run_case`, :func:`calibration_case`, :func:`measure_and_fit`);
- :mod:`~fe_impact.calibration.execution`: the cases run on Dask, resumable and
  stoppable, and the run's files (:func:`calibrate`), on the cluster of
  :mod:`~fe_impact.calibration.cluster`.
"""

from fe_impact.calibration.cluster import CaseStopped, check_scheduler_address, cores, numba_folder
from fe_impact.calibration.execution import (
    STOP_GRACE,
    SUMMARY_SCHEMA,
    Studies,
    Sweep,
    calibrate,
    finished_record,
    load_finished,
    run_locked_case,
)
from fe_impact.calibration.measurement import (
    GAP_FRACTION,
    HISTORY_PER_CONTACT,
    MAX_GAP,
    STEPS_PER_CONTACT,
    STOP_AFTER_SEPARATION,
    VTU_FRAME_STRIDE,
    ZONE_REACH,
    calibration_case,
    measure_and_fit,
    restitution_models,
    run_case,
)
from fe_impact.calibration.meshcycle import PositionCase
from fe_impact.calibration.planning import (
    LEVELS,
    NOMINAL_LOAD,
    OPERATING_SPEEDS_RPM,
    ImpactCase,
    Settings,
    case_contact,
    case_hash,
    mesh_impact_speed,
    plan_cases,
)

__all__ = [
    "GAP_FRACTION", "HISTORY_PER_CONTACT", "LEVELS", "MAX_GAP", "NOMINAL_LOAD",
    "OPERATING_SPEEDS_RPM", "STEPS_PER_CONTACT", "STOP_AFTER_SEPARATION", "STOP_GRACE",
    "SUMMARY_SCHEMA", "VTU_FRAME_STRIDE", "ZONE_REACH", "CaseStopped", "ImpactCase",
    "PositionCase", "Settings", "Studies", "Sweep", "calibrate", "calibration_case",
    "case_contact", "case_hash", "check_scheduler_address", "cores", "finished_record",
    "load_finished", "measure_and_fit", "mesh_impact_speed", "numba_folder", "plan_cases",
    "restitution_models", "run_case", "run_locked_case",
]
