"""Solvers: quasi-static contact (:mod:`~fe_impact.solvers.static`) and the
transient impact (:mod:`~fe_impact.solvers.dynamic`), with the set-up they
share (:mod:`~fe_impact.solvers.model`), the time integrators
(:mod:`~fe_impact.solvers.integrators`) and the impact measurements
(:mod:`~fe_impact.solvers.measurements`)."""
