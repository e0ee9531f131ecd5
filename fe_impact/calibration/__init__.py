"""Calibration: the lumped IMPACT law from FE impacts.

In the order the data flows:

- :mod:`~fe_impact.calibration.history`: an FE force-approach history checked
  and resampled for fitting;
- :mod:`~fe_impact.calibration.stiffness`: the power law ``F = K delta^xi`` of
  the loading branch and the mesh stiffness at a nominal load;
- :mod:`~fe_impact.calibration.impact_model`: the fast dimensionless one-DOF
  IMPACT-law model;
- :mod:`~fe_impact.calibration.impact_fit`: the joint fit of
  ``(k, exponent, cmax, d)`` to force history and restitution;
- :mod:`~fe_impact.calibration.closed_form`: the seed's closed-form parameters,
  the hysteresis factors and the comparison with the fit;
- :mod:`~fe_impact.calibration.records`: the calibration record, its schema and
  its JSON/CSV files;
- :mod:`~fe_impact.calibration.meshcycle`: the quasi-static mesh-cycle positions;
- :mod:`~fe_impact.calibration.planning`: a run's cases, their settings and
  resume keys; :mod:`~fe_impact.calibration.measurement`: one case from mesh
  to fitted record; :mod:`~fe_impact.calibration.execution`: the cases run on
  Dask (:mod:`~fe_impact.calibration.cluster`), resumable, and the run's files
  (:mod:`~fe_impact.calibration.sweep` re-exports their public names);
- :mod:`~fe_impact.calibration.report` and
  :mod:`~fe_impact.calibration.meshcycle_report`: ``report.md`` and plots.

:mod:`~fe_impact.calibration.fitting` re-exports the fitting functions.
"""
