"""Recipes of the small committed meshes in this folder, and the builders they need.

Run ``python meshes/generate.py`` to write every mesh again (a few seconds),
``python meshes/generate.py NAME ...`` for some of them, ``--out FOLDER`` to
write elsewhere. Each recipe is a builder and its parameters; README.md lists
them. ``tests/test_meshes.py`` regenerates each one and compares it with the
committed file (node and element counts, physical groups).

The sphere-on-block and two-block specimens come from
:mod:`validation.specimens`. The spring column and the bridge are defined
here: they exist for the tests.

Spring column (``build_spring_column``): a cube of edge ``size`` (volume
``column``) with its bottom face ``column_bottom`` at z = -size and its top
face ``column_top`` at z = 0, and above it, ``gap`` away, a second cube
(``stop``; faces ``stop_all`` and ``stop_bottom``) that gives the case the
contact pair the transient solver requires. Meshed transfinite with two
nodes per edge, linear tetrahedra: the only nodes are the cube corners.
Fixing ``column_bottom`` and tying ``column_top`` to a rigid body moving
along z leaves one degree of freedom, and the displacement field is exactly
linear (uniaxial strain): the column is a linear spring of stiffness
``(lambda + 2 mu) size`` carrying the consistent mass ``rho size^3 / 3``.

Bridge (``build_bridge``): two columns on the floor, ``left`` (1 x 1 x 1 mm)
and ``right`` (1 x 1 x 1.5 mm, its top level with the left one's), and a
beam ``top`` (2.5 x 1 x 0.5 mm) resting on both, ``gap`` above them: two
contact pairs (``left_top`` and ``right_top`` against ``top_bottom``).
Faces ``left_bottom``, ``right_bottom``, ``top_top``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.meshing.session import gmsh_session, write_msh  # noqa: E402

HERE = Path(__file__).resolve().parent


def _faces_at(model, volume: int, axis: int, value: float, tol: float) -> list[int]:
    """Boundary faces of ``volume`` lying in the plane ``x[axis] = value``."""
    out = []
    for _, tag in model.getBoundary([(3, volume)], oriented=False):
        box = model.getBoundingBox(2, tag)
        if abs(box[axis] - value) < tol and abs(box[axis + 3] - value) < tol:
            out.append(tag)
    return out


def build_spring_column(path: str | Path, size: float = 1e-3, gap: float = 1e-4) -> Path:
    """Write the spring-column specimen (see the module docstring) as MSH 4.1."""
    with gmsh_session("spring_column") as model:
        occ = model.occ
        column = occ.addBox(0, 0, -size, size, size, size)
        stop = occ.addBox(0, 0, gap, size, size, size)
        occ.synchronize()
        tol = 1e-3 * size
        model.addPhysicalGroup(3, [column], name="column")
        model.addPhysicalGroup(3, [stop], name="stop")
        model.addPhysicalGroup(2, _faces_at(model, column, 2, 0.0, tol), name="column_top")
        model.addPhysicalGroup(2, _faces_at(model, column, 2, -size, tol), name="column_bottom")
        model.addPhysicalGroup(2, [t for _, t in model.getBoundary([(3, stop)], oriented=False)],
                               name="stop_all")
        model.addPhysicalGroup(2, _faces_at(model, stop, 2, gap, tol), name="stop_bottom")
        # transfinite with two nodes per edge: each cube is cut into tetrahedra between its
        # eight corners only (an unstructured mesh adds nodes at the face centres)
        for _, tag in model.getEntities(1):
            model.mesh.setTransfiniteCurve(tag, 2)
        for _, tag in model.getEntities(2):
            model.mesh.setTransfiniteSurface(tag)
        for _, tag in model.getEntities(3):
            model.mesh.setTransfiniteVolume(tag)
        model.mesh.generate(3)
        return write_msh(path)


def build_bridge(path: str | Path, size: float = 0.25e-3, gap: float = 1e-7) -> Path:
    """Write the bridge specimen (see the module docstring) as MSH 4.1, linear tetrahedra."""
    import gmsh

    mm = 1e-3
    with gmsh_session("bridge") as model:
        occ = model.occ
        left = occ.addBox(0, 0, -1 * mm, 1 * mm, 1 * mm, 1 * mm)
        right = occ.addBox(1.5 * mm, 0, -1.5 * mm, 1 * mm, 1 * mm, 1.5 * mm)
        top = occ.addBox(0, 0, gap, 2.5 * mm, 1 * mm, 0.5 * mm)
        occ.synchronize()
        tol = 1e-3 * mm
        for name, vol, bottom, upper in (("left", left, -1 * mm, 0.0),
                                         ("right", right, -1.5 * mm, 0.0),
                                         ("top", top, gap, gap + 0.5 * mm)):
            model.addPhysicalGroup(3, [vol], name=name)
            model.addPhysicalGroup(2, _faces_at(model, vol, 2, bottom, tol),
                                   name=f"{name}_bottom")
            model.addPhysicalGroup(2, _faces_at(model, vol, 2, upper, tol), name=f"{name}_top")
        gmsh.option.setNumber("Mesh.MeshSizeMin", size)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        model.mesh.generate(3)
        return write_msh(path)


def _hertz_specimen(path: Path, h_contact: float, order: int) -> Path:
    # the static Hertz study's specimen (validation/hertz_static.py, specimen_mesh)
    from validation.specimens import SphereBlockSpec, build_sphere_block

    spec = SphereBlockSpec(radius=10e-3, h_contact=h_contact, r_fine=0.8e-3, order=order)
    return build_sphere_block(spec, path)


def _two_blocks(path: Path, size: float, gap: float) -> Path:
    from validation.specimens import build_two_blocks

    return build_two_blocks(path, size=size, gap=gap)


@dataclass(frozen=True)
class Recipe:
    """How one committed mesh is made: ``builder(path, **parameters)``."""

    builder: Callable[..., Path]
    parameters: dict = field(default_factory=dict)

    def build(self, path: Path) -> Path:
        return self.builder(Path(path), **self.parameters)


#: Committed mesh file name -> recipe (README.md describes each).
RECIPES: dict[str, Recipe] = {
    "hertz_coarse.msh": Recipe(_hertz_specimen, {"h_contact": 0.2e-3, "order": 2}),
    "hertz_coarse_p1.msh": Recipe(_hertz_specimen, {"h_contact": 0.2e-3, "order": 1}),
    "hertz_medium.msh": Recipe(_hertz_specimen, {"h_contact": 0.1e-3, "order": 2}),
    "two_blocks.msh": Recipe(_two_blocks, {"size": 1e-3, "gap": 1e-8}),
    "spring_column.msh": Recipe(build_spring_column, {"size": 1e-3, "gap": 1e-4}),
    "bridge.msh": Recipe(build_bridge, {"size": 0.25e-3, "gap": 1e-7}),
}


def committed(name: str) -> Path:
    """Path of a committed mesh; a clear error if the file or the recipe is missing."""
    if name not in RECIPES:
        raise KeyError(f"no mesh recipe {name!r}; pick one of {sorted(RECIPES)}")
    path = HERE / name
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: run python meshes/generate.py {name}")
    return path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("names", nargs="*", help=f"meshes to write (default all: {sorted(RECIPES)})")
    p.add_argument("--out", type=Path, default=HERE, help="folder (default: meshes/)")
    args = p.parse_args(argv)
    for name in args.names or sorted(RECIPES):
        if name not in RECIPES:
            p.error(f"unknown mesh {name!r}; pick from {sorted(RECIPES)}")
        path = RECIPES[name].build(args.out / name)
        print(f"wrote {path} ({path.stat().st_size / 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
