"""Static Hertz validation: a hemisphere pressed on a block, four mesh levels.

Run ``python validation/hertz_static.py --out out/hertz_static`` (about 5
minutes and 9 GB, most of it the finest level; ``--quick``, the medium and
fine levels, one to two minutes); it writes ``hertz_static.csv``,
``hertz_static.json``, ``hertz_static.md`` (with the checks) and
``hertz_static.png``, and exits 1 when a check fails: the force within 1%
from the medium level on, the contact radius within half an element, the
peak and centre pressure within 5% once the contact radius spans four
elements (see the constants).

Model: quarter of a hemisphere R = 10 mm on a 20 x 20 x 10 mm block (both
20CrMnTi), symmetry planes x = 0 and y = 0, block bottom fixed in z, the
hemisphere's flat equator face pushed down 5 ... 25 um in five steps, the
curved face the slave surface. Reported forces are for the whole sphere
(4 x the quarter model).

What is compared
----------------
Hertz theory assumes two half-spaces and measures the approach between
points far away. The model is finite: the equator is 10 mm above the
contact and the block bottom 10 mm below, so the prescribed displacement
D is not the Hertz approach (the bodies' own compliance adds to it). To
separate that far-field part from the discretisation error, the approach
is measured locally, between the points on the axis at depth ``d`` in
each body, and compared with Hertz plus the Boussinesq-type axial
displacement of a half-space under the Hertz pressure at that depth
(``hertz.axial_displacement``):

    delta_local(F) = a(F)^2 / R - w(d; a, p0) [sphere] - w(d; a, p0) [block]

Force error: the FE force against the Hertz force that produces the
measured local approach. The far-field part, reported separately, is
``(D - a^2/R) / D`` at the FE force: the share of the prescribed
displacement that is not Hertz approach. Contact radius from the contact
area (sqrt(4 A / pi) for the quarter), peak pressure the largest nodal
pressure, both against Hertz at the FE force.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.case import MULTIPLIERS
from fe_impact.fe.casefile import write_case as write_case_file
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_csv, write_json
from fe_impact.physics import hertz
from fe_impact.solvers.static import StaticSolver
from validation import checks as ck
from validation.impact_cases import NU, E, R, sphere_block_case
from validation.specimens import SphereBlockSpec, build_sphere_block

logger = logging.getLogger(__name__)

DISPLACEMENTS = (-5e-6, -1e-5, -1.5e-5, -2e-5, -2.5e-5)
#: Element size at the contact (m). At the first step (a = 225 um) the contact
#: radius spans 1.1 / 2.2 / 4.5 / 6.4 elements.
LEVELS = {"coarse": 0.2e-3, "medium": 0.1e-3, "fine": 0.05e-3, "finest": 0.035e-3}
QUICK_LEVELS = ("medium", "fine")
SYMMETRY = 4.0  # quarter model
DEPTH = 2.0e-3  # axis points for the local approach: 4 contact radii at full load


@dataclass(frozen=True)
class LevelResult:
    level: str
    h_contact: float
    n_dofs: int
    n_contact_dofs: int
    seconds: float
    rows: list[dict]


#: Hertz contact radius at the first load step (5 um): sqrt(R D), 224 um.
A_FIRST = float(np.sqrt(R * -DISPLACEMENTS[0]))
#: Force error against Hertz through the local approach: the far-field
#: correction itself is accurate to about 0.3% (converged under far-field
#: refinement) and the contact mesh adds under 0.4% from the medium level on,
#: so 1% (levels resolving a with 2 elements or more).
FORCE_TOLERANCE = 0.01
#: The contact radius comes from the loaded nodes' areas, which place the edge
#: to within half an element: tolerance 0.5 h / a at each step (its Hertz a) plus 1%.
RADIUS_SLACK = 0.01
#: Peak and centre pressure: the issue's 5% once a spans 4 elements or more
#: at the first step (fine, finest); coarser levels are reported only.
PRESSURE_TOLERANCE = 0.05


def specimen_mesh(folder: Path, h_contact: float, order: int = 2) -> Path:
    """Mesh the hemisphere-on-block specimen of this study into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    spec = SphereBlockSpec(radius=R, h_contact=h_contact, r_fine=0.8e-3, order=order)
    return build_sphere_block(spec, folder / "sphere_block.msh")


