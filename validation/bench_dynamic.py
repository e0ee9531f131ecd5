"""Transient solver benchmark: Newmark impact wall time and explicit step cost.

Run ``python validation/bench_dynamic.py`` (about a minute). Writes
``out/bench_dynamic/bench_dynamic.json``.

1. Newmark: the 1 m/s rigid-mass hemisphere impact (``hertz_impact`` case a)
   on a quarter model of about 18k DOF of P2 tetrahedra, time step t_c/60 so
   that at least 50 steps fall within the contact; wall time from reading
   the case to the last step (target 15 s; a mature open-source FE code
   needs about 150 s CPU for this size with 31 implicit steps).
2. Explicit: the average time of one central-difference step (stiffness
   product, contact forces, history) over 2000 steps of the same model,
   against the memory-bandwidth bound of the stiffness product measured in
   the same run: the bytes a CSR product must read (values, column indices,
   row pointers, x, and y written) divided by the read bandwidth of a large
   numpy reduction. Target: at most 1.5x.
3. Elastic-plastic explicit: the same 2000 steps with J2 plasticity (yield
   835 MPa) tracked near the contact, against the elastic step of item 2.
   Target: at most 2x.
4. Elastic-plastic Newmark: the case of item 1 with the same yield strength
   (1 m/s is 11.5 x the yield-onset speed), by Newton with the consistent
   tangent and by Anderson-accelerated modified Newton: time of the steps
   against item 1's elastic steps, iterations, GMRES products, restitution.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.case import load_case
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_json
from fe_impact.physics import hertz
from fe_impact.solvers.dynamic import DynamicSolver
from validation.hertz_impact import HEMISPHERE_MASS, RIGID_MASS
from validation.impact_cases import NU, E, R, sphere_block_mesh, write_sphere_impact

H_CONTACT = 0.16e-3   # about 18k DOF with P2
SPEED = 1.0


def bandwidth(nbytes: int = 400_000_000, repeat: int = 5) -> float:
    """Memory read bandwidth (bytes/s): best of ``repeat`` sums of a large array."""
    a = np.ones(nbytes // 8)
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        a.sum()
        best = min(best, time.perf_counter() - t)
    return a.nbytes / best


def matvec_bytes(K) -> int:
    n = K.shape[0]
    return K.data.nbytes + K.indices.nbytes + K.indptr.nbytes + 2 * 8 * n


def newmark(out: Path, solver: str | None = None) -> dict:
    """Item 1; with ``solver`` ("newton" or "anderson") the elastic-plastic item 4."""
    folder = out / "case"
    mesh = sphere_block_mesh(folder, H_CONTACT, gap=1e-6)
    ref = hertz.impact(RIGID_MASS + HEMISPHERE_MASS, SPEED, R, hertz.effective_modulus(E, NU))
    case = write_sphere_impact(folder, mesh, SPEED, 1e-6 / SPEED + 1.3 * ref.contact_time,
                               rigid_mass=RIGID_MASS, time_step=ref.contact_time / 60,
                               frames=10, name=f"newmark_{solver or 'elastic'}.toml")
    if solver is not None:
        case.write_text(case.read_text().replace(
            "density = 7860\n", "density = 7860\nyield_strength = 835e6\n").replace(
            'integrator = "newmark"\n', f'integrator = "newmark"\nplastic_solver = "{solver}"\n'))
    t0 = time.perf_counter()
    dyn = DynamicSolver(load_case(case), load_mesh(mesh))
    res = dyn.run()
    wall = time.perf_counter() - t0
    m = res.measurements
    if solver is not None:
        pl = res.info["plasticity"]
        return {"solver": solver, "wall_s": wall, "steps_s": res.timings["integration"],
                "plastic_iterations": pl["plastic_iterations"],
                "krylov_products": pl["krylov_products"],
                "plastic_points": pl["plastic_points"], "restitution": m["restitution"],
                "dissipation_J": pl["dissipation"], "energy_error": m["energy_error"]}
    return {"n_dofs": res.info["n_dofs"], "steps": res.info["steps"],
            "steps_in_contact": int(round(m["contact_duration"] / res.info["time_step"])),
            "wall_s": wall, "target_s": 15.0, "timings_s": res.timings,
            "peak_force_error_vs_hertz": 4 * m["peak_force"] / ref.force_max - 1.0,
            "projections": res.info["projections"]}


def _explicit_case(out: Path, steps: int, plastic: bool) -> Path:
    folder = out / "case"
    mesh = sphere_block_mesh(folder, H_CONTACT, gap=1e-6)
    probe = write_sphere_impact(folder, mesh, SPEED, 1e-6, integrator="explicit",
                                rigid_mass=RIGID_MASS, frames=1, name="explicit_probe.toml")
    dt = DynamicSolver(load_case(probe), load_mesh(mesh)).dt
    case = write_sphere_impact(folder, mesh, SPEED, steps * dt, integrator="explicit",
                               rigid_mass=RIGID_MASS, frames=1,
                               name="explicit_plastic.toml" if plastic else "explicit.toml")
    if plastic:
        case.write_text(case.read_text().replace(
            "density = 7860\n", "density = 7860\nyield_strength = 835e6\n"))
    return case


def explicit_plastic(out: Path, elastic_step_ms: float, steps: int = 2000) -> dict:
    case = load_case(_explicit_case(out, steps, plastic=True))
    solver = DynamicSolver(case, load_mesh(case.mesh_file, case.unit))
    t = time.perf_counter()
    res = solver.run()
    step = (time.perf_counter() - t) / res.info["steps"]
    pl = res.info["plasticity"]
    return {"step_ms": step * 1e3, "over_elastic": step * 1e3 / elastic_step_ms,
            "zone_elements": pl["zone_elements"], "plastic_points": pl["plastic_points"],
            "target_ratio": 2.0}


def explicit(out: Path, steps: int = 2000) -> dict:
    case = load_case(_explicit_case(out, steps, plastic=False))
    solver = DynamicSolver(case, load_mesh(case.mesh_file, case.unit))
    dt = solver.dt
    K = solver.K
    x = np.random.default_rng(0).random(K.shape[0])
    reps = 300
    t = time.perf_counter()
    for _ in range(reps):
        K @ x
    matvec = (time.perf_counter() - t) / reps
    bw = bandwidth()
    bound = matvec_bytes(K) / bw
    t = time.perf_counter()
    res = solver.run()
    step = (time.perf_counter() - t) / res.info["steps"]
    return {"n_reduced_dofs": int(K.shape[0]), "nnz": int(K.nnz), "time_step": dt,
            "stable_time_step": res.info["stable_time_step"], "steps": res.info["steps"],
            "bandwidth_GB_s": bw / 1e9, "matvec_bytes": matvec_bytes(K),
            "bound_ms": bound * 1e3, "matvec_ms": matvec * 1e3, "step_ms": step * 1e3,
            "step_over_bound": step / bound, "matvec_over_bound": matvec / bound,
            "target_ratio": 1.5}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_dynamic"))
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = {"newmark": newmark(args.out), "explicit": explicit(args.out)}
    result["explicit_plastic"] = explicit_plastic(args.out, result["explicit"]["step_ms"])
    elastic_steps = result["newmark"]["timings_s"]["integration"]
    for solver in ("newton", "anderson"):
        r = newmark(args.out, solver)
        r["steps_over_elastic"] = r["steps_s"] / elastic_steps
        result[f"newmark_plastic_{solver}"] = r
    result["newton_over_anderson"] = (result["newmark_plastic_newton"]["steps_s"]
                                      / result["newmark_plastic_anderson"]["steps_s"])
    write_json(args.out / "bench_dynamic.json", result)
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
