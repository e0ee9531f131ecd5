"""Benchmark: the near-field static tooth pair (six loads) against today's refined FE.

Run ``python validation/bench_nearfield.py`` (a few minutes, most of it the
baseline). Both are measured in the same run, each in a fresh process (one
core, so their peak resident sets are their own): the refined FE is the
mesh cycle's pitch-point position at the default level
(:func:`fe_impact.calibration.meshcycle.run_position`), the near field the
same six forces on the coarse mesh of :mod:`validation.nearfield_pair`.
Writes ``out/bench_nearfield/bench_nearfield.json`` and ``.md``.

The machine is shared, so absolute times are reported, not asserted. It exits
1 when the near field is not faster than the refined FE in the same run (wall
time, meshing included) or uses more memory.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from validation import checks as ck
from validation.nearfield_pair import FORCES


def _near() -> dict:
    from fe_impact.contact import nearfield as nf
    from fe_impact.fe.linalg import limit_threads
    from validation import nearfield_pair as npair

    gs, _ = npair._gearset()
    with tempfile.TemporaryDirectory() as cache, limit_threads(1):
        t0 = time.perf_counter()
        pm = npair.coarse_pair(gs, Path(cache))
        t_mesh = time.perf_counter() - t0
        far, n_dofs, an = npair.near_field_model(gs, pm)
        heights = npair.flank_heights(gs, an)
        far.operator(nf.Grid.centred(1e-3, 1e-4, 2, 2), npair.DEPTH)   # the hat solves
        t_setup = time.perf_counter() - t0 - t_mesh
        approaches, per_force = [], []
        for f in npair.FORCES:
            t = time.perf_counter()
            approaches.append(npair.solve_force(far, an, f, heights=heights)[0].approach)
            per_force.append(time.perf_counter() - t)
        wall = time.perf_counter() - t0
    return {"n_dofs": n_dofs, "wall_s": wall, "mesh_s": t_mesh, "setup_s": t_setup,
            "solve_s": wall - t_mesh - t_setup, "approaches": approaches,
            "per_force_s": per_force, "far_solves": far.solves,
            "peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _refined() -> dict:
    from validation import nearfield_pair as npair

    gs, text = npair._gearset()
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        r = npair.refined_fe(gs, text, Path(cache))
        wall = time.perf_counter() - t0
    return {"n_dofs": r["n_dofs"], "wall_s": wall, "mesh_s": r["timings"]["mesh"],
            "solve_s": r["timings"]["fe"], "approaches": r["approaches"],
            "peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _in_fresh_process(fn):
    with ProcessPoolExecutor(1, mp_context=get_context("spawn"), max_tasks_per_child=1) as ex:
        return ex.submit(fn).result()


def run() -> dict:
    return {"near_field": _in_fresh_process(_near), "refined": _in_fresh_process(_refined)}


def check(r: dict) -> list[ck.Check]:
    nfr, ref = r["near_field"], r["refined"]
    return [ck.at_most("near-field wall time / refined FE's (same run)",
                       nfr["wall_s"] / ref["wall_s"], 1.0),
            ck.at_most("near-field peak RSS / refined FE's", nfr["peak_rss_MiB"]
                       / ref["peak_rss_MiB"], 1.0)]


def report(r: dict) -> str:
    nfr, ref = r["near_field"], r["refined"]
    lines = ["# Static tooth pair, six loads (50 N - 1 kN): near field vs refined FE", "",
             "| | DOFs | wall (s) | mesh (s) | solve (s) | peak RSS (MiB) |",
             "|---|---|---|---|---|---|"]
    for name, x in (("refined FE (default level)", ref), ("near field (coarse mesh)", nfr)):
        lines.append(f"| {name} | {x['n_dofs']} | {x['wall_s']:.1f} | {x['mesh_s']:.1f} "
                     f"| {x['solve_s']:.1f} | {x['peak_rss_MiB']:.0f} |")
    lines += ["", "| force (N) | refined (um) | near field (um) | difference |",
              "|---|---|---|---|"]
    for f, a, b in zip(FORCES, ref["approaches"], nfr["approaches"], strict=True):
        lines.append(f"| {f:g} | {a * 1e6:.4f} | {b * 1e6:.4f} | {b / a - 1:+.2%} |")
    per = nfr["per_force_s"]
    position = nfr["mesh_s"] + nfr["setup_s"] + 5 * sum(per) / len(per)
    lines += ["", "Against issue 47's targets (the rows the near field reaches today):", "",
              "| benchmark | target | near field now | refined FE now |", "|---|---|---|---|",
              f"| one mesh-cycle position (five loads), default level | at most 2 s | "
              f"{position:.1f} s (mesh {nfr['mesh_s']:.1f} s, set-up and "
              f"{nfr['far_solves']} hat solves {nfr['setup_s']:.1f} s, "
              f"{sum(per) / len(per):.1f} s a load) | {ref['wall_s'] * 5 / 6:.1f} s "
              f"(six loads {ref['wall_s']:.1f} s) |",
              "| one default flank impact; one approach-corner impact; make run; "
              "CalculiX pair | 8 s; 60 s; 8 min; 50x | not measured: the near field is not "
              "behind the solvers | - |", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_nearfield"))
    args = p.parse_args(argv)
    r = run()
    checks = check(r)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_nearfield.json").write_text(json.dumps(r, indent=1))
    text = report(r) + "\n## Checks\n\n" + ck.markdown(checks)
    (args.out / "bench_nearfield.md").write_text(text)
    print(text)
    return ck.finish("bench_nearfield", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
