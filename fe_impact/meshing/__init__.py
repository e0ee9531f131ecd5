"""Gmsh meshes, downstream of the gear geometry: the gmsh session helper
(:mod:`~fe_impact.meshing.session`), the tooth-pair mesh builders
(:mod:`~fe_impact.meshing.toothpair`, one pair; :mod:`~fe_impact.meshing.twopair`,
two), which mesh with :mod:`~fe_impact.meshing.pairgeometry`,
:mod:`~fe_impact.meshing.sizing`, :mod:`~fe_impact.meshing.contactstretch` and
:mod:`~fe_impact.meshing.stretchmesh`, reuse what :mod:`~fe_impact.meshing.cache`
and :mod:`~fe_impact.meshing.solids` keep, and set up the impact case with
:mod:`~fe_impact.meshing.paircase`."""
