"""Static tooth-pair benchmark: one mesh-cycle position, phase by phase.

Run ``python validation/bench_static_pair.py`` (under a minute; ``--quick``
on the coarse level). The case is what the mesh cycle solves at every
position: stage 1 of the built-in gear set at the pitch point, the pinion
pressed by torque at six normal forces from 3 N to 1 kN
(:func:`fe_impact.calibration.meshcycle.run_position`, one core). It meshes
afresh and reports the phases (mesh, assembly, factorisation, condensation,
load steps), the projections per load step, the largest resident set and
the approaches, and writes ``out/bench_static_pair/bench_static_pair.json``.

The speed issue's target for this solve is 10 s and 2 GB at the default
level; the machine is shared, so absolute times are reported, not asserted.
It exits 1 on what does not depend on the machine or is a ratio measured in
the same run:

- the projections per load step (:data:`MAX_PROJECTIONS`): the projection
  iteration contracts by about 1e-3 a step on a tooth pair, so from the last
  load step's state the third projection is within the tolerance of 1e-6
  and its estimate says so;
- at the default level, the load steps' time against the factorisation's
  (:data:`STEPS_OVER_FACTOR`): a projection costs one backward substitution
  (half a solve, about a fiftieth of the factorisation at 100k DOFs) and one
  projection of the zone, so the 18 of six load steps cost under one
  factorisation. The factorisation grows faster than linearly with the
  DOFs and the projection does not, so the ratio says nothing at the coarse
  level (``--quick``, 38k DOFs: measured 1.6), where it is reported only.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json
from validation import checks as ck

FORCES = (3.0, 50.0, 100.0, 200.0, 500.0, 1000.0)   # N
#: Mean projections per load step at most this (measured 2.7 on the coarse and
#: default levels: three from the last step's state, two at the first load).
MAX_PROJECTIONS = 3.5
#: At the default level, the load steps' wall time at most this multiple of
#: the factorisation's (measured 0.97, and 1.9 before the projection hints and
#: the backward-only substitutions).
STEPS_OVER_FACTOR = 1.5


def run(quick: bool, out: Path | None = None) -> dict:
    """Mesh and solve the case; its figures (``out`` is not written: :func:`main` does)."""
    from fe_impact.calibration import meshcycle as mc
    from fe_impact.gears import default_gearset
    from fe_impact.gears.gearset import default_gearset_path

    text = default_gearset_path().read_text(encoding="utf-8-sig")
    gs = default_gearset()
    level = "coarse" if quick else "default"
    case = mc.PositionCase(1, gs.stages[0].teeth, 0.0, FORCES, "")
    with tempfile.TemporaryDirectory() as cache:
        t = time.perf_counter()
        rec = mc.run_position(case, level, 2, text, cache)
        wall = time.perf_counter() - t
        # the projections of each load step, from a second solve on the cached mesh
        iterations = _iterations(case, level, text, cache)
    timing = rec.timings_s
    return {"level": level, "n_dofs": rec.n_dofs, "forces_N": list(FORCES),
            "approaches_m": rec.approaches, "stiffness": rec.stiffness,
            "exponent": rec.exponent, "wall_s": wall,
            "fe_s": timing["fe"], "phases_s": {k: timing[k] for k in (
                "mesh", "fe_assembly", "fe_factorisation", "fe_condensation", "fe_steps")},
            "projections_per_step": iterations,
            "peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def _iterations(case, level: str, text: str, cache: str) -> list[int]:
    """Projections of each load step of ``case`` (its mesh is in ``cache``)."""
    import tomllib

    from fe_impact.calibration import meshcycle as mc
    from fe_impact.gears import gearset_from_dict
    from fe_impact.meshing.toothpair import build_pair

    gs = gearset_from_dict(tomllib.loads(text))
    key = mc.case_hash(case, level, 2, text)
    pm = build_pair(gs, case.stage, case.roll_angle_deg, level, 2, mc.PAIR_GAP, 0.1,
                    Path(cache) / "meshes" / f"static_{key}", reuse=True,
                    design_force=max(case.forces))
    _, result = mc.solve_static_pair(gs, pm, case.forces)
    return [s.iterations for s in result.steps]


def check(r: dict) -> list[ck.Check]:
    it = r["projections_per_step"]
    checks = [ck.at_most("projections per load step (mean)", sum(it) / len(it),
                         MAX_PROJECTIONS)]
    if r["level"] == "default":
        checks.append(ck.at_most("load steps / factorisation (wall, same run)",
                                 r["phases_s"]["fe_steps"] / r["phases_s"]["fe_factorisation"],
                                 STEPS_OVER_FACTOR))
    return checks


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_static_pair"))
    p.add_argument("--quick", action="store_true", help="coarse level (about 40k DOFs)")
    args = p.parse_args(argv)
    r = run(args.quick)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "bench_static_pair.json", r)
    phases = ", ".join(f"{k} {v:.2f} s" for k, v in r["phases_s"].items())
    ratio = r["phases_s"]["fe_steps"] / r["phases_s"]["fe_factorisation"]
    print(f"load steps / factorisation {ratio:.2f}")
    print(f"stage 1 pitch point, {r['level']} level, {r['n_dofs']} DOFs, six loads to 1 kN: "
          f"FE {r['fe_s']:.1f} s (target 10 s), {r['wall_s']:.1f} s with the mesh ({phases}); "
          f"peak RSS {r['peak_rss_MiB']:.0f} MiB (target 2 GB); projections per load step "
          f"{r['projections_per_step']}; approach at 1 kN {r['approaches_m'][-1] * 1e6:.4f} um")
    return ck.finish("bench_static_pair", check(r), args.out)


if __name__ == "__main__":
    sys.exit(main())
