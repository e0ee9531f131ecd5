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


def test_set_nodes_moves_nodes_as_gmsh_set_node_does():
    # session.set_nodes calls gmsh's C entry point row by row; the nodes must
    # read back exactly where they were put, and a bad tag is a MeshError.
    import gmsh
    import numpy as np

    from fe_impact.errors import MeshError
    from fe_impact.meshing.session import gmsh_session, set_nodes

    with gmsh_session("set_nodes") as model:
        model.occ.addBox(0, 0, 0, 1, 1, 1)
        model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        model.mesh.generate(3)
        tags, coords, _ = model.mesh.getNodes()
        moved = coords.reshape(-1, 3) * 2.0 + np.array([0.1, -0.2, 0.3])
        set_nodes(tags, moved)
        tags2, coords2, _ = model.mesh.getNodes()
        order = np.argsort(tags2)
        np.testing.assert_array_equal(tags2[order], np.sort(tags))
        np.testing.assert_array_equal(coords2.reshape(-1, 3)[order],
                                      moved[np.argsort(tags)])
        with pytest.raises(MeshError, match="could not move node"):
            set_nodes([int(tags.max()) + 1000], [[0.0, 0.0, 0.0]])
