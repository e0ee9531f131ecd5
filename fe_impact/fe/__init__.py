"""Finite-element model: mesh loading (:mod:`~fe_impact.fe.mesh`), the case
description and its reader (:mod:`~fe_impact.fe.case`) and writer
(:mod:`~fe_impact.fe.casefile`), the compiled element loops
(:mod:`~fe_impact.fe.assembly`), elasticity (:mod:`~fe_impact.fe.elasticity`),
J2 plasticity (:mod:`~fe_impact.fe.plasticity`), the DOFs, supports and rigid
bodies in reduced coordinates (:mod:`~fe_impact.fe.kinematics`) and the sparse
linear algebra on PARDISO (:mod:`~fe_impact.fe.linalg`)."""
