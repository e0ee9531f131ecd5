"""Calibration: fit the lumped IMPACT law to FE impacts
(:mod:`~fe_impact.calibration.fitting`), the sweep over stages and speeds
(:mod:`~fe_impact.calibration.sweep`) and its report."""
