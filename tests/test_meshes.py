"""The committed meshes in meshes/ are what their recipes make, and stay small."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from fe_impact.fe.mesh import load_mesh
from meshes.generate import RECIPES, committed


def _signature(path) -> dict:
    """Node count, element counts by type, element counts by physical group, bounding box."""
    m = meshio.read(path, file_format="gmsh")
    groups = {name: {t: len(idx) for t, idx in blocks.items() if len(idx)}
              for name, blocks in m.cell_sets_dict.items() if not name.startswith("gmsh:")}
    return {"points": len(m.points),
            "cells": {t: len(c) for t, c in m.cells_dict.items()},
            "groups": groups,
            "box": np.concatenate([m.points.min(axis=0), m.points.max(axis=0)])}


@pytest.mark.parametrize("name", sorted(RECIPES))
def test_committed_mesh_is_what_its_recipe_makes(tmp_path, name):
    path = committed(name)
    assert path.read_text().startswith("$MeshFormat\n4.1 ")
    assert path.stat().st_size < 2e6
    ours, again = _signature(path), _signature(RECIPES[name].build(tmp_path / name))
    assert again["points"] == ours["points"]
    assert again["cells"] == ours["cells"]
    assert again["groups"] == ours["groups"]
    # the same geometry: coordinates are written with 16 digits
    np.testing.assert_allclose(again["box"], ours["box"], rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", sorted(RECIPES))
def test_committed_mesh_loads_with_its_groups(name):
    mesh = load_mesh(committed(name))
    assert mesh.volumes and mesh.surfaces
    assert (mesh.point_dof[np.unique(mesh.cells)] >= 0).all()


def test_spring_column_has_its_corners_only():
    # tests/test_integrators.py relies on it: every node on the top or bottom face
    mesh = load_mesh(committed("spring_column.msh"))
    column = np.unique(mesh.cells[mesh.volume("column")])
    assert len(column) == 8
    on_faces = np.union1d(mesh.surface_points("column_top"), mesh.surface_points("column_bottom"))
    assert np.array_equal(column, on_faces)
