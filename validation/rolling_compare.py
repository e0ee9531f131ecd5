"""The lumped torsional model against the rolling FE, on three operating conditions.

Run ``python validation/rolling_compare.py --calibration CAL --out out/rolling_compare``
with ``CAL`` a ``calibration.json`` of the seed set (``fe-impact calibrate --level coarse
--corners --out DIR``; ``make run`` writes ``out/calibration/calibration.json``) and,
for the FE side, ``--fe DIR`` holding one ``fe-impact roll`` output folder per
condition (``DIR/<condition>``). Exit status: 0 when the goal holds on every condition,
1 when it fails on one, 2 when the FE side (or the calibration) is not available: then
the lumped side alone is computed, printed and written, and nothing is asserted.

Conditions (the seed set, stage 1 unless ``--stage``, one pinion on one face-gear rotor
of the stage's inertia, the pinion at constant speed, the stage's default backlash):

- ``loaded-1000``: 1000 r/min, 50 N m on the face gear (634 N a mesh on stage 1, inside
  the mesh cycle's calibrated forces 50-1000 N): a tooth pair enters on the face
  gear's rounded tip edge every mesh period (mesh-in impacts);
- ``rattle-300``: 300 r/min, no load: the mesh rattles in its backlash;
- ``noload-1000``: 1000 r/min, no load.

The no-load cases need an excitation: a kinematic transmission error of
`TE_AMPLITUDE` at mesh frequency and a drag of `DRAG` on the face gear (the lumped
model's defaults, `fe_impact.switching.model.DriveModel`); the FE must run with the same
(`RollingCondition`). Each condition runs ``--cycles`` mesh periods (the FE's own
duration when its record is there), the first ``--settle`` periods left out.

Compared per condition (`fe_impact.rolling.compare.COMPARED`): the mean-removed TE's
peak-to-peak and RMS and its amplitudes at mesh orders 1-4 (whole periods, exact DFT
bins), the peak mesh-in force (median and largest), the mesh-in closing speeds, the
number of mesh-in and rattle impacts, the mean mesh force. The lumped model runs twice:
on the calibration's laws and on the seed's closed forms.

Goal (issue: the lumped model against the rolling FE): on each condition where the
FE has the figure, the calibrated model within `GOAL` (10%) of the rolling FE on the TE
peak-to-peak and RMS and the peak mesh-in force (median and largest), and closer to
it than the closed forms on each.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.errors import FeImpactError
from fe_impact.gears.gearset import GearSet, default_gearset, load_gearset
from fe_impact.rolling.compare import (
    GOAL,
    REFERENCE,
    RollingCondition,
    RollingRecord,
    check_goal,
    comparison_rows,
    goal_lines,
    markdown_table,
    mesh_metrics,
    record_from_roll,
    write_comparison,
)
from fe_impact.rolling.lumped import run_lumped
from validation import checks as ck

logger = logging.getLogger(__name__)

#: Exit status when the FE side (or the calibration) is missing: nothing asserted.
SKIPPED = 2
#: Kinematic transmission error [m] and drag [N m]: the lumped model's defaults.
TE_AMPLITUDE = 1e-6
DRAG = 0.01
#: Load torque of the loaded condition [N m].
LOAD = 50.0
#: (name, pinion speed r/min, load N m) of the three conditions.
CONDITIONS = (("loaded-1000", 1000.0, LOAD), ("rattle-300", 300.0, 0.0),
              ("noload-1000", 1000.0, 0.0))


def conditions(gearset: GearSet, stage: int, cycles: float, settle: float
               ) -> list[RollingCondition]:
    """The three `RollingCondition` of the study on ``stage`` of ``gearset``."""
    backlash = _default_backlash(gearset, stage)
    out = []
    for name, rpm, torque in CONDITIONS:
        period = 60.0 / (gearset.pinion.teeth * rpm)
        out.append(RollingCondition(
            name, stage, rpm, torque, cycles * period, gearset.pinion.inertia,
            gearset.stages[stage - 1].inertia, backlash, transmission_error=TE_AMPLITUDE,
            drag_torque=DRAG, settle=settle * period))
    return out


def _default_backlash(gearset: GearSet, stage: int) -> float:
    from fe_impact.switching.geometry import default_backlash

    p = gearset.pinion
    return float(default_backlash(p.module, p.pitch_radius,
                                  0.5 * gearset.module * gearset.stages[stage - 1].teeth))


def fe_record(condition: RollingCondition, gearset: GearSet, fe: Path | None
              ) -> RollingRecord | None:
    """The rolling FE's record of ``condition`` from ``fe/<name>``; None when absent."""
    if fe is None:
        return None
    folder = fe / condition.name
    try:
        from fe_impact.rolling.run import read_roll  # the rolling FE's reader
    except ImportError:
        logger.warning("the rolling FE's reader (fe_impact.rolling.run.read_roll) is not "
                       "available")
        return None
    if not folder.is_dir():
        logger.warning("no rolling FE output for %s at %s", condition.name, folder)
        return None
    result = read_roll(folder)
    duration = float(result.time_s[-1] - result.time_s[0])
    condition = replace(condition, duration=duration)
    return record_from_roll(result, condition, gearset.pinion.teeth, REFERENCE)


