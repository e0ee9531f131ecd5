"""Benchmark: static sphere-on-block contact at about 31.6k DOF (P2), five increments.

Reference point (issue target): a mature open-source FE code needs about
230 s on this kind of machine for this size; target <= 20 s wall including
assembly. Run ``python validation/bench_static.py``; prints DOF, time per
phase and peak memory, and writes ``out/bench_static/bench_static.json``.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.fe.case import load_case
from fe_impact.fe.mesh import load_mesh
from fe_impact.output.files import write_json
from fe_impact.solvers.static import StaticSolver
from validation.hertz_static import write_case

H_CONTACT = 0.092e-3  # gives ~31.6k DOF with the hertz_static specimen
REFERENCE_S = 230.0


def run(out: Path, h_contact: float = H_CONTACT) -> dict:
    case = load_case(write_case(out, h_contact))
    t0 = time.perf_counter()
    solver = StaticSolver(case, load_mesh(case.mesh_file, case.unit))
    result = solver.run()
    wall = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB -> MiB
    record = {"n_dofs": result.info["n_dofs"], "n_contact_dofs": result.info["n_contact_dofs"],
              "increments": len(result.steps), "wall_s": wall, "phases_s": result.timings,
              "peak_rss_MiB": peak, "reference_s": REFERENCE_S,
              "speedup_vs_reference": REFERENCE_S / wall,
              "force_full_load_N": 4 * result.steps[-1].contact_force[0]}
    write_json(out / "bench_static.json", record)
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_static"))
    args = p.parse_args(argv)
    r = run(args.out)
    phases = ", ".join(f"{k} {v:.2f} s" for k, v in r["phases_s"].items())
    print(f"{r['n_dofs']} DOF ({r['n_contact_dofs']} condensed), {r['increments']} increments: "
          f"{r['wall_s']:.1f} s wall ({phases}); peak RSS {r['peak_rss_MiB']:.0f} MiB; "
          f"{r['speedup_vs_reference']:.0f}x faster than the {REFERENCE_S:.0f} s reference")
    return 0


if __name__ == "__main__":
    sys.exit(main())
