"""Contact patch test: uniform pressure between two blocks with non-matching meshes.

Run ``python validation/patch_test.py --out out/patch_test`` (a few seconds;
``--quick`` is the same study: it is small). It writes ``patch_test.json``
and ``checks.json`` and exits 1 when a check fails.

Model: two blocks of the same square footprint ``W x W``, stacked, the upper
one ``gap`` above the lower, each meshed with its own element size, so their
facing surfaces do not match. Roller supports on the symmetry planes x = 0
and y = 0 (both blocks) and on the lower block's bottom; the upper block's
top is pushed down by ``D``. Both blocks are of one material, so they expand
sideways alike and no tangential slip arises: the exact solution is a uniform
uniaxial stress, and the contact pressure is uniform,

    p = E (D - gap) / (2 H + E / eps),

with ``H`` the height of each block and ``eps`` the penalty (Pa/m), whose
penetration ``p / eps`` is part of the exact solution of the penalty model.
A contact discretisation passes the patch test when every slave node carries
that pressure (Taylor and Papadopoulos 1991; Puso and Laursen 2004 for the
mortar form): the check is 0.1% at every node, for each mesh taken as the
slave, the coarse one and the fine one. 0.1% is well above the solver's own
error (the projection iteration's tolerance 1e-6 of the displacement, the
linear solve's round-off) and far below the +-3% a slave quadrature that is
not split at the master's edges gives on these meshes.
"""

from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    MaterialSpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.meshing.session import gmsh_session, write_msh
from fe_impact.output.files import write_json
from validation import checks as ck

logger = logging.getLogger(__name__)

E, NU, RHO = 212e9, 0.289, 7860.0
WIDTH = 1e-3        # footprint edge W, m
HEIGHT = 0.5e-3     # each block's height H, m
GAP = 1e-7          # initial gap, m
PUSH = 1e-6         # the upper top's downward displacement D, m
#: Element sizes (m) of the coarse and the fine block: 3 and 7 elements along
#: an edge, so that no edge of one mesh lines up with the other's.
COARSE, FINE = WIDTH / 3.0, WIDTH / 7.0
#: Every node's pressure within this of the exact one (see the module docstring).
PRESSURE_TOL = 1e-3


@dataclass(frozen=True)
class BlockSpec:
    """One block: footprint ``(x0, y0, width, depth)`` (m), height (m), element size (m)."""

    x0: float
    y0: float
    width: float
    depth: float
    height: float
    size: float