def write_case(folder: Path, h_contact: float, order: int = 2,
               displacements=DISPLACEMENTS, multiplier: str = "linear") -> Path:
    """Mesh the specimen and write its case file; returns the case path.

    The study itself builds the case in memory (:func:`run_level`); the
    file serves the tests of the case-file path.
    """
    case = sphere_block_case(specimen_mesh(folder, h_contact, order), displacements)
    case = replace(case, contacts=(replace(case.contacts[0], multiplier=multiplier),))
    return write_case_file(case, folder / "case.toml")


def axis_point(solver: StaticSolver, volume: str, z: float) -> int:
    """Index of the mesh point on the axis x = y = 0 of ``volume`` nearest height z."""
    mesh = solver.mesh
    pts = np.unique(mesh.cells[mesh.volume(volume)])
    x = mesh.points[pts]
    on_axis = pts[np.hypot(x[:, 0], x[:, 1]) < 1e-9]
    return int(on_axis[np.argmin(np.abs(mesh.points[on_axis, 2] - z))])


def compare(step, solver: StaticSolver, ps: int, pb: int) -> dict:
    """Errors of one load step against Hertz (see module docstring)."""
    e_star = hertz.effective_modulus(E, NU)
    force = SYMMETRY * step.contact_force[0]
    zs, zb = solver.mesh.points[ps, 2], -solver.mesh.points[pb, 2]
    local = step.u[pb, 2] - step.u[ps, 2]  # approach of the two axis points

    def local_hertz(f: float) -> float:
        c = hertz.sphere_contact(f, R, e_star)
        return float(c.a ** 2 / R - hertz.axial_displacement(zs, c.a, c.p0, E, NU)
                - hertz.axial_displacement(zb, c.a, c.p0, E, NU))

    f_hertz = brentq(lambda f: local_hertz(float(f)) - local, 1e-3 * force, 1e3 * force,
                     xtol=1e-12)
    c = hertz.sphere_contact(force, R, e_star)
    # Contact radius from the loaded area of the quarter model: the tributary
    # areas of the surface nodes with a positive pressure, which resolve the
    # edge to about half an element.
    a_fe = np.sqrt(SYMMETRY * step.contact_area[0] / np.pi)
    return {
        "displacement_um": -step.value * 1e6,
        "force_N": force,
        "force_hertz_local_N": f_hertz,
        "force_error": force / f_hertz - 1.0,
        "force_hertz_uncorrected_N": hertz.sphere_force(-step.value, R, e_star),
        "far_field_share": (-step.value - c.a ** 2 / R) / -step.value,
        "contact_radius_um": a_fe * 1e6,
        "contact_radius_hertz_um": c.a * 1e6,
        "radius_error": a_fe / c.a - 1.0,
        "peak_pressure_MPa": step.max_pressure / 1e6,
        "peak_pressure_hertz_MPa": c.p0 / 1e6,
        "pressure_error": step.max_pressure / c.p0 - 1.0,
        **pressure_field(step, solver, c),
        "penetration_ratio": step.max_penetration / (c.a ** 2 / R),
        "iterations": step.iterations,
    }


def pressure_field(step, solver: StaticSolver, c) -> dict:
    """Nodal pressures against Hertz's p(r) = p0 sqrt(1 - r^2/a^2) at every contact node.

    ``centre_pressure_error``: the node on the axis against p0 (Hertz's peak is
    the centre pressure). ``pressure_rms_error`` / ``pressure_max_deviation``:
    RMS and largest |p_FE(r) - p_Hertz(r)| / p0 over the slave nodes where
    either is positive. The largest nodal pressure (``pressure_error``) can
    sit on a single node off the centre whose weighted gap is noisy.
    """
    pts = solver.mesh.points
    slave = np.unique(solver.pairs[0].slave.faces)
    r = np.hypot(pts[slave, 0], pts[slave, 1])
    p = step.pressure[slave]
    p_h = c.p0 * np.sqrt(np.clip(1.0 - (r / c.a) ** 2, 0.0, None))
    on = (p > 0) | (p_h > 0)
    dev = (p[on] - p_h[on]) / c.p0
    centre = slave[np.argmin(r)]
    return {"centre_pressure_error": float(step.pressure[centre] / c.p0 - 1.0),
            "pressure_rms_error": float(np.sqrt(np.mean(dev ** 2))),
            "pressure_max_deviation": float(np.abs(dev).max())}


