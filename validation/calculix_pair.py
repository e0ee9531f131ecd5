"""The static tooth pair against CalculiX on the same mesh.

Run ``python validation/calculix_pair.py --out out/calculix_pair`` (needs
CalculiX's ``ccx`` on the path, Debian package ``calculix-ccx``; 16 minutes
on two cores, nearly all of it CalculiX: 423 and 552 s for the two
meshes). ``--quick``: 200 and 1000 N on the first mesh alone (about five
minutes).

The case is a mesh-cycle position: stage 1 of the built-in gear set at the
pitch point, coarse P2 mesh (``fe_impact.meshing.toothpair.build_pair``,
the mesh a calibration solves), the face-gear hub held and the pinion hub
turned as a rigid body about the pinion's axis. fe-impact first solves it
under torque, for contact normal forces of 50, 200, 500 and 1000 N
(:func:`fe_impact.meshing.paircase.static_case`, as the mesh cycle does);
the hub rotations it finds are then prescribed to CalculiX 2.20 on the same
nodes and elements (C3D10, a linear-elastic steel, no geometric
nonlinearity), as the small-rotation field ``theta e x (x - p)`` of the hub
nodes, which is exactly how fe-impact ties a hub to its rigid body. The
contact is frictionless penalty contact in both: CalculiX's
surface-to-surface contact (``*CONTACT PAIR, TYPE=SURFACE TO SURFACE``,
pinion flank slave) with a linear pressure-overclosure of the same slope
as fe-impact's automatic penalty. CalculiX's reaction torque on the hub
nodes is compared with the torque fe-impact carried at that rotation.

Two series: the four loads on the mesh made for 1000 N (the mesh cycle
meshes each position for its largest load), and 50 N on a mesh made for
50 N.

Tolerance (set before the first comparison was run): **2%** in torque.
Both codes solve the same linear elasticity on the same mesh, so their
stiffness matrices agree to round-off and the teeth's bending is the same
in both; they differ in how the penalty contact is discretised on the flank
faces (fe-impact: weighted nodal gaps, CalculiX: gaps at the slave faces'
integration points). At the load a mesh is made for, the coarse level's
sizes (b/2 across the Hertz ellipse) put four elements across the patch,
where the static Hertz study's force error against the closed form is
0.24-0.36% (its medium and fine levels, ``hertz_static.py``); the Hertz
approach is 70-97% of the pair's approach from 50 N to 1 kN near the pitch
point (the coarse mesh cycle's positions) and force goes as approach to
about 1.4, so discretisation differences of that size move the torque by
well under 1%. The penalty itself (1000 E*/h, penetration under 0.3% of the approach)
is the same slope in both.

What the first run showed: within 0.57% at 200-1000 N, and 5.0% at 50 N,
where the patch on the mesh made for 1000 N is (50/1000)^(1/3) = 0.37 times
as wide: 1.5 elements across, the resolution of the Hertz study's coarse
level (1.1 elements, 5.0% force error). The premise above was then said to
hold at the design load only, and the second series (its 2% set before it
was run) was added to test it where it holds: +0.23%. The 50 N check
failed (+5.03%) until fe-impact's slave quadrature was split at the
master's edges (segment integration,
``fe_impact.contact.surfaces.mortar_segments``) and its auto penalty took
the contact faces' element size (8% stiffer here; both codes take the same
slope). With both, the first series measures +1.65% / -0.08% / +0.43% /
-0.045% at 50 / 200 / 500 / 1000 N (it was +5.03% / +0.56% / +0.17% /
+0.08%), and the second series -0.88% (it was +0.23%), so every check
passes at the 2% set before the first run. The
split is the likelier cause (CalculiX's surface-to-surface contact also
integrates on slave-face segments cut by the master's faces, and a patch
1.5 elements wide is where a rule of six points a face, whatever master
faces lie under it, errs most; a penalty 8% stiffer moves the approach by
about 0.03%), but the two changes were not run apart.

Writes ``calculix_pair.json`` (per series: rotations, approaches, both
torques, DOFs, both run times), each series' CalculiX deck ``pair.inp`` and
its ``pair.dat`` and ``ccx.log``, and ``checks.json``; exits 1 if a check
fails, and 2 with a ``SKIPPED`` line without ``ccx`` (``make validate``
lists it as skipped).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json
from validation import checks as ck
from validation.run_all import SKIPPED

FORCES = (50.0, 200.0, 500.0, 1000.0)   # N, contact normal forces of the fe-impact solve
QUICK_FORCES = (200.0, 1000.0)
#: Largest relative difference of the hub torque, CalculiX against fe-impact
#: (module docstring).
TORQUE_TOLERANCE = 0.02
#: C3D10 faces (CalculiX/Abaqus S1-S4) by their corner nodes, 0-based.
C3D10_FACES = ((0, 1, 2), (0, 3, 1), (1, 3, 2), (2, 3, 0))
#: Tension of CalculiX's linear pressure-overclosure at large clearances
#: [MPa]: "should be small" (CalculiX manual, *SURFACE BEHAVIOR); a
#: millionth of the contact pressures here (GPa).
TENSION_MPA = 1e-3


def find_ccx() -> str | None:
    """The CalculiX executable: ``$CCX``, else ``ccx`` on the path."""
    return os.environ.get("CCX") or shutil.which("ccx")


def element_faces(cells: np.ndarray, *surfaces: np.ndarray) -> list[list[tuple[int, int]]]:
    """(element, face number 1-4) of each triangle of each surface of a C3D10 mesh.

    ``cells``: tetrahedra, VTK/C3D10 node order; ``surfaces``: 6-node triangle
    arrays, looked up in one map of the elements' faces. Raises ValueError
    for a triangle no element owns.
    """
    owner: dict[tuple[int, ...], tuple[int, int]] = {}
    corners = cells[:, :4]
    for face, (a, b, c) in enumerate(C3D10_FACES, start=1):
        keys = np.sort(corners[:, [a, b, c]], axis=1)
        for e, key in enumerate(map(tuple, keys)):
            owner[key] = (e, face)
    out = []
    for triangles in surfaces:
        faces = []
        for tri in np.sort(triangles[:, :3], axis=1):
            hit = owner.get(tuple(tri))
            if hit is None:
                raise ValueError(f"surface triangle {tri.tolist()} is the face of no element")
            faces.append(hit)
        out.append(faces)
    return out


def write_mesh(path: Path, mesh) -> None:
    """Nodes [mm] and C3D10 elements of ``mesh`` as a CalculiX/Abaqus input file, through
    meshio's Abaqus writer (C3D10 is VTK's node order), every element in set EALL.

    CalculiX reads at most 20 characters a field: 13 significant digits.
    """
    import meshio

    meshio.write(path, meshio.Mesh(mesh.points * 1e3, [("tetra10", mesh.cells)]),
                 file_format="abaqus", float_fmt=".12e")
    # meshio names the element set after the cell type; the section needs EALL
    path.write_text(re.sub(r"(?im)^\*ELEMENT, *TYPE=C3D10.*$",
                           "*ELEMENT, TYPE=C3D10, ELSET=EALL", path.read_text()))


def write_deck(path: Path, mesh, case, rotations: list[float], penalty: float) -> None:
    """The CalculiX input deck of ``case`` on ``mesh`` with the hub rotations prescribed.

    Units: mm, N, MPa. ``penalty``: fe-impact's contact penalty [Pa/m], the
    slope of CalculiX's linear pressure-overclosure.
    """
    x_mm = mesh.points * 1e3
    body = case.rigid_bodies[0]
    axis = np.asarray(body.direction, dtype=float)
    axis /= np.linalg.norm(axis)
    point_mm = np.asarray(body.point, dtype=float) * 1e3
    hub = mesh.surface_points(body.surface)
    held = mesh.surface_points(case.supports[0].surface)
    write_mesh(path, mesh)
    mat = case.materials[0]
    lines = ["*NSET, NSET=PHUB", *_rows(hub + 1), "*NSET, NSET=FHUB", *_rows(held + 1)]
    contact = case.contacts[0]
    faces = element_faces(mesh.cells, mesh.surface(contact.slave),
                          mesh.surface(contact.master))
    for name, listed in zip(("SLAVE", "MASTER"), faces, strict=True):
        lines.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
        lines += [f"{e + 1}, S{f}" for e, f in listed]
    lines += [
        "*MATERIAL, NAME=STEEL", "*ELASTIC",
        f"{mat.youngs_modulus * 1e-6:.10g}, {mat.poisson_ratio:.10g}",
        "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
        "*SURFACE INTERACTION, NAME=FLANKS",
        "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
        f"{penalty * 1e-9:.10g}, {TENSION_MPA:g}",          # Pa/m -> N/mm^3
        "*CONTACT PAIR, INTERACTION=FLANKS, TYPE=SURFACE TO SURFACE",
        "SLAVE, MASTER",
        "*BOUNDARY", "FHUB, 1, 3",
    ]
    arm = x_mm[hub] - point_mm
    for theta in rotations:
        u = theta * np.cross(axis, arm)
        lines += ["*STEP, INC=200", "*STATIC", "1., 1.", "*BOUNDARY"]
        lines += [f"{n + 1}, {d + 1}, {d + 1}, {u[i, d]:.12e}"
                  for i, n in enumerate(hub) for d in range(3)]
        lines += ["*NODE PRINT, NSET=PHUB", "RF", "*END STEP"]
    with open(path, "a") as fh:    # after the nodes and elements write_mesh wrote
        fh.write("\n".join(lines) + "\n")


def _rows(ids: np.ndarray, per_line: int = 16) -> list[str]:
    return [", ".join(str(int(i)) for i in ids[k:k + per_line])
            for k in range(0, len(ids), per_line)]


def read_reactions(dat: Path) -> dict[float, dict[int, np.ndarray]]:
    """The nodal reaction forces of set PHUB (node id -> RF, N) by total time.

    CalculiX prints them after every increment; a later block at the same
    time (a step's last increment) replaces an earlier one.
    """
    blocks: dict[float, dict[int, np.ndarray]] = {}
    current: dict[int, np.ndarray] | None = None
    for line in dat.read_text().splitlines():
        if "forces (fx,fy,fz) for set PHUB and time" in line:
            current = blocks[round(float(line.split()[-1]), 9)] = {}
            continue
        parts = line.split()
        if current is None or not parts:
            continue
        try:
            current[int(parts[0])] = np.array([float(v) for v in parts[1:4]])
        except ValueError:
            current = None
    return blocks


def torque(reactions: dict[int, np.ndarray], x_mm: np.ndarray, axis: np.ndarray,
           point_mm: np.ndarray) -> float:
    """Torque [N m] of the nodal forces about the axis through ``point_mm``."""
    ids = np.fromiter(reactions, dtype=int) - 1
    f = np.array([reactions[i + 1] for i in ids])
    return float(np.sum(np.cross(x_mm[ids] - point_mm, f) @ axis)) * 1e-3


def compare(folder: Path, forces: tuple[float, ...], design_force: float) -> dict:
    """One series: the mesh made for ``design_force``, fe-impact under torque at
    ``forces``, then CalculiX at the rotations fe-impact found (files in ``folder``)."""
    from fe_impact.calibration.meshcycle import PAIR_GAP
    from fe_impact.fe.linalg import limit_threads
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.gears import default_gearset
    from fe_impact.meshing.paircase import static_pair_case
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.solvers.static import StaticSolver

    folder.mkdir(parents=True, exist_ok=True)
    gs = default_gearset()
    spec = dict(stage=1, roll_angle_deg=0.0, level="coarse", order=2, gap=PAIR_GAP,
                impact_speed=0.1, design_force=design_force)
    t0 = time.perf_counter()
    pm = build_pair(gs, out_dir=folder / "mesh", reuse=True, **spec)
    case = static_pair_case(gs, pm, forces)
    mesh = load_mesh(case.mesh_file, case.unit)
    t1 = time.perf_counter()
    with limit_threads(2):
        result = StaticSolver(case, mesh, stress=False).run()
    fe_s = time.perf_counter() - t1
    rotations = [float(s.rigid_values[0]) for s in result.steps]
    torques = [float(s.rigid_reactions[0]) for s in result.steps]
    write_deck(folder / "pair.inp", mesh, case, rotations, result.penalties[0])
    r = {"design_force_N": design_force, "forces_N": list(forces),
         "contact_forces_N": [float(s.contact_force[0]) for s in result.steps],
         "rotations_rad": rotations, "torques_fe_Nm": torques,
         "approaches_m": [-q * pm.analysis.masses.pinion_lever - PAIR_GAP for q in rotations],
         "n_dofs": int(result.info["n_dofs"]), "n_elements": int(len(mesh.cells)),
         "penalty_Pa_per_m": float(result.penalties[0]), "mesh_s": t1 - t0,
         "fe_impact_s": fe_s}
    t2 = time.perf_counter()
    proc = subprocess.run([find_ccx(), "-i", "pair"], cwd=folder, capture_output=True,
                          text=True, env={**os.environ, "OMP_NUM_THREADS": "2"})
    r["ccx_s"] = time.perf_counter() - t2
    (folder / "ccx.log").write_text(proc.stdout + proc.stderr)
    printed = read_reactions(folder / "pair.dat") if (folder / "pair.dat").is_file() else {}
    # step i (period 1) ends at total time i
    steps = [printed[float(i)] for i in range(1, len(rotations) + 1) if float(i) in printed]
    if proc.returncode != 0 or len(steps) != len(rotations):
        raise RuntimeError(f"ccx failed (exit {proc.returncode}, {len(steps)} of "
                           f"{len(rotations)} steps printed); see {folder / 'ccx.log'}")
    body = case.rigid_bodies[0]
    axis = np.asarray(body.direction, dtype=float) / np.linalg.norm(body.direction)
    r["torques_ccx_Nm"] = [torque(s, mesh.points * 1e3, axis, np.asarray(body.point) * 1e3)
                           for s in steps]
    return r


def run(quick: bool, out: Path) -> dict:
    """The series on the mesh made for the largest load; without ``quick`` also the
    smallest load on a mesh made for it."""
    forces = QUICK_FORCES if quick else FORCES
    series = {"design_largest": compare(out / "design_largest", forces, max(forces))}
    if not quick:
        series["design_smallest"] = compare(out / "design_smallest", forces[:1], forces[0])
    return {"ccx": find_ccx(), "series": series}


def check(r: dict) -> list[ck.Check]:
    checks = []
    for s in r["series"].values():
        mesh = f"mesh for {s['design_force_N']:.0f} N"
        checks += [ck.within(f"hub torque at {f:.0f} N ({mesh}), CalculiX against fe-impact",
                             c, t, TORQUE_TOLERANCE)
                   for f, c, t in zip(s["forces_N"], s["torques_ccx_Nm"], s["torques_fe_Nm"],
                                      strict=True)]
    return checks


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/calculix_pair"))
    p.add_argument("--quick", action="store_true",
                   help="200 and 1000 N on the mesh for 1000 N alone")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if find_ccx() is None:
        print("calculix_pair: SKIPPED (ccx not found: install Debian's calculix-ccx, or set "
              "CCX to the CalculiX executable)")
        return SKIPPED
    try:
        r = run(args.quick, args.out)
    except RuntimeError as exc:     # CalculiX stopped: its log says why
        print(f"calculix_pair: FAIL ({exc})")
        return 1
    write_json(args.out / "calculix_pair.json", r)
    for s in r["series"].values():
        print(f"stage 1 pitch point, coarse mesh for {s['design_force_N']:.0f} N, "
              f"{s['n_dofs']} DOFs: fe-impact {s['fe_impact_s']:.1f} s, "
              f"CalculiX {s['ccx_s']:.1f} s")
        for f, q, t, c in zip(s["forces_N"], s["rotations_rad"], s["torques_fe_Nm"],
                              s["torques_ccx_Nm"], strict=True):
            print(f"  {f:6.0f} N: rotation {q:.6e} rad, torque fe-impact {t:.6g} N m, "
                  f"CalculiX {c:.6g} N m ({c / t - 1:+.3%})")
    return ck.finish("calculix_pair", check(r), args.out)


if __name__ == "__main__":
    sys.exit(main())
