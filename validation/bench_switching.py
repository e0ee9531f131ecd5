"""Benchmark: the seed's 15 s variable-speed switching run (section 5.1) in the torsional model.

Three stages at 100, 300 and 1000 r/min, 5 s each, no load, two ratio
switches. Target (issue): at most 10 s wall on a 2-core machine. Run
``python validation/bench_switching.py``; prints the integrator, steps
taken, impacts and wall time (the one-off numba compilation is timed
separately), and writes ``out/bench_switching/bench_switching.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json
from fe_impact.switching import DriveModel, Segment, StageSchedule, get_preset, simulate

TARGET_S = 10.0


def run(out: Path | None = None, duration: float | None = None) -> dict:
    """Time the variable-speed preset; ``duration`` shortens it (coarse checks)."""
    preset = get_preset("variable-speed")
    if duration is not None:
        preset = preset.scaled(duration)
    schedule = preset.cases[0].schedule
    model = DriveModel()
    t0 = time.perf_counter()
    # compile (or load the cached machine code) and build the law tables once
    simulate(model, StageSchedule((Segment(1e-3, 1, 100.0),)))
    warmup = time.perf_counter() - t0
    result = simulate(model, schedule)
    info = result.info
    record = {
        "preset": preset.name,
        "simulated_s": schedule.duration,
        "integrator": info["integrator"],
        "steps": info["steps"],
        "rejected_steps": info["rejected_steps"],
        "rhs_evaluations": info["rhs_evaluations"],
        "impacts": info["impacts"],
        "impacts_by_kind": {k: int((result.events.kind == i).sum())
                            for i, k in enumerate(("rattle", "mesh-in", "switch"))},
        "wall_s": info["wall_s"],
        "warmup_s": warmup,
        "target_s": TARGET_S,
        "steps_per_simulated_s": info["steps"] / schedule.duration,
        "law_source": info["law_source"],
    }
    if out is not None:
        write_json(out / "bench_switching.json", record)
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/bench_switching"))
    p.add_argument("--duration", type=float, default=None,
                   help="simulated time [s] (default: the seed's 15 s)")
    args = p.parse_args(argv)
    r = run(args.out, args.duration)
    print(f"{r['preset']}: {r['simulated_s']:g} s simulated in {r['wall_s']:.2f} s wall "
          f"(target {r['target_s']:g} s; compile/load {r['warmup_s']:.1f} s once)")
    print(f"  {r['integrator']}")
    print(f"  {r['steps']} steps ({r['rejected_steps']} rejected), {r['rhs_evaluations']} "
          f"right-hand sides, {r['impacts']} impacts {r['impacts_by_kind']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
