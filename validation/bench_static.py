"""Benchmark: static sphere-on-block contact at about 31.6k DOF (P2), five increments.

Reference point (issue target): a mature open-source FE code needs about
230 s on this kind of machine for this size; target <= 20 s wall including
assembly. The machine is shared, so the target is asserted as a ratio to a
baseline of the same run: the whole solve (set-up, contact condensation and
the five increments) at most 12 times the assembly plus factorisation of
the stiffness (its own phases). On this machine kind, unloaded, those take
1.6 s at 31k DOF, so 12 x is the 20 s target.
Friction: the same case with the seed's greased flanks (mu_static 0.05,
mu_dynamic 0.02; a static case slips at mu_static) solved in the same run,
alternating with the frictionless case :data:`FRICTION_REPEATS` times each, on
one thread (BLAS, PARDISO), as the calibration's workers run: the best CPU time
(set-up and solve, the machine being shared) with friction may be at most
:data:`FRICTION_OVER_FRICTIONLESS` times the best without. (On all threads of a
loaded machine the threads' waiting counts as CPU time: one such run measured
2.4 x where one thread measured 1.2 x.)

Run ``python validation/bench_static.py`` (``--quick``: h = 0.15 mm, about
15k DOF); prints DOF, time per phase and peak memory, writes
``out/bench_static/bench_static.json`` and exits 1 when a ratio is missed.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from dataclasses import replace
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.linalg import limit_threads
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_json
from fe_impact.solvers.static import StaticSolver
from validation import checks as ck
from validation.hertz_static import DISPLACEMENTS, specimen_mesh
from validation.impact_cases import sphere_block_case

H_CONTACT = 0.092e-3  # gives ~31.6k DOF with the hertz_static specimen
QUICK_H_CONTACT = 0.15e-3
REFERENCE_S = 230.0
#: 20 s target / 1.6 s assembly + factorisation (see the module docstring).
OVER_LINEAR_SOLVE = 12.0
#: friction may cost at most 30% (the issue's), friction on against off in one run
FRICTION_OVER_FRICTIONLESS = 1.3
#: the seed's greased flanks (eqs. 9-10)
MU_STATIC, MU_DYNAMIC = 0.05, 0.02
#: solves of each side (frictionless, with friction), alternated, for the friction ratio
FRICTION_REPEATS = 3


def run(quick: bool = False, out: str | Path = "out/bench_static",
        h_contact: float | None = None) -> dict:
    """Time the static solve; ``h_contact`` overrides the mesh size."""
    out = Path(out)
    h = h_contact or (QUICK_H_CONTACT if quick else H_CONTACT)
    mesh_file = specimen_mesh(out, h)
    case = sphere_block_case(mesh_file, DISPLACEMENTS)
    wall, result = _timed(case, mesh_file)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB -> MiB
    # The baseline: the solve's own assembly and factorisation phases, timed in
    # the same process within the same minute, so the load of the shared
    # machine weighs on both sides alike.
    linear = result.timings["assembly"] + result.timings["factorisation"]
    record = {"n_dofs": result.info["n_dofs"], "n_contact_dofs": result.info["n_contact_dofs"],
              "increments": len(result.steps), "wall_s": wall, "phases_s": result.timings,
              "peak_rss_MiB": peak, "reference_s": REFERENCE_S,
              "speedup_vs_reference": REFERENCE_S / wall,
              "linear_solve_s": linear, "over_linear_solve": wall / linear,
              "target_ratio": OVER_LINEAR_SOLVE,
              "force_full_load_N": 4 * result.steps[-1].contact_force[0]}
    rough = replace(case, contacts=(replace(case.contacts[0], mu_static=MU_STATIC,
                                            mu_dynamic=MU_DYNAMIC),))
    off, on = [], []
    with limit_threads(1):
        for _ in range(FRICTION_REPEATS):
            off.append(_cpu(case, mesh_file)[0])
            on.append(_cpu(rough, mesh_file))
    cpu_0 = min(off)
    cpu_f, result_f = min(on, key=lambda x: x[0])
    record["friction"] = {
        "cpu_s": cpu_f, "frictionless_cpu_s": cpu_0, "phases_s": result_f.timings,
        "runs_cpu_s": [x[0] for x in on], "frictionless_runs_cpu_s": off,
        "threads": 1, "n_contact_dofs": result_f.info["n_contact_dofs"],
        "over_frictionless": cpu_f / cpu_0, "target_ratio": FRICTION_OVER_FRICTIONLESS,
        "force_full_load_N": 4 * result_f.steps[-1].contact_force[0],
        "friction_dissipation_J": 4 * result_f.steps[-1].friction_dissipation}
    write_json(out / "bench_static.json", record)
    return record


def _cpu(case, mesh_file: Path):
    """CPU time of set-up and solve from the loaded mesh, and the result."""
    c0 = time.process_time()
    _, result = _timed(case, mesh_file)
    return time.process_time() - c0, result


def _timed(case, mesh_file: Path):
    """Wall time of set-up and solve from the loaded mesh, and the result."""
    mesh = load_mesh(mesh_file)
    t0 = time.perf_counter()
    result = StaticSolver(case, mesh).run()
    return time.perf_counter() - t0, result


def check(r: dict) -> list[ck.Check]:
    return [ck.at_most("solve / (assembly + factorisation)", r["over_linear_solve"],
                       OVER_LINEAR_SOLVE),
            ck.at_most("with friction / without", r["friction"]["over_frictionless"],
                       FRICTION_OVER_FRICTIONLESS)]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_static"))
    p.add_argument("--quick", action="store_true", help="h = 0.15 mm (about 15k DOF)")
    args = p.parse_args(argv)
    r = run(args.quick, args.out)
    phases = ", ".join(f"{k} {v:.2f} s" for k, v in r["phases_s"].items())
    print(f"{r['n_dofs']} DOF ({r['n_contact_dofs']} condensed), {r['increments']} increments: "
          f"{r['wall_s']:.1f} s wall ({phases}); peak RSS {r['peak_rss_MiB']:.0f} MiB; "
          f"{r['speedup_vs_reference']:.0f}x faster than the {REFERENCE_S:.0f} s reference; "
          f"{r['over_linear_solve']:.1f} x assembly + factorisation; with friction "
          f"{r['friction']['cpu_s']:.1f} s CPU on one thread against "
          f"{r['friction']['frictionless_cpu_s']:.1f} s without "
          f"({r['friction']['over_frictionless']:.2f} x, best of {FRICTION_REPEATS} each)")
    return ck.finish("bench_static", check(r), args.out)


if __name__ == "__main__":
    sys.exit(main())
