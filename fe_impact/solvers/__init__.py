"""Solvers: quasi-static contact (:mod:`~fe_impact.solvers.static`) and the
transient impact (:mod:`~fe_impact.solvers.dynamic`)."""