def run_level(level: str, h_contact: float, out: Path,
              multiplier: str = "linear") -> LevelResult:
    t = time.perf_counter()
    mesh_file = specimen_mesh(out / level, h_contact)
    case = sphere_block_case(mesh_file, DISPLACEMENTS)
    case = replace(case, contacts=(replace(case.contacts[0], multiplier=multiplier),))
    solver = StaticSolver(case, load_mesh(mesh_file))
    ps = axis_point(solver, "sphere", DEPTH)
    pb = axis_point(solver, "block", -DEPTH)
    result = solver.run()
    rows = [compare(s, solver, ps, pb) for s in result.steps]
    secs = time.perf_counter() - t
    logger.info("%s: %d DOFs in %.1f s", level, result.info["n_dofs"], secs)
    return LevelResult(level, h_contact, result.info["n_dofs"],
                       result.info["n_contact_dofs"], secs, rows)


def run(levels: dict[str, float] | None = None, out: str | Path = "out/hertz_static",
        multiplier: str = "linear", quick: bool = False) -> list[LevelResult]:
    """Solve the levels and write the tables; returns the per-level results.

    ``levels`` None: every level, or :data:`QUICK_LEVELS` with ``quick``.
    """
    out = Path(out)
    if levels is None:
        levels = {k: LEVELS[k] for k in QUICK_LEVELS} if quick else LEVELS
    results = [run_level(name, h, out, multiplier) for name, h in levels.items()]
    header = ["level", "h_contact_mm", "n_dofs"] + list(results[0].rows[0])
    table = [[r.level, r.h_contact * 1e3, r.n_dofs] + list(row.values())
             for r in results for row in r.rows]
    write_csv(out / "hertz_static.csv", header, table)
    write_json(out / "hertz_static.json", {"levels": [vars(r) for r in results],
                                           "depth_m": DEPTH, "radius_m": R})
    (out / "hertz_static.md").write_text(report(results, multiplier))
    return results


def check(results: list[LevelResult]) -> list[ck.Check]:
    """Force, contact radius and pressure of each level against its tolerance."""
    out = []
    for r in results:
        span = A_FIRST / r.h_contact     # elements across a at the first step
        if span >= 2.0:
            out.append(ck.at_most(f"{r.level}: force error", worst(r, "force_error"),
                                  FORCE_TOLERANCE))
            # the margin each step's error leaves below its own half element
            margin = min(0.5 * r.h_contact / (row["contact_radius_hertz_um"] * 1e-6)
                         + RADIUS_SLACK - abs(row["radius_error"]) for row in r.rows)
            out.append(ck.at_least(f"{r.level}: contact radius error, margin below 0.5 h / a "
                                   "+ 1% at each step", margin, 0.0))
        if span >= 4.0:
            for key in ("pressure_error", "centre_pressure_error"):
                out.append(ck.at_most(f"{r.level}: {key.replace('_', ' ')}", worst(r, key),
                                      PRESSURE_TOLERANCE))
    return out


def worst(r: LevelResult, key: str) -> float:
    """Largest absolute error of ``key`` over the load steps."""
    return max(abs(row[key]) for row in r.rows)


