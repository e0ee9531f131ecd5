"""Gmsh meshes: the gmsh session helper and the tooth-pair mesh builder
(:mod:`~fe_impact.meshing.toothpair`), downstream of the gear geometry."""
