"""Cattaneo-Mindlin: a sphere pressed on a block, then a rising tangential load below sliding.

Run ``python validation/friction_cattaneo.py --out out/friction_cattaneo``
(three meshes; ``--quick``: the coarsest alone). Writes
``friction_cattaneo.json`` and ``checks.json``; exits 1 when a check fails.

Model: half a hemisphere (R = 10 mm, symmetry y = 0) on a block, both
20CrMnTi, friction ``MU`` (static solver). Step 1 pushes the hemisphere's flat
face down ``PRESS`` without friction: Mindlin's solution starts from a normal
load that leaves no tangential traction (true of two half-spaces of one
material), while the finite model pressed with friction locks radial
tractions into its rows (measured: up to 0.4 of the cone at r = 0.86 a, the
edge rows on it). Friction is then switched on, and the next steps move the
face along x: a small first step (``NOSLIP_FRACTION`` of ``SLIDE``) and
``SLIDE_STEPS`` equal ones to ``SLIDE`` (below gross slip). Each step's normal
load ``P`` and tangential load ``Q`` are the reactions of that face (twice the
half model's).

Closed forms (Johnson 1985, sections 7.2 and 7.3; Mindlin 1949), with
``x = Q / (mu P)``, ``a`` the Hertz radius of ``P`` and two equal bodies:

- stick radius ``c / a = (1 - x)^(1/3)``;
- tangential displacement of the bodies' distant points
  ``delta_M = 3 mu P (2 - nu) / (8 G a) (1 - (1 - x)^(2/3))``, whose slope at
  ``Q = 0`` is the no-slip compliance ``C_0 = (2 - nu) / (4 G a)``;
- the incremental compliance ``d delta_M / dQ = (2 - nu) / (4 G c)``: the
  partial-slip contact is as stiff as a no-slip contact of the stick disc.

What is measured:

- the finite bodies' own compliance: the FE's displacement ``delta`` holds,
  besides ``delta_M``, the bodies' linear compliance beyond the half-space's.
  The first, small tangential step (``x`` about 0.005, where Mindlin's
  microslip is 1e-3 of the displacement, removed by the closed form) gives the
  FE's no-slip compliance ``C_FE``, and ``C_bulk = C_FE - C_0``.
- the compliance's microslip part: ``delta(Q) - C_FE Q`` against
  ``delta_M(Q) - C_0 Q``.
- the stick radius by the stiffness: ``c = (2 - nu) / (4 G (d delta / dQ -
  C_bulk))``, ``d delta / dQ`` the FE's secant over the steps either side of
  the check load, against the same secant of ``delta_M`` turned into ``c`` by
  the same formula (which equals ``a (1 - x)^(1/3)`` at the interval's load to
  second order in the step). A direct count of the rows is not used: each
  row sticks or slips by its own nodal forces, and the rows' tangential
  forces in the stick zone scatter about Cattaneo's traction by 0.14-0.25
  of the cone (rms; the normal forces by 5-12%) on P2 meshes of 0.1 and
  0.14 mm, so rows near the front reach the cone early: the stick rows'
  area gives a disc smaller than Mindlin's, by 9% on the coarsest mesh and
  3.4-3.6% on the finest (reported as ``c_over_a_rows``, not checked).

``--quick`` (the coarsest mesh) checks the friction force within the cone
and the stiffness's stick radius within half an element of Mindlin's at every
step.

Tolerances: 3% (the issue's, set before any result) on ``c / a`` and on the
compliance's microslip part at the two loads ``CHECK_LOADS`` on the finest
mesh; the same 3% on the largest ``c / a`` error over every step between
(a check added after the first full run, stricter than the two loads); the
observed order of the errors over the three meshes (refinement ratio
``sqrt(2)``) reported. Coarser meshes are reported only.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.contact.friction import FrictionLaw
from fe_impact.fe.case import (
    AnalysisSpec,
    Case,
    ContactSpec,
    DisplacementSpec,
    MaterialSpec,
    SupportSpec,
)
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_json
from fe_impact.physics import hertz
from fe_impact.solvers.static import StaticSolver
from validation import checks as ck
from validation.friction_specimens import HalfSphereBlock, build_half_sphere_block

E, NU, RHO, R = 212e9, 0.289, 7860.0, 10e-3
G = E / (2.0 * (1.0 + NU))
MU = 0.3
PRESS = 20e-6
SLIDE = 5.6e-6
SLIDE_STEPS = 16
#: the first tangential step, a fraction of SLIDE: x about 0.005, the no-slip reference
NOSLIP_FRACTION = 0.005
#: contact element sizes (m), coarse to fine, each sqrt(2) finer
LEVELS = {"coarse": 0.13e-3, "medium": 0.092e-3, "fine": 0.065e-3}
RATIO = math.sqrt(2.0)
#: the meshes' grading: fine within 0.7 mm along the surface (1.5 a) and 0.35 mm
#: in depth, coarsening over 10 mm, twice as fast in depth
MESH = {"r_fine": 0.7e-3, "r_grade": 10e-3, "depth_ratio": 2.0}
#: the loads Q / (mu P) at which c / a and the compliance are checked (the steps
#: nearest to them)
CHECK_LOADS = (0.5, 0.8)
#: the issue's tolerance at the finest mesh
TOLERANCE = 0.03


def hertz_radius(P: float) -> float:
    """Hertz contact radius (m) of the sphere on a flat under ``P`` (N)."""
    return (3.0 * P * R / (4.0 * hertz.effective_modulus(E, NU))) ** (1.0 / 3.0)


def mindlin_displacement(Q, P):
    """``delta_M`` of two equal bodies (m) at the tangential loads ``Q`` (N)."""
    a = hertz_radius(P)
    x = np.asarray(Q) / (MU * P)
    return 3.0 * MU * P * (2.0 - NU) / (8.0 * G * a) * (1.0 - (1.0 - x) ** (2.0 / 3.0))


def noslip_compliance(P: float) -> float:
    """``C_0 = (2 - nu) / (4 G a)`` (m/N): Mindlin's compliance at ``Q = 0``."""
    return (2.0 - NU) / (4.0 * G * hertz_radius(P))


