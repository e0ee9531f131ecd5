"""Two contact pairs: each carries the load that equilibrium gives it.

The bridge (meshes/bridge.msh): a beam pressed down on two columns of
different heights, one contact pair per column. The columns' bottoms and the
beam's top are held in x and y and given their z displacement (0 for the
columns, pressed down for the beam), so every reaction is reported.
Each column is in equilibrium between its support and its contact: its
support reaction balances its pair's contact force, and the beam's reaction
the sum of both, whatever the discretisation.
"""

from __future__ import annotations

import numpy as np
import pytest

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    MaterialSpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.static import StaticSolver
from meshes.generate import committed

PRESS = (-2e-6, -4e-6)   # beam top, m


@pytest.fixture(scope="module")
def bridge():
    path = committed("bridge.msh")
    case = Case(
        path=path.with_suffix(".case"), mesh_file=path, unit="m",
        materials=(MaterialSpec(("left", "right", "top"), 212e9, 0.289, 7860.0),),
        contacts=(ContactSpec("left_top", "top_bottom"), ContactSpec("right_top", "top_bottom")),
        supports=tuple(SupportSpec(s, (0, 1)) for s in ("left_bottom", "right_bottom", "top_top")),
        displacements=(DisplacementSpec("top_top", 2, PRESS),
                       DisplacementSpec("left_bottom", 2, (0.0, 0.0)),
                       DisplacementSpec("right_bottom", 2, (0.0, 0.0))),
        analysis=AnalysisSpec(type="static"))
    return StaticSolver(case, load_mesh(path)).run()


def _largest_tilt(mesh, u: np.ndarray) -> float:
    """Largest angle (rad) between z and the deformed normal of a beam-bottom face."""
    faces = mesh.surface("top_bottom")[:, :3]
    x = mesh.points + u
    n = np.cross(x[faces[:, 1]] - x[faces[:, 0]], x[faces[:, 2]] - x[faces[:, 0]])
    cos = np.abs(n[:, 2]) / np.linalg.norm(n, axis=1)
    return float(np.arccos(np.clip(cos, -1.0, 1.0)).max())


def test_each_pair_carries_its_columns_reaction(bridge):
    """Each contact force acts along the beam bottom's deformed normal, which tilts by
    theta as the beam bends: the z reaction of a column is its pair's force times a
    weighted mean of cos(theta), between F (1 - theta_max^2 / 2) and F, and the beam's
    is minus the sum. The displacement is recovered from the contact forces by one
    solve, so beyond that the balance holds to the rounding of K u (1e-12 of F)."""
    for step in bridge.steps:
        left, right = step.contact_force
        beam, left_support, right_support = step.reaction_force
        assert left > 0.0 and right > 0.0
        slack = 0.5 * _largest_tilt(bridge.mesh, step.u) ** 2 + 1e-12
        for force, reaction in ((left, left_support), (right, right_support),
                                (left + right, -beam)):
            assert force * (1.0 - slack) <= reaction <= force * (1.0 + 1e-12)
        assert -beam == pytest.approx(left_support + right_support, rel=1e-12)


def test_the_stiffer_column_carries_more(bridge):
    # Columns of the same section, 1 mm and 1.5 mm tall: the shorter one is stiffer
    # (1.5 times for the columns alone), and both forces grow with the pressing.
    first, second = bridge.steps
    for step in bridge.steps:
        assert step.contact_force[0] > step.contact_force[1]
    assert np.all(np.array(second.contact_force) > np.array(first.contact_force))
