"""The torsional model's view of the gear set: :mod:`fe_impact.gears.kinematics`.

The line of action, the corner gaps and the switching speeds depend on the gear
set alone and are needed upstream of the lumped model (the calibration's plan,
the geometry report), so they live in :mod:`fe_impact.gears.kinematics`; this
module gives the switching model its names from there.
"""

from fe_impact.gears.kinematics import (
    CORNER_SOURCES,
    CornerGap,
    MeshGeometry,
    default_backlash,
    mesh_geometry,
    seed_switching_speed,
    solid_corner_gaps,
    switching_speed,
)

__all__ = [
    "CORNER_SOURCES",
    "CornerGap",
    "MeshGeometry",
    "default_backlash",
    "mesh_geometry",
    "seed_switching_speed",
    "solid_corner_gaps",
    "switching_speed",
]