def build_blocks(path: str | Path, upper: BlockSpec, lower: BlockSpec, gap: float,
                 order: int = 1) -> Path:
    """Two blocks meshed independently, the upper ``gap`` above the lower (top at z = 0).

    Groups: volumes ``upper``, ``lower``; surfaces ``upper_bottom``,
    ``lower_top`` (the facing faces), ``upper_top``, ``lower_bottom``,
    ``sym_x`` and ``sym_y`` (the faces of both blocks on x = 0 and y = 0),
    ``upper_all`` (the upper block's boundary).
    """
    import gmsh

    with gmsh_session("blocks") as model:
        occ = model.occ
        lo = occ.addBox(lower.x0, lower.y0, -lower.height, lower.width, lower.depth,
                        lower.height)
        up = occ.addBox(upper.x0, upper.y0, gap, upper.width, upper.depth, upper.height)
        occ.synchronize()
        model.addPhysicalGroup(3, [up], name="upper")
        model.addPhysicalGroup(3, [lo], name="lower")
        groups: dict[str, list[int]] = {k: [] for k in ("upper_bottom", "upper_top",
                                                         "lower_top", "lower_bottom",
                                                         "sym_x", "sym_y", "upper_all")}
        for name, vol, z_top in (("upper", up, gap + upper.height), ("lower", lo, 0.0)):
            for _, t in model.getBoundary([(3, vol)], oriented=False):
                x0, y0, zb, x1, y1, zt = model.getBoundingBox(2, t)
                if name == "upper":
                    groups["upper_all"].append(t)
                tol = 1e-3 * min(upper.height, lower.height)
                if abs(zt - zb) < tol:
                    side = "top" if abs(zb - z_top) < tol else "bottom"
                    groups[f"{name}_{side}"].append(t)
                elif abs(x1 - x0) < tol and abs(x0) < tol:
                    groups["sym_x"].append(t)
                elif abs(y1 - y0) < tol and abs(y0) < tol:
                    groups["sym_y"].append(t)
        for name, tags in groups.items():
            if tags:
                model.addPhysicalGroup(2, tags, name=name)
        for vol, spec in ((up, upper), (lo, lower)):
            points = model.getBoundary([(3, vol)], combined=False, oriented=False,
                                       recursive=True)
            model.mesh.setSize([p for p in points if p[0] == 0], spec.size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", min(upper.size, lower.size))
        gmsh.option.setNumber("Mesh.MeshSizeMax", max(upper.size, lower.size))
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
        gmsh.option.setNumber("General.NumThreads", 1)
        model.mesh.generate(3)
        if order == 2:
            model.mesh.setOrder(2)
        return write_msh(path)


def patch_case(mesh_file: Path, slave: str, penalty: float,
               push: float = PUSH) -> Case:
    """The patch test's static case, ``slave`` ``"upper"`` or ``"lower"``."""
    pair = ("upper_bottom", "lower_top") if slave == "upper" else ("lower_top", "upper_bottom")
    return Case(path=Path(mesh_file).with_suffix(".case"), mesh_file=Path(mesh_file),
                unit="m", materials=(MaterialSpec(("upper", "lower"), E, NU, RHO),),
                contacts=(ContactSpec(*pair, penalty=penalty),),
                supports=(SupportSpec("lower_bottom", (2,)), SupportSpec("sym_x", (0,)),
                          SupportSpec("sym_y", (1,))),
                displacements=(DisplacementSpec("upper_top", 2, (-push,)),),
                analysis=AnalysisSpec(tolerance=1e-9))


def exact_pressure(penalty: float, push: float = PUSH, gap: float = GAP) -> float:
    """Uniform contact pressure of the penalty model (Pa): see the module docstring."""
    return E * (push - gap) / (2.0 * HEIGHT + E / penalty)


@dataclass(frozen=True)
class PatchResult:
    """One run: which block is the slave and the slave nodes' pressure errors."""

    coarse: str              # "upper" or "lower": the block with the coarse mesh
    slave: str               # "upper" or "lower"
    n_nodes: int             # slave nodes on the contact face
    exact: float             # Pa
    max_error: float         # largest |p / exact - 1| over the slave's nodes
    force_error: float       # total force against exact * W^2


def run_one(folder: Path, coarse: str, slave: str, order: int = 1,
            penalty_factor: float = 100.0) -> PatchResult:
    """Mesh (once per folder and layout) and solve one patch test."""
    from fe_impact.solvers.static import StaticSolver

    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"blocks_{coarse}_coarse_p{order}.msh"
    sizes = {"upper": COARSE, "lower": FINE} if coarse == "upper" else \
        {"upper": FINE, "lower": COARSE}
    if not path.exists():
        build_blocks(path, BlockSpec(0.0, 0.0, WIDTH, WIDTH, HEIGHT, sizes["upper"]),
                     BlockSpec(0.0, 0.0, WIDTH, WIDTH, HEIGHT, sizes["lower"]), GAP, order)
    mesh = load_mesh(path, "m")
    # a penalty as stiff as the blocks' own compliance over a fine element
    penalty = penalty_factor * E / FINE
    case = patch_case(path, slave, penalty)
    step = StaticSolver(case, mesh).run().steps[0]
    face = mesh.surface("upper_bottom" if slave == "upper" else "lower_top")
    nodes = np.unique(face[:, :3])
    p = step.pressure[nodes]
    exact = exact_pressure(penalty)
    return PatchResult(coarse, slave, len(nodes), exact,
                       float(np.abs(p / exact - 1.0).max()),
                       float(step.contact_force[0] / (exact * WIDTH ** 2) - 1.0))


def run(quick: bool = False, out: Path | None = None, order: int = 1) -> list[PatchResult]:
    """The four patch tests: each block coarse in turn, each taken as the slave
    (``quick``: the same, the study is small)."""
    folder = Path(out) if out is not None else Path("out/patch_test")
    return [run_one(folder, coarse, slave, order)
            for coarse in ("upper", "lower") for slave in ("upper", "lower")]


def check(results: list[PatchResult]) -> list[ck.Check]:
    """Every slave node's pressure within :data:`PRESSURE_TOL` of the exact one."""
    return [ck.at_most(f"{r.coarse} coarse, {r.slave} slave: largest nodal pressure error",
                       r.max_error, PRESSURE_TOL) for r in results]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/patch_test"))
    ap.add_argument("--quick", action="store_true", help="the same study (it is small)")
    ap.add_argument("--order", type=int, default=1, choices=(1, 2))
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    results = run(args.quick, args.out, args.order)
    for r in results:
        print(f"{r.coarse} coarse, {r.slave} slave: {r.n_nodes} nodes, exact {r.exact:.6g} Pa,"
              f" largest nodal error {r.max_error:.3e}, force error {r.force_error:+.2e}")
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "patch_test.json", {"results": [r.__dict__ for r in results]})
    return ck.finish("patch_test", check(results), args.out)


if __name__ == "__main__":
    sys.exit(main())
