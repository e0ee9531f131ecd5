"""Tooth impact benchmark: one calibration case from mesh to fit, phase by phase.

Run ``python validation/bench_tooth_impact.py`` (a few minutes; ``--quick``
on the coarse level, under one). The case is the first of the default
calibration: stage 1 in mesh at 100 r/min
(:func:`fe_impact.calibration.sweep.plan_cases`), Newmark, default level,
everything on one core (``limit_threads(1)``, as ``run_case`` does). It
meshes afresh (no cache) and reports each phase's wall and CPU time (mesh,
assembly, contact set-up, factorisation, condensation, steps, output
frames, fit), the back-substitutions of the steps, the largest resident set
of the process and the calibration's measurements (peak force, approach,
contact time, restitution, fitted K and exponent), so that a change can be
compared with the one before it. Writes
``out/bench_tooth_impact/bench_tooth_impact.json``.

Exits 1 only on a ratio measured in the same run (the machine is shared,
absolute times are not targets): the steps' CPU time against the CPU time
of their back-substitutions (a step is its solves with the factorised
system plus the small condensed contact problem, which must not cost more
than the solves themselves; :data:`STEPS_OVER_SOLVES`).
"""

from __future__ import annotations

import argparse
import json
import logging
import resource
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json
from validation import checks as ck

#: The steps' CPU time at most this multiple of their back-substitutions'
#: (each timed in the same run): the rest of a step is the condensed
#: contact problem on a few hundred zone coordinates, the history row and
#: the re-projections, each far smaller than a pass over the factor.
STEPS_OVER_SOLVES = 2.0
SPEED_RPM = 100.0


def _rss_mb() -> float:
    """Largest resident set of this process so far (MB; Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class _Phases:
    """Wall and CPU seconds of named phases."""

    def __init__(self) -> None:
        self.wall: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    @contextmanager
    def __call__(self, name: str):
        w, c = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - w, time.process_time() - c)

    def add(self, name: str, wall: float, cpu: float) -> None:
        self.wall[name] = self.wall.get(name, 0.0) + wall
        self.cpu[name] = self.cpu.get(name, 0.0) + cpu


class _CountingSolve:
    """Wraps a factorisation's ``solve``: counts the calls and their CPU time."""

    def __init__(self, solve) -> None:
        self.solve, self.calls, self.cpu, self.wall = solve, 0, 0.0, 0.0

    def __call__(self, b, *args):
        w, c = time.perf_counter(), time.process_time()
        try:
            return self.solve(b, *args)
        finally:
            self.calls += 1
            self.cpu += time.process_time() - c
            self.wall += time.perf_counter() - w


