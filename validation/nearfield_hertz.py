"""Near field on a coarse mesh: Hertz sphere on block against Hertz and the refined FE.

Run ``python validation/nearfield_hertz.py --out out/nearfield_hertz`` (about
half a minute: the coarse near-field model and, in the same run, the refined
FE on ``meshes/hertz_medium.msh`` as the baseline); writes
``nearfield_hertz.json`` and ``nearfield_hertz.md`` and exits 1 when a check
fails.

Model: the static Hertz study's specimen (quarter hemisphere R = 10 mm on a
20 x 20 x 10 mm block, 20CrMnTi, block bottom held, equator pushed down
5 ... 25 um), meshed with :data:`H_CONTACT` = 0.5 mm at the contact: five
times coarser than ``hertz_medium`` (0.1 mm). The contact is solved on a
64 x 64 grid over 1.3 sqrt(R D) by the combined model of
:mod:`fe_impact.contact.nearfield_fe`: half-space layer down to
:data:`DEPTH`, the coarse FE below it.

Checks (tolerances set before the results were seen, from issue 47):

- force at the prescribed displacement within 1% of the refined FE
  (``hertz_medium``, today's static solver);
- force within 1% of Hertz's for the local approach between the axis
  points at :data:`DEPTH` (the Hertz study's measure: Hertz plus the
  half-space's axial displacement at that depth, ``hertz.axial_displacement``);
- peak pressure p0 and contact radius within 2% of Hertz at the model's force.

The refined FE's own p0 and contact radius are reported beside it: its
contact radius is resolved only to half an element (50 um, 10-22% of a) and
its largest nodal pressure to 1-10% (see ``validation/hertz_static.py``), so
they are compared, not held to 2%.
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.contact import nearfield as nf
from fe_impact.contact import nearfield_fe as nff
from fe_impact.fe.elasticity import build_model
from fe_impact.fe.linalg import SPDSolver
from fe_impact.fe.mesh import load_mesh
from fe_impact.physics import hertz
from fe_impact.solvers.model import Prescribed
from validation import checks as ck
from validation.impact_cases import NU, E, R, sphere_block_case
from validation.specimens import SphereBlockSpec, build_sphere_block

logger = logging.getLogger(__name__)

DISPLACEMENTS = (5e-6, 1e-5, 1.5e-5, 2e-5, 2.5e-5)
#: Coarse element size at the contact (m): 5 x hertz_medium's 0.1 mm.
H_CONTACT = 0.5e-3
#: Matching depth (m): 4 coarse elements, R / 5 (see nearfield_fe).
DEPTH = 2.0e-3
#: Grid: cells per side and half-width per sqrt(R D) (the Hertz radius of
#: the prescribed displacement, which bounds the patch from above here).
CELLS = 64
GRID_SPAN = 1.3
REFINED_MESH = Path(__file__).resolve().parents[1] / "meshes" / "hertz_medium.msh"
FORCE_TOLERANCE = 0.01     # issue 47: force and approach within 1%
SHAPE_TOLERANCE = 0.02     # issue 47: p0 and contact radius within 2%


@dataclass(frozen=True)
class Step:
    displacement: float
    force: float
    p0: float
    radius: float
    local_approach: float
    hertz_local_force: float
    iterations: int


def coarse_mesh(folder: Path, h_contact: float = H_CONTACT) -> Path:
    """The specimen meshed with ``h_contact`` at the contact (cached in ``folder``)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"sphere_block_{h_contact * 1e3:g}mm.msh"
    if not path.exists():
        build_sphere_block(SphereBlockSpec(radius=R, h_contact=h_contact, r_fine=0.8e-3,
                                           order=2), path)
    return path


def sides() -> tuple[nff.Side, nff.Side]:
    """Sphere above (its surface at R - sqrt(R^2 - r^2)), block below (z = 0)."""
    def cap(x, y):
        return R - np.sqrt(R ** 2 - x ** 2 - y ** 2)
    return (nff.Side("sphere", E, NU, cap, +1.0),
            nff.Side("block", E, NU, lambda x, y: np.zeros_like(x), -1.0))