def report(results: list[LevelResult], multiplier: str = "linear") -> str:
    lines = ["# Static Hertz validation (hemisphere R = 10 mm on a block, P2, "
             f"{multiplier} contact pressure)", "",
             "| level | h at contact (mm) | DOFs | time (s) | force error | radius error "
             "| peak (largest nodal) pressure error | centre pressure error "
             "| p(r) RMS / max deviation | far-field share of D |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        ff = [row["far_field_share"] for row in r.rows]
        lines.append(f"| {r.level} | {r.h_contact * 1e3:.3g} | {r.n_dofs} | {r.seconds:.1f} "
                     f"| {worst(r, 'force_error'):.2%} | {worst(r, 'radius_error'):.2%} "
                     f"| {worst(r, 'pressure_error'):.2%} "
                     f"| {worst(r, 'centre_pressure_error'):.2%} "
                     f"| {worst(r, 'pressure_rms_error'):.2%} / "
                     f"{worst(r, 'pressure_max_deviation'):.2%} "
                     f"| {min(ff):.1%} to {max(ff):.1%} |")
    lines += ["", "Errors are the largest over the five load steps (5-25 um). Pressure "
              "deviations are relative to p0, over the slave nodes where the FE or the "
              "Hertz pressure is positive. Hertz's p0 is the centre pressure. The contact "
              "radius is sqrt(area / pi), the area being the tributary areas of the "
              "surface nodes with a positive pressure (on the faces' linear sub-triangles, "
              "so the edge is resolved to about half an element).", "",
              "Per load step (convergence at equal load), contact radius error / largest "
              "nodal pressure error / centre pressure error:", "",
              "| D (um) | " + " | ".join(r.level for r in results) + " |",
              "|---|" + "---|" * len(results)]
    for i, row in enumerate(results[0].rows):
        cells = [f"{r.rows[i]['radius_error']:+.2%} / {r.rows[i]['pressure_error']:+.2%} / "
                 f"{r.rows[i]['centre_pressure_error']:+.2%}" for r in results]
        lines.append(f"| {row['displacement_um']:g} | " + " | ".join(cells) + " |")
    lines.append("")
    return "\n".join(lines)


def plot(results: list[LevelResult], path: str | Path) -> Path:
    """Force-approach, contact radius and peak pressure against Hertz (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    for r in results:
        f = [row["force_N"] for row in r.rows]
        ax[0].plot([row["force_hertz_local_N"] for row in r.rows], f, "o-", label=r.level)
        ax[1].plot(f, [row["contact_radius_um"] for row in r.rows], "o-", label=r.level)
        ax[2].plot(f, [row["peak_pressure_MPa"] for row in r.rows], "o-", label=r.level)
    fh = np.linspace(1, max(row["force_N"] for row in results[-1].rows) * 1.05, 100)
    e_star = hertz.effective_modulus(E, NU)
    hc = [hertz.sphere_contact(x, R, e_star) for x in fh]
    ax[0].plot(fh, fh, "k--", label="Hertz")
    ax[1].plot(fh, [c.a * 1e6 for c in hc], "k--", label="Hertz")
    ax[2].plot(fh, [c.p0 / 1e6 for c in hc], "k--", label="Hertz")
    ax[0].set(xlabel="Hertz force for the measured local approach (N)", ylabel="FE force (N)",
              title="force-approach")
    ax[1].set(xlabel="force (N)", ylabel="contact radius (um)", title="contact radius")
    ax[2].set(xlabel="force (N)", ylabel="peak pressure (MPa)", title="peak pressure")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/hertz_static"))
    p.add_argument("--levels", default=None,
                   help=f"comma-separated subset of {list(LEVELS)} (default: all)")
    p.add_argument("--quick", action="store_true",
                   help=f"levels {', '.join(QUICK_LEVELS)} only (about two minutes)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    p.add_argument("--multiplier", choices=MULTIPLIERS, default="linear",
                   help="contact pressure interpolation on the quadratic faces "
                        "(default: linear, the solver's default)")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("skfem").setLevel(logging.WARNING)
    names = (args.levels.split(",") if args.levels
             else list(QUICK_LEVELS) if args.quick else list(LEVELS))
    unknown = [k for k in names if k not in LEVELS]
    if unknown:
        p.error(f"--levels: unknown level(s) {unknown}; pick from {list(LEVELS)}")
    chosen = {k: LEVELS[k] for k in names}
    results = run(chosen, args.out, args.multiplier)
    checks = check(results)
    text = report(results, args.multiplier) + "\n## Checks\n\n" + ck.markdown(checks)
    (args.out / "hertz_static.md").write_text(text)
    if not args.no_plot:
        plot(results, args.out / "hertz_static.png")
    print(text)
    return ck.finish("hertz_static", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