def stick_radius(compliance: float) -> float:
    """The stick radius (m) whose no-slip compliance is ``compliance`` (m/N)."""
    return (2.0 - NU) / (4.0 * G * compliance)


def slides(steps: int = SLIDE_STEPS) -> tuple[float, ...]:
    """The face's x displacement per step (m): the press, the small no-slip step,
    then ``steps`` equal steps to :data:`SLIDE`."""
    return (0.0, NOSLIP_FRACTION * SLIDE, *np.linspace(0.0, SLIDE, steps + 1)[1:])


def cattaneo_case(mesh_file: Path, steps: int = SLIDE_STEPS) -> Case:
    """The press, then the tangential steps of :func:`slides`."""
    s = tuple(float(v) for v in slides(steps))
    return Case(path=Path(mesh_file).with_suffix(".case"), mesh_file=Path(mesh_file),
                unit="m", materials=(MaterialSpec(("sphere", "block"), E, NU, RHO),),
                contacts=(ContactSpec("sphere_contact", "block_contact",
                                      search_distance=4e-6, mu_static=MU, mu_dynamic=MU),),
                supports=(SupportSpec("block_bottom", (0, 1, 2)), SupportSpec("sym_y", (1,))),
                displacements=(DisplacementSpec("sphere_equator", 2, (-PRESS,) * len(s)),
                               DisplacementSpec("sphere_equator", 0, s)),
                analysis=AnalysisSpec(tolerance=1e-8, max_iterations=60))


