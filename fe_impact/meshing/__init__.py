"""Gmsh meshes, downstream of the gear geometry: the gmsh session helper
(:mod:`~fe_impact.meshing.session`) and the tooth-pair mesh builder
(:mod:`~fe_impact.meshing.toothpair`, which meshes with
:mod:`~fe_impact.meshing.pairgeometry`, :mod:`~fe_impact.meshing.sizing` and
:mod:`~fe_impact.meshing.contactstretch` and sets up the impact case with
:mod:`~fe_impact.meshing.paircase`)."""
