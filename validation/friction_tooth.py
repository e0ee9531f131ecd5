"""What the seed's flank friction changes in a tooth impact (a measurement, no check).

Run ``python validation/friction_tooth.py --out out/friction_tooth``
(``--level``: the mesh level, default coarse). The first case of the default
calibration (stage 1 in mesh at 100 r/min, the gear set's material, Newmark)
is run twice on one mesh: frictionless, and with the seed's greased flanks
(eqs. 9-10: mu_static 0.05, mu_dynamic 0.02, transition 0.01 m/s). Written:
peak force, contact duration, restitution, the friction's dissipation and the
relative change of each, in ``friction_tooth.json``. The calibration itself
stays frictionless (its gear-set keys are not there yet); this is the
measurement of what friction would change.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.output.files import write_json

MU_STATIC, MU_DYNAMIC, TRANSITION = 0.05, 0.02, 0.01
SPEED_RPM = 100.0


def run(level: str = "coarse", out: str | Path = "out/friction_tooth") -> dict:
    from fe_impact.calibration.sweep import (
        GAP_FRACTION,
        MAX_GAP,
        Settings,
        calibration_case,
        plan_cases,
    )
    from fe_impact.fe.linalg import limit_threads
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.gears import default_gearset
    from fe_impact.gears.pairanalysis import hertz_impact_estimate
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.solvers.dynamic import DynamicSolver

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    gearset = default_gearset()
    case = plan_cases(gearset, [1], [SPEED_RPM])[0]
    settings = Settings(level=level)
    est = hertz_impact_estimate(gearset, case.stage, settings.roll_angle_deg, case.impact_speed)
    gap = min(MAX_GAP, GAP_FRACTION * est.delta_max)
    runs = {}
    with limit_threads(1):
        pair = build_pair(gearset, case.stage, settings.roll_angle_deg, level, settings.order,
                          gap, case.impact_speed, out / "mesh")
        fe_case = calibration_case(pair, settings)
        rough = replace(fe_case, contacts=tuple(
            replace(c, mu_static=MU_STATIC, mu_dynamic=MU_DYNAMIC, transition_speed=TRANSITION)
            for c in fe_case.contacts))
        for name, c in (("frictionless", fe_case), ("friction", rough)):
            t = time.process_time()
            res = DynamicSolver(c, load_mesh(c.mesh_file, c.unit)).run()
            m = res.measurements
            runs[name] = {"peak_force_N": m.peak_force, "contact_duration_s": m.contact_duration,
                          "restitution": m.restitution, "energy_error": m.energy_error,
                          "friction_dissipation_J": float(res.history["friction_dissipation"][-1]),
                          "initial_energy_J": float(res.history["total_energy"][0]),
                          "cpu_s": time.process_time() - t}
    change = {k: runs["friction"][k] / runs["frictionless"][k] - 1.0
              for k in ("peak_force_N", "contact_duration_s", "restitution")
              if runs["frictionless"][k]}
    record = {"level": level, "stage": case.stage, "speed_rpm": SPEED_RPM,
              "impact_speed_m_s": case.impact_speed, "mu_static": MU_STATIC,
              "mu_dynamic": MU_DYNAMIC, "runs": runs, "relative_change": change}
    write_json(out / "friction_tooth.json", record)
    return record


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/friction_tooth"))
    p.add_argument("--level", default="coarse")
    args = p.parse_args(argv)
    print(json.dumps(run(args.level, args.out), indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
