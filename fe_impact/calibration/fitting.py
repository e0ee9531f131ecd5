"""Fitting of lumped contact laws to an FE tooth impact: the calibration step.

An FE single-tooth impact gives a history: time ``t``,
total normal contact force ``F(t)``, approach ``delta(t)``, together with the
effective mass ``m``, the impact speed ``v`` and the measured restitution
``e``. The calibration turns it into the parameters of the lumped laws of
`fe_impact.physics.laws`. This module gathers the
public names of the modules that do it, in the order of the data flow:

- `fe_impact.calibration.history`: the history checked, first touch and end
  of contact found, resampled on a common normalised time;
- `fe_impact.calibration.stiffness`: `fit_power_law`, the stiffness law
  ``F = K delta^xi`` on the loading branch, and `mesh_stiffness`, the
  linearised stiffness ``dF/d delta`` at a nominal load;
- `fe_impact.calibration.impact_model`: the one-degree-of-freedom IMPACT
  impact in dimensionless form, integrated fast (numba) for the fit;
- `fe_impact.calibration.impact_fit`: `fit_impact_law`, the ADAMS
  ``IMPACT`` parameters ``(k, exponent, cmax, d)`` fitted jointly so that
  the impact ``m delta'' = -F_IMPACT(delta, delta')`` from ``delta'(0) = v``
  reproduces the FE force history and restitution;
- `fe_impact.calibration.closed_form`: `hysteresis_chis`, the hysteresis
  factors of the five models of `fe_impact.physics.laws.CHI_MODELS` and the
  restitution each actually produces; `closed_form_parameters` and
  `compare`, the seed's eq. 12-17 values and their relative difference
  from a fit.

Input problems (non-monotonic time, no contact, non-positive mass, ...)
raise `fe_impact.errors.CalibrationError`. SI units throughout.
"""

from __future__ import annotations

from fe_impact.calibration.closed_form import (
    HYSTERESIS_MODELS,
    ClosedFormParameters,
    ModelChi,
    closed_form_parameters,
    compare,
    hysteresis_chis,
)
from fe_impact.calibration.impact_fit import ImpactFit, fit_impact_law
from fe_impact.calibration.stiffness import (
    MeshStiffness,
    PowerFit,
    fit_power_law,
    mesh_stiffness,
)

__all__ = [
    "HYSTERESIS_MODELS",
    "ClosedFormParameters",
    "ImpactFit",
    "MeshStiffness",
    "ModelChi",
    "PowerFit",
    "closed_form_parameters",
    "compare",
    "fit_impact_law",
    "fit_power_law",
    "hysteresis_chis",
    "mesh_stiffness",
]
