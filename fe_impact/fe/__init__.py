"""Finite-element model: mesh loading, the case description, elasticity, J2
plasticity and the sparse linear algebra (PARDISO)."""