def solve(case: Case, mesh_file: Path):
    """The case's steps, the first (the press) without friction: its contact
    laws are swapped for frictionless ones for that step alone."""
    solver = StaticSolver(case, load_mesh(mesh_file), stress=False)
    laws = solver.contact.laws
    solver.contact.laws = [FrictionLaw(0.0, 0.0, law.transition_speed) for law in laws]
    steps = []
    for i in range(case.n_steps):
        if i == 1:
            solver.contact.laws = laws
        steps.append(solver.solve_step(i))
    return solver, steps


def rows_stick_radius(rows) -> float:
    """The radius (m) of the half disc as large as the stick rows' tributary area
    (rows in contact and not on the friction cone)."""
    stick = (rows.normal_force > 0) & ~rows.slipping
    return math.sqrt(2.0 * float(rows.weight[stick].sum()) / math.pi)


def mesh_spec(h: float) -> HalfSphereBlock:
    """The half-hemisphere model meshed with ``h`` (m) at the contact."""
    return HalfSphereBlock(radius=R, h_contact=h, order=2, hemisphere=True, **MESH)


def run_level(out: Path, name: str, h: float, steps: int = SLIDE_STEPS) -> dict:
    """One mesh: the steps' loads, the measured and closed-form figures, the checks'."""
    mesh_file = out / f"half_hemisphere_{name}.msh"
    t0, c0 = time.perf_counter(), time.process_time()
    if not mesh_file.exists():
        build_half_sphere_block(mesh_spec(h), mesh_file)
    case = cattaneo_case(mesh_file, steps)
    solver, results = solve(case, mesh_file)
    s = np.array(case.displacements[1].values)
    P = np.array([-2.0 * r.reaction_force[0] for r in results])
    Q = np.array([2.0 * r.reaction_force[1] for r in results])
    # the no-slip reference: the small first step, Mindlin's microslip in it removed
    C_fe = s[1] / Q[1] - (float(mindlin_displacement(Q[1], P[1])) / Q[1]
                          - noslip_compliance(P[1]))
    C_bulk = C_fe - noslip_compliance(P[1])
    rows = []
    for k in range(2, len(results)):
        x = Q[k] / (MU * P[k])
        a = hertz_radius(P[k])
        row = {"slide_m": float(s[k]), "P": float(P[k]), "Q": float(Q[k]), "x": float(x),
               "a_hertz": a, "c_over_a_theory": (1.0 - x) ** (1.0 / 3.0) if x < 1 else 0.0,
               "c_over_a_rows": rows_stick_radius(results[k].friction_rows) / a,
               "microslip_fe_m": float(s[k] - C_fe * Q[k]),
               "microslip_theory_m": float(mindlin_displacement(Q[k], P[k])
                                           - noslip_compliance(P[k]) * Q[k])}
        if 2 < k < len(results) - 1:
            dQ = Q[k + 1] - Q[k - 1]
            slope_fe = (s[k + 1] - s[k - 1]) / dQ
            slope_th = (float(mindlin_displacement(Q[k + 1], P[k + 1]))
                        - float(mindlin_displacement(Q[k - 1], P[k - 1]))) / dQ
            row.update(c_over_a_stiffness=stick_radius(slope_fe - C_bulk) / a,
                       c_over_a_stiffness_theory=stick_radius(slope_th) / a)
        rows.append(row)
    checks = []
    for target in CHECK_LOADS:
        r = min((r for r in rows if "c_over_a_stiffness" in r),
                key=lambda r, t=target: abs(r["x"] - t))
        checks.append({
            "x": r["x"],
            "c_over_a_error": r["c_over_a_stiffness"] / r["c_over_a_stiffness_theory"] - 1,
            "microslip_error": r["microslip_fe_m"] / r["microslip_theory_m"] - 1,
            "c_over_a_rows_error": r["c_over_a_rows"] / r["c_over_a_theory"] - 1})
    errors = [r["c_over_a_stiffness"] / r["c_over_a_stiffness_theory"] - 1
              for r in rows if "c_over_a_stiffness" in r]
    return {"level": name, "h_contact": h, "n_dofs": solver.model.n_dofs,
            "c_over_a_largest_error": max(errors, key=abs),
            "n_contact_dofs": int(solver.n_condensed),
            "noslip_compliance_fe": C_fe, "noslip_compliance_theory": noslip_compliance(P[1]),
            "wall_seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            "steps": rows, "checks": checks}


def observed_order(errors: list[float], ratio: float = RATIO) -> float | None:
    """Order of the error from three meshes refined by ``ratio`` each time (None:
    the errors do not fall monotonically)."""
    e0, e1, e2 = (abs(e) for e in errors)
    if min(e0, e1, e2) == 0.0 or not e0 > e1 > e2:
        return None
    return math.log(e1 / e2) / math.log(ratio)


def run(quick: bool = False, out: str | Path = "out/friction_cattaneo") -> dict:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    names = ["coarse"] if quick else list(LEVELS)
    levels = [run_level(out, n, LEVELS[n]) for n in names]
    record = {"quick": quick, "mu": MU, "refinement_ratio": RATIO, "levels": levels}
    if len(levels) == 3:
        record["orders"] = {
            f"{key} at x = {CHECK_LOADS[i]}": observed_order(
                [lv["checks"][i][key] for lv in levels])
            for i in range(len(CHECK_LOADS))
            for key in ("c_over_a_error", "microslip_error", "c_over_a_rows_error")}
        record["orders"]["c_over_a_largest_error"] = observed_order(
            [lv["c_over_a_largest_error"] for lv in levels])
    write_json(out / "friction_cattaneo.json", record)
    return record


def quick_checks(level: dict) -> list[ck.Check]:
    """The coarse mesh's checks: the friction force within the cone (Coulomb) and
    the stick radius by the stiffness within half an element of Mindlin's at every
    interior step (a contact edge is placed to half an element: the rule the static
    Hertz study applies to the contact radius)."""
    steps = level["steps"]
    ratio = max(s["Q"] / (MU * s["P"]) for s in steps)
    worst = max((abs(s["c_over_a_stiffness"] - s["c_over_a_theory"]) * s["a_hertz"]
                 for s in steps if "c_over_a_stiffness" in s), default=math.inf)
    h = level["h_contact"]
    return [ck.at_most(f"Q/(mu P), largest over the steps, {level['level']} mesh", ratio,
                       1.0 + 1e-6),
            ck.holds(f"stick radius (by the stiffness), largest |c - c_Mindlin| / h over the "
                     f"interior steps, {level['level']} mesh", worst / h, worst <= 0.5 * h,
                     "<= 0.5 (half an element)")]


def check(r: dict) -> list[ck.Check]:
    if r["quick"]:
        return quick_checks(r["levels"][0])
    finest = r["levels"][-1]
    out = []
    for c in finest["checks"]:
        for key, what in (("c_over_a_error", "stick radius c/a (by the stiffness)"),
                          ("microslip_error", "tangential compliance (microslip part)")):
            out.append(ck.holds(f"{what} at Q/(mu P) = {c['x']:.2f}, {finest['level']} mesh",
                                c[key], abs(c[key]) <= TOLERANCE, f"|error| <= {TOLERANCE:g}"))
    worst = finest["c_over_a_largest_error"]
    out.append(ck.holds(f"stick radius c/a (by the stiffness), largest error over every "
                        f"interior step, {finest['level']} mesh", worst,
                        abs(worst) <= TOLERANCE, f"|error| <= {TOLERANCE:g}"))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/friction_cattaneo"))
    p.add_argument("--quick", action="store_true", help="the coarsest mesh alone")
    args = p.parse_args(argv)
    r = run(args.quick, args.out)
    print(json.dumps(r, indent=2, default=float))
    return ck.finish("friction_cattaneo", check(r), args.out)


if __name__ == "__main__":
    sys.exit(main())