class _Retries(logging.Handler):
    """Counts the mesh builder's 'meshing again' warnings."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.count = 0

    def emit(self, record: logging.LogRecord) -> None:
        if "meshing again" in record.getMessage():
            self.count += 1


def tooth_impact(level: str, out: Path, frames: bool = True) -> dict:
    """One calibration case, phase by phase (see the module docstring)."""
    from fe_impact.calibration.sweep import (
        GAP_FRACTION,
        MAX_GAP,
        VTU_FRAME_STRIDE,
        Settings,
        calibration_case,
        measure_and_fit,
        plan_cases,
    )
    from fe_impact.fe.linalg import limit_threads
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.gears import default_gearset
    from fe_impact.gears.pairanalysis import hertz_impact_estimate
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.output.results import DynamicWriter
    from fe_impact.solvers.dynamic import DynamicSolver

    gearset = default_gearset()
    case = plan_cases(gearset, [1], [SPEED_RPM])[0]
    settings = Settings(level=level)
    ph = _Phases()
    retries = _Retries()
    logging.getLogger("fe_impact.meshing").addHandler(retries)
    with limit_threads(1), tempfile.TemporaryDirectory(dir=out) as tmp:
        with ph("mesh"):
            est = hertz_impact_estimate(gearset, case.stage, settings.roll_angle_deg,
                                        case.impact_speed)
            gap = min(MAX_GAP, GAP_FRACTION * est.delta_max)
            pair = build_pair(gearset, case.stage, settings.roll_angle_deg, level,
                              settings.order, gap, case.impact_speed, Path(tmp) / "mesh")
        rss_mesh = _rss_mb()
        w, c = time.perf_counter(), time.process_time()
        fe_case = calibration_case(pair, settings)
        solver = DynamicSolver(fe_case, load_mesh(fe_case.mesh_file, fe_case.unit))
        setup_wall, setup_cpu = time.perf_counter() - w, time.process_time() - c
        parts = ("assembly", "contact_setup", "factorisation", "condensation")
        for k in parts:
            ph.add(k, solver.timings[k], solver.cpu_timings[k])
        ph.add("setup_other", setup_wall - sum(solver.timings[k] for k in parts),
               setup_cpu - sum(solver.cpu_timings[k] for k in parts))
        rss_setup = _rss_mb()
        zone = solver.condensed.solver
        counting = _CountingSolve(zone.solve)
        zone.solve = counting
        # A step in contact may split its solve into a forward and a backward
        # substitution around the zone's Schur system: the pair is one solve.
        halves = [_CountingSolve(zone.forward), _CountingSolve(zone.backward)]
        zone.forward, zone.backward = halves
        writer = DynamicWriter(Path(tmp) / "fe", fe_case, solver.mesh, solver.model.material)
        frame_time = _Phases()

        def frame(f) -> None:
            if frames:
                with frame_time("frames"):
                    writer.frame(f)

        w, c = time.perf_counter(), time.process_time()
        result = solver.run(frame_hook=frame, frame_stride=VTU_FRAME_STRIDE)
        with frame_time("frames"):
            writer.finish(result)
        run_wall, run_cpu = time.perf_counter() - w, time.process_time() - c
        fw, fc = frame_time.wall.get("frames", 0.0), frame_time.cpu.get("frames", 0.0)
        ph.add("frames", fw, fc)
        ph.add("steps", run_wall - fw, run_cpu - fc)
        with ph("fit"):
            record = measure_and_fit(case, result, solver.effective_mass, settings, pair,
                                     gearset.material)
        # one back-substitution, timed apart from the run
        rhs = np.random.default_rng(0).standard_normal(solver.kin.n)
        one = _CountingSolve(counting.solve)
        for _ in range(5):
            one(rhs)
    logging.getLogger("fe_impact.meshing").removeHandler(retries)
    fe = record.fe
    steps = result.info["steps"]
    return {
        "level": level,
        "case": case.id,
        "n_dofs": result.info["n_dofs"],
        "mesh_retries": retries.count,
        "stretch_factor": pair.stats.element_sizes.get("factor"),
        "steps": steps,
        "frames": len(writer.frames),
        "contact_zone_nodes": result.info["contact_zone_nodes"],
        "projections": result.info["projections"],
        "zone_growths": result.info["zone_growths"],
        "time_step": result.info["time_step"],
        "cpu_s": {**ph.cpu, "total": sum(ph.cpu.values())},
        "wall_s": {**ph.wall, "total": sum(ph.wall.values())},
        "max_rss_mb": {"after_mesh": rss_mesh, "after_setup": rss_setup, "end": _rss_mb()},
        "solves": counting.calls + halves[0].calls,
        "solves_cpu_s": counting.cpu + halves[0].cpu + halves[1].cpu,
        "solve_cpu_s": one.cpu / one.calls,
        "solves_per_step": (counting.calls + halves[0].calls) / max(steps, 1),
        "steps_over_solves": ph.cpu["steps"] / max(counting.cpu + halves[0].cpu
                                                    + halves[1].cpu, 1e-12),
        "measurements": {"peak_force": fe.peak_force, "max_approach": fe.max_approach,
                         "contact_time": fe.contact_time,
                         "restitution": fe.restitution_measured,
                         "stiffness_k": fe.stiffness_k,
                         "stiffness_exponent": fe.stiffness_exponent,
                         "energy_error": fe.energy_error,
                         "impact_k": record.impact.k,
                         "impact_exponent": record.impact.exponent},
    }


def run(quick: bool = False, out: str | Path = "out/bench_tooth_impact",
        frames: bool = True) -> dict:
    """The default-level case (``quick``: the coarse one)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return {"quick": quick, "impact": tooth_impact("coarse" if quick else "default", out,
                                                   frames)}


def check(result: dict) -> list[ck.Check]:
    """The steps against their back-substitutions (see :data:`STEPS_OVER_SOLVES`)."""
    return [ck.at_most("steps CPU / their back-substitutions' CPU",
                       result["impact"]["steps_over_solves"], STEPS_OVER_SOLVES)]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_tooth_impact"))
    p.add_argument("--quick", action="store_true", help="the coarse level")
    p.add_argument("--no-frames", action="store_true", help="write no VTU frames")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(args.quick, args.out, not args.no_frames)
    checks = check(result)
    write_json(args.out / "bench_tooth_impact.json", result)
    print(json.dumps(result, indent=2))
    return ck.finish("bench_tooth_impact", checks, args.out)


if __name__ == "__main__":
    sys.exit(main())