def run(gearset: GearSet, calibration: Path | None, fe: Path | None, stage: int = 1,
        cycles: float = 6.0, settle: float = 1.0) -> dict:
    """Compute the records, metrics and goal checks of every condition.

    Returns
    -------
    dict
        ``records`` (all models, all conditions), ``goal`` (condition -> GoalCheck, only
        where the FE record is there), ``missing`` (what is not available).
    """
    records, goal, missing = [], {}, []
    if calibration is None or not calibration.is_file():
        missing.append(f"calibration file {calibration}")
    for condition in conditions(gearset, stage, cycles, settle):
        fe_side = fe_record(condition, gearset, fe)
        if fe_side is not None:
            condition = fe_side.condition
            records.append(fe_side)
        else:
            missing.append(f"rolling FE of {condition.name}")
        wall = time.perf_counter()
        lumped = {"closed-form": run_lumped(condition, "closed-form", gearset)}
        if calibration is not None and calibration.is_file():
            lumped["calibrated"] = run_lumped(condition, "calibrated", gearset, calibration)
        logger.info("%s: lumped runs %.1f s", condition.name, time.perf_counter() - wall)
        records.extend(lumped.values())
        if fe_side is not None and "calibrated" in lumped:
            goal[condition.name] = check_goal(mesh_metrics(fe_side),
                                              mesh_metrics(lumped["calibrated"]),
                                              mesh_metrics(lumped["closed-form"]))
    return {"records": records, "goal": goal, "missing": missing}


def check(result: dict) -> list[ck.Check]:
    """One check per condition and goal figure: within `GOAL`, and closer than the closed
    forms."""
    out = []
    for name, g in result["goal"].items():
        for figure, rel in g.calibrated.items():
            out.append(ck.holds(f"{name} {figure} calibrated vs FE", rel, g.within[figure],
                                f"|rel| <= {GOAL:g}"))
            out.append(ck.holds(f"{name} {figure} closer than closed forms", rel,
                                g.closer[figure],
                                f"|rel| < closed forms' {abs(g.closed_form[figure]):.3g}"))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gearset", nargs="?", help="gear-set TOML (default: the seed set)")
    parser.add_argument("--calibration", type=Path,
                        default=Path("out/calibration/calibration.json"))
    parser.add_argument("--fe", type=Path, help="folder of the rolling FE's outputs, one "
                        "sub-folder per condition")
    parser.add_argument("--stage", type=int, default=1)
    parser.add_argument("--cycles", type=float, default=6.0,
                        help="mesh periods simulated when there is no FE record (default 6)")
    parser.add_argument("--settle", type=float, default=1.0,
                        help="mesh periods left out at the start (default 1)")
    parser.add_argument("--out", type=Path, default=Path("out/rolling_compare"))
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(message)s")
    try:
        gearset = default_gearset() if args.gearset is None else load_gearset(args.gearset)
        if not 1 <= args.stage <= len(gearset.stages):
            raise FeImpactError(f"--stage {args.stage}: the gear set has stages "
                                f"1..{len(gearset.stages)}")
        if not (math.isfinite(args.cycles) and args.cycles > args.settle + 1.0 > 1.0):
            raise FeImpactError(f"--cycles {args.cycles} must exceed --settle "
                                f"{args.settle} (>= 0) by one mesh period or more")
        result = run(gearset, args.calibration, args.fe, args.stage, args.cycles, args.settle)
    except FeImpactError as exc:
        print(f"rolling_compare: {exc}", file=sys.stderr)
        return 1
    write_comparison(args.out, result["records"], goal=result["goal"])
    print(markdown_table(comparison_rows(result["records"])))
    if result["goal"]:
        print(goal_lines(result["goal"]))
    for what in result["missing"]:
        print(f"not available: {what}")
    if result["missing"]:
        print(f"rolling_compare: SKIPPED (exit {SKIPPED}): the goal needs the rolling FE "
              "and a calibration on every condition; the lumped side is in "
              f"{args.out}")
        return SKIPPED
    return ck.finish("rolling_compare", check(result), args.out)


if __name__ == "__main__":
    sys.exit(main())