def near_field_model(mesh_file: Path):
    """Factorise the coarse FE with the equator and the block bottom held."""
    mesh = load_mesh(mesh_file)
    case = sphere_block_case(mesh_file, (0.0,))
    model = build_model(mesh, case.materials)
    dofs = Prescribed.build(case, mesh, model.n_dofs)
    K = model.K[dofs.free][:, dofs.free].tocsr()
    solver = SPDSolver(K)
    far = nff.FarField(mesh, dofs.free, solver.solve, sides(), fold=True)
    return far, model.n_dofs


def solve_step(far: nff.FarField, d: float, guess: float) -> tuple[Step, nf.Grid]:
    """One prescribed displacement ``d`` (m) on its own grid."""
    half = GRID_SPAN * np.sqrt(R * d)
    grid = nf.Grid.centred(half, half, CELLS, CELLS)
    nff.check_grid(grid, np.sqrt(R * d) / GRID_SPAN)
    nff.check_half_space(np.sqrt(R * d), R, DEPTH, H_CONTACT)
    X, Y = grid.centres()
    sep = R - np.sqrt(R ** 2 - X ** 2 - Y ** 2)
    near = nf.Convolution(grid, far.near_kernel(grid, DEPTH)).apply
    farop = far.operator(grid, DEPTH)
    sol = nff.solve_combined_approach(sep, near, farop, d, grid.cell_area, guess)
    # local approach between the axis points at DEPTH: the prescribed
    # displacement less the coarse FE's displacement of those points, which
    # is the far field at the grid's centre
    centre = farop(sol.pressure)
    mid = slice(CELLS // 2 - 1, CELLS // 2 + 1)
    local = d - float(np.mean(centre[mid, mid]))
    e_star = hertz.effective_modulus(E, NU)

    def local_hertz(f: float) -> float:
        c = hertz.sphere_contact(f, R, e_star)
        return float(c.a ** 2 / R - 2 * hertz.axial_displacement(DEPTH, c.a, c.p0, E, NU))
    f_h = brentq(lambda f: local_hertz(f) - local, 1e-3 * sol.force, 1e3 * sol.force,
                 xtol=1e-12)
    return Step(d, sol.force, float(sol.pressure.max()), sol.contact_radius(grid), local,
                f_h, sol.iterations), grid


def refined_fe() -> dict:
    """Today's static solver on hertz_medium: force, p0, radius per displacement."""
    from fe_impact.solvers.static import StaticSolver

    t = time.perf_counter()
    mesh = load_mesh(REFINED_MESH)
    solver = StaticSolver(sphere_block_case(REFINED_MESH, tuple(-d for d in DISPLACEMENTS)),
                          mesh, stress=False)
    res = solver.run()
    rows = [{"force": 4.0 * s.contact_force[0], "p0": s.max_pressure,
             "radius": float(np.sqrt(4.0 * s.contact_area[0] / np.pi))} for s in res.steps]
    return {"seconds": time.perf_counter() - t, "n_dofs": res.info["n_dofs"], "rows": rows}


def run(out: str | Path = "out/nearfield_hertz", baseline: bool = True) -> dict:
    """Solve the coarse near-field model (and the refined FE); returns the results."""
    out = Path(out)
    mesh_file = coarse_mesh(out)
    t = time.perf_counter()
    far, n_dofs = near_field_model(mesh_file)
    t_setup = time.perf_counter() - t
    steps, guess = [], 100.0
    for d in DISPLACEMENTS:
        step, grid = solve_step(far, d, guess)
        steps.append(step)
        guess = step.force
    t_nf = time.perf_counter() - t
    rss_nf = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    result = {"coarse_mesh": str(mesh_file), "n_dofs": n_dofs, "far_solves": far.solves,
              "seconds": t_nf, "setup_seconds": t_setup, "peak_rss_MB_after_near_field": rss_nf,
              "grid_cells": CELLS * CELLS, "depth_m": DEPTH, "h_contact_m": H_CONTACT,
              "steps": [vars(s) for s in steps]}
    if baseline:
        result["refined"] = refined_fe()
    out.mkdir(parents=True, exist_ok=True)
    (out / "nearfield_hertz.json").write_text(json.dumps(result, indent=1))
    return result


def check(result: dict) -> list[ck.Check]:
    e_star = hertz.effective_modulus(E, NU)
    out = []
    errs = {"hertz_force": [], "p0": [], "radius": [], "refined_force": []}
    for i, s in enumerate(result["steps"]):
        c = hertz.sphere_contact(s["force"], R, e_star)
        errs["hertz_force"].append(s["force"] / s["hertz_local_force"] - 1)
        errs["p0"].append(s["p0"] / c.p0 - 1)
        errs["radius"].append(s["radius"] / c.a - 1)
        if "refined" in result:
            errs["refined_force"].append(s["force"] / result["refined"]["rows"][i]["force"] - 1)
    out.append(ck.at_most("force vs Hertz (local approach at depth)",
                          max(map(abs, errs["hertz_force"])), FORCE_TOLERANCE))
    out.append(ck.at_most("p0 vs Hertz", max(map(abs, errs["p0"])), SHAPE_TOLERANCE))
    out.append(ck.at_most("contact radius vs Hertz", max(map(abs, errs["radius"])),
                          SHAPE_TOLERANCE))
    if errs["refined_force"]:
        out.append(ck.at_most("force vs refined FE (hertz_medium) at equal displacement",
                              max(map(abs, errs["refined_force"])), FORCE_TOLERANCE))
    return out


def report(result: dict) -> str:
    e_star = hertz.effective_modulus(E, NU)
    lines = ["# Near field on a coarse mesh: sphere on block", "",
             f"Coarse FE: {result['n_dofs']} DOFs (h = {result['h_contact_m'] * 1e3:g} mm at "
             f"the contact), {result['far_solves']} far-field solves, grid "
             f"{CELLS} x {CELLS}, matching depth {result['depth_m'] * 1e3:g} mm; "
             f"{result['seconds']:.1f} s for the five displacements (set-up "
             f"{result['setup_seconds']:.1f} s)."]
    ref = result.get("refined")
    if ref:
        lines.append(f"Refined FE (hertz_medium): {ref['n_dofs']} DOFs, {ref['seconds']:.1f} s.")
    lines += ["", "| D (um) | force (N) | vs refined FE | vs Hertz (local) | p0 vs Hertz "
              "| a vs Hertz | refined p0 / a vs Hertz |", "|---|---|---|---|---|---|---|"]
    for i, s in enumerate(result["steps"]):
        c = hertz.sphere_contact(s["force"], R, e_star)
        rf = ""
        vs = ""
        if ref:
            r = ref["rows"][i]
            cr = hertz.sphere_contact(r["force"], R, e_star)
            vs = f"{s['force'] / r['force'] - 1:+.2%}"
            rf = f"{r['p0'] / cr.p0 - 1:+.1%} / {r['radius'] / cr.a - 1:+.1%}"
        lines.append(f"| {s['displacement'] * 1e6:g} | {s['force']:.2f} | {vs} "
                     f"| {s['force'] / s['hertz_local_force'] - 1:+.2%} "
                     f"| {s['p0'] / c.p0 - 1:+.2%} | {s['radius'] / c.a - 1:+.2%} | {rf} |")
    lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/nearfield_hertz"))
    p.add_argument("--no-baseline", action="store_true",
                   help="skip the refined FE (its check is then left out)")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("skfem").setLevel(logging.WARNING)
    result = run(args.out, baseline=not args.no_baseline)
    checks = check(result)
    text = report(result) + "\n## Checks\n\n" + ck.markdown(checks)
    (args.out / "nearfield_hertz.md").write_text(text)
    print(text)
    return ck.finish("nearfield_hertz", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
