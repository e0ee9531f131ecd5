"""The CalculiX peer check's deck (``validation/calculix_pair.py``): faces, fields, output.

Running CalculiX itself takes minutes and a Debian package, so the study is
not run here; these check what it relies on, on the committed coarse Hertz
mesh (P2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fe_impact.fe.mesh import load_mesh
from validation import calculix_pair as cp

MESH = Path(__file__).resolve().parents[1] / "meshes" / "hertz_coarse.msh"
#: VTK / C3D10 order: the mid-side node of each tetrahedron edge (corner pairs).
TET_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))


@pytest.fixture(scope="module")
def mesh():
    return load_mesh(MESH, "mm")


def test_each_surface_triangle_is_the_named_face_of_its_element(mesh):
    """The face S1-S4 given for a triangle has the triangle's three corners and its
    three mid-side nodes: CalculiX then integrates the contact on the same six
    nodes fe-impact does."""
    for group in ("sphere_contact", "block_contact"):
        tris = mesh.surface(group)
        faces, = cp.element_faces(mesh.cells, tris)
        assert len(faces) == len(tris)
        for tri, (e, f) in zip(tris, faces, strict=True):
            cell = mesh.cells[e]
            corners = cp.C3D10_FACES[f - 1]
            assert sorted(cell[list(corners)]) == sorted(tri[:3])
            mid = {frozenset(cell[[a, b]]): cell[4 + k] for k, (a, b) in enumerate(TET_EDGES)}
            for k, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
                assert mid[frozenset(tri[[a, b]])] == tri[3 + k]


def test_a_triangle_of_no_element_is_refused(mesh):
    cell = mesh.cells[0]
    other = next(n for n in mesh.cells[1:, 0] if n not in cell)
    tri = np.array([[cell[0], cell[1], other, cell[4], 0, 0]])
    with pytest.raises(ValueError, match="face of no element"):
        cp.element_faces(mesh.cells[:1], mesh.cells[:1, [0, 1, 2, 4, 5, 6]], tri)


def test_node_lines_fit_calculix_fields(tmp_path, mesh):
    """CalculiX reads at most 20 characters a field (its first failure here was a
    coordinate printed with 17 digits)."""
    path = tmp_path / "m.inp"
    cp.write_mesh(path, mesh)
    lines = path.read_text().splitlines()
    start = lines.index("*NODE") + 1
    fields = [f.strip() for line in lines[start:start + 200] for f in line.split(",")]
    assert max(len(f) for f in fields) <= 20
    assert "*ELEMENT, TYPE=C3D10, ELSET=EALL" in lines


def test_reactions_keep_the_last_increment_of_each_time(tmp_path):
    dat = tmp_path / "pair.dat"
    dat.write_text(
        "\n forces (fx,fy,fz) for set PHUB and time  0.1000000E+01\n\n"
        "        33  1.0E+00  0.0E+00  0.0E+00\n        34  2.0E+00  0.0E+00  0.0E+00\n\n"
        " forces (fx,fy,fz) for set PHUB and time  0.2000000E+01\n\n"
        "        33  5.0E+00  0.0E+00  0.0E+00\n\n"
        " forces (fx,fy,fz) for set PHUB and time  0.2000000E+01\n\n"
        "        33  7.0E+00  0.0E+00  1.0E+00\n")
    blocks = cp.read_reactions(dat)
    assert sorted(blocks) == [1.0, 2.0]
    assert sorted(blocks[1.0]) == [33, 34]
    np.testing.assert_array_equal(blocks[2.0][33], [7.0, 0.0, 1.0])


def test_torque_about_an_axis():
    """Two opposite unit forces 2 mm apart about z: 2 N mm = 0.002 N m."""
    x = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    forces = {1: np.array([0.0, 1.0, 0.0]), 2: np.array([0.0, -1.0, 0.0])}
    assert cp.torque(forces, x, np.array([0.0, 0.0, 1.0]), np.zeros(3)) == pytest.approx(2e-3)
