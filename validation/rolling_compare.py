"""The lumped torsional model against the rolling FE, on three operating conditions.

Run ``python validation/rolling_compare.py validation/rolling_compare_elastic.toml
--calibration CAL --fe DIR --run-fe --out out/rolling_compare`` with ``CAL`` the
``calibration.json`` of ``fe-impact calibrate validation/rolling_compare_elastic.toml
--level coarse --stages 1 --corners --corner-impacts --out D`` (19 minutes on two
workers, mostly its two approach-corner impacts): the seed set as the rolling FE models
it, elastic and frictionless, so that the calibration's FE impacts, the tip edges' among
them, hold the same material as the rolling sectors. A calibration of the seed set
itself (yield strength 835 MPa) gives the tip-edge laws the plastic dissipation of its
corner impacts, which the elastic rolling FE cannot have; without ``--corner-impacts``
their laws take the closed-form restitution, which dissipates most of a mesh-in.
``--run-fe`` runs the rolling FE (`fe_impact.rolling.api.roll`, coarse) of each
condition whose record is not yet in ``DIR/<condition>/record.json`` and keeps it there;
without it, the records already there are used. The lumped runs take about a second
each. Exit status: 0 when the goal holds on every condition, 1 when it fails on one, 2
when the FE side (or the calibration) is not available: then the lumped side alone is
computed, printed and written, and nothing is asserted.

Conditions (the seed set, stage 1 unless ``--stage``, one pinion on one face-gear rotor
of the stage's inertia, the pinion at constant speed from t = 0, the face gear at the
conjugate speed touching its drive flank at zero force, the stage's default backlash,
`CYCLES` mesh periods: what the FE's 5-tooth sectors hold; ``--teeth N`` (4..7, default
`STUDY_TEETH` = 7) sectors hold ``N - 5`` more, and the runs are that much longer,
`cycles_for`):

- ``loaded-1000``: 1000 r/min, 50 N m on the face gear rising as ``sin^2`` over the
  first period (634 N a mesh on stage 1, inside the mesh cycle's calibrated forces
  50-1000 N): a tooth pair enters on the face gear's rounded tip edge every mesh
  period (mesh-in impacts); the ramp's period is left out;
- ``rattle-300``: 300 r/min, no load: the mesh rattles in its backlash;
- ``noload-1000``: 1000 r/min, no load.

The no-load cases need an excitation: a kinematic transmission error of
`TE_AMPLITUDE` at mesh frequency and a drag of `DRAG` on the face gear (the lumped
model's defaults, `fe_impact.switching.model.DriveModel`), both models alike. The
tooth pairs start where `MESH_PHASE` puts them; the lumped model's planar path of
contact need not place a pair's first touch at the same pinion angle as the FE's
contact analysis, so the lumped pairs are then shifted by the offset of the two models'
mesh-in impacts on the first condition that has them (printed), on every condition.

Compared per condition (`fe_impact.rolling.compare.COMPARED`): the mean-removed TE's
peak-to-peak and RMS and its amplitudes at mesh orders 1-4 (whole periods, exact DFT
bins), the peak mesh-in force (median and largest), the mesh-in closing speeds, the
number of mesh-in and rattle impacts, the largest rattle's force and closing speed,
the mean mesh force; below the table, what each model's figures rest on
(`fe_impact.rolling.compare.basis_lines`: figures set by one impact are named). The
lumped model runs twice: on the calibration's laws and on the seed's closed forms.

Two more lumped runs are shown beside them and left out of the goal. One on the
calibrated laws with no damping in the tip-edge (mesh-in) laws: the rolling FE is
elastic, so it cannot dissipate what the tip-edge laws' restitution (closed form, with
plasticity, unless the calibration ran the FE corner impacts on an elastic set) takes
out of a mesh-in, and this run shows how much of a difference that part makes. One on
the calibrated laws with each mesh-cycle position's law fitted up to 50 N instead of
from 50 N up (`low_force_model`): the unloaded conditions' rattles peak at 3-20 N a
pair, below the calibration's fits, the loaded condition's forces above.

Goal (issue: the lumped model against the rolling FE): on each condition where the
FE has the figure, the calibrated model within `GOAL` (10%) of the rolling FE on the TE
peak-to-peak and RMS and the peak mesh-in force (median and largest), and closer to
it than the closed forms on each.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fe_impact.calibration.meshcycle import FIT_MIN_FORCE, fit_power_law
from fe_impact.errors import FeImpactError
from fe_impact.gears.gearset import GearSet, default_gearset, load_gearset
from fe_impact.rolling.compare import (
    GOAL,
    REFERENCE,
    RollingCondition,
    RollingRecord,
    basis_lines,
    check_goal,
    comparison_rows,
    goal_lines,
    markdown_table,
    mesh_metrics,
    phase_offset,
    read_record,
    record_from_roll,
    write_comparison,
    write_record,
)
from fe_impact.rolling.lumped import lumped_model, run_lumped, run_model
from fe_impact.rolling.sectors import SECTOR_TEETH, check_teeth, tooth_range
from validation import checks as ck

logger = logging.getLogger(__name__)

#: Exit status when the FE side (or the calibration) is missing: nothing asserted.
SKIPPED = 2
#: Kinematic transmission error of the no-load conditions [m] and drag on the face gear
#: [N m]: the lumped model's defaults. The drag is given as load torque (the rolling FE
#: has no drag of its own), so both models ramp it alike.
TE_AMPLITUDE = 1e-6
DRAG = 0.01
#: Load torque of the loaded condition [N m].
LOAD = 50.0
#: Mesh periods the rolling FE's sectors hold (5 teeth each: 2.47 cycles; each added
#: tooth adds one, `cycles_for`).
CYCLES = 2.4
#: Teeth of each of the rolling FE's sectors by default (`fe-impact roll`'s), the ones
#: `CYCLES` and `FE_PAIR_OFFSET` are counted for.
TEETH = SECTOR_TEETH
#: Teeth of each sector this study runs unless told (``--teeth``): 7 hold 4.4 periods,
#: so that the loaded condition's figures rest on three mesh-ins after the load ramp,
#: not on one (5 teeth: 2.4 periods, one mesh-in).
STUDY_TEETH = 7
#: The records' name of the diagnostic run on position laws fitted at low force
#: (`low_force_model`).
LOW_FORCE_SOURCE = "lumped, calibrated, position laws up to 50 N"
#: Pair 0 this many base pitches past the path's start at t = 0: a pair then enters at
#: about 0.08, 1.08 and 2.08 cycles, so the pair entering after the 1-cycle load ramp
#: passes its single-contact zone (0.76-1 period after entry, contact ratio 1.76), where
#: its force peaks, before the run ends.
MESH_PHASE = 0.85
#: The rolling FE numbers its pairs from a tooth two pitches earlier (5-tooth sectors):
#: the same mesh phase is ``MESH_PHASE - 2`` there, which the sectors' window (from
#: -1.22 on the seed set's coarse sectors) holds for `CYCLES`. The window begins a
#: pitch earlier for each tooth past tooth 3 (`pair_offset`).
FE_PAIR_OFFSET = 2
#: Time steps per mesh period of the rolling FE: 8 or more per Hertz contact time of its
#: fastest mesh-in (`fe_impact.rolling.api.STEPS_PER_CONTACT`; the FE asks 363 at 300 r/min).
FE_STEPS = {"loaded-1000": 240, "rattle-300": 400, "noload-1000": 240}
#: (name, pinion speed r/min, load N m, kinematic TE m, load ramp and settling time in
#: mesh periods) of the three conditions.
CONDITIONS = (("loaded-1000", 1000.0, LOAD, 0.0, 1.0, 1.0),
              ("rattle-300", 300.0, 0.0, TE_AMPLITUDE, 0.0, 0.4),
              ("noload-1000", 1000.0, 0.0, TE_AMPLITUDE, 0.0, 0.4))


def cycles_for(teeth: int) -> float:
    """Mesh periods run with sectors of ``teeth`` teeth: `CYCLES` and one more for each
    tooth past 5 (the window grows by a base pitch a tooth)."""
    return CYCLES + (teeth - TEETH)


def pair_offset(teeth: int) -> int:
    """`FE_PAIR_OFFSET` for sectors of ``teeth`` teeth: the window's start moves a pitch
    earlier with each tooth past tooth 3 (the last one of the 5-tooth sectors)."""
    return FE_PAIR_OFFSET + max(tooth_range(teeth)) - max(tooth_range(TEETH))


def conditions(gearset: GearSet, stage: int, cycles: float = CYCLES, friction: bool = False
               ) -> list[RollingCondition]:
    """The three `RollingCondition` of the study on ``stage`` of ``gearset``; with
    ``friction`` the flanks have the gear set's coefficients in both models (the names
    end in ``-friction``, so that their FE records are kept apart)."""
    backlash = _default_backlash(gearset, stage)
    out = []
    for name, rpm, torque, te, ramp, settle in CONDITIONS:
        period = 60.0 / (gearset.pinion.teeth * rpm)
        out.append(RollingCondition(
            f"{name}-friction" if friction else name, stage, rpm, torque + DRAG,
            cycles * period, gearset.pinion.inertia, gearset.stages[stage - 1].inertia,
            backlash, transmission_error=te,
            settle=settle * period, load_ramp=ramp * period, mesh_phase=MESH_PHASE,
            friction=friction))
    return out


def _default_backlash(gearset: GearSet, stage: int) -> float:
    from fe_impact.switching.geometry import default_backlash

    p = gearset.pinion
    return float(default_backlash(p.module, p.pitch_radius,
                                  0.5 * gearset.module * gearset.stages[stage - 1].teeth))


def fe_record(condition: RollingCondition, gearset: GearSet, fe: Path | None,
              run_fe: bool = False, level: str = "coarse", teeth: int = TEETH
              ) -> RollingRecord | None:
    """The rolling FE's record of ``condition``: ``fe/<name>/record.json`` if there, else
    (``run_fe``) a rolling run written there; None when neither."""
    if fe is None:
        return None
    path = fe / condition.name / "record.json"
    if path.is_file():
        record = read_record(path)
        kept = int(record.info.get("inputs", {}).get("teeth", TEETH))
        if kept != teeth or not math.isclose(record.condition.duration, condition.duration,
                                             rel_tol=1e-6):
            raise FeImpactError(
                f"--fe {fe}: {path} is a run of {kept}-tooth sectors over "
                f"{record.condition.duration * 1e3:.4g} ms, this comparison asks "
                f"--teeth {teeth} over {condition.duration * 1e3:.4g} ms (--cycles); give "
                "another --fe folder for these")
        return record
    if not run_fe:
        logger.warning("no rolling FE record for %s at %s (run with --run-fe)",
                       condition.name, path)
        return None
    from fe_impact.rolling.api import RollInputs, roll

    period = 1.0 / condition.mesh_frequency(gearset.pinion.teeth)
    inputs = RollInputs(stage=condition.stage, speed_rpm=condition.speed_rpm,
                        steps_per_cycle=FE_STEPS[condition.name.removesuffix("-friction")],
                        torque_nm=condition.torque + condition.drag_torque,
                        cycles=condition.duration / period, level=level,
                        ramp_cycles=condition.load_ramp / period,
                        te_amplitude=condition.transmission_error,
                        friction=condition.friction,     # the same flanks as the lumped run
                        teeth=teeth,
                        start_cycles=condition.mesh_phase - pair_offset(teeth))
    wall = time.perf_counter()
    # the record is what the comparison needs: the run's own files (frames, plots) are
    # not written; the sector mesh is made once for every condition
    try:
        result = roll(gearset, inputs, mesh_dir=fe / "mesh")
    except FeImpactError as exc:
        logger.warning("rolling FE of %s: %s", condition.name, exc)
        return None
    logger.info("%s: rolling FE %.0f s", condition.name, time.perf_counter() - wall)
    backlash = result.info.get("backlash_m")
    if backlash:
        condition = replace(condition, backlash=float(backlash))
    record = record_from_roll(result, condition, gearset.pinion.teeth, REFERENCE)
    write_record(path, record)
    return record


def run(gearset: GearSet, calibration: Path | None, fe: Path | None, stage: int = 1,
        cycles: float | None = None, run_fe: bool = False, level: str = "coarse",
        friction: bool = False, teeth: int = STUDY_TEETH) -> dict:
    """Compute the records, metrics and goal checks of every condition (over ``cycles``
    mesh periods; default: what sectors of ``teeth`` teeth hold, `cycles_for`).

    Returns
    -------
    dict
        ``records`` (all models, all conditions), ``goal`` (condition -> GoalCheck, only
        where the FE record is there), ``missing`` (what is not available).
    """
    if cycles is None:
        cycles = cycles_for(teeth)
    records, goal, missing = [], {}, []
    if calibration is None or not calibration.is_file():
        missing.append(f"calibration file {calibration}")
    shift = math.nan
    for condition in conditions(gearset, stage, cycles, friction):
        fe_side = fe_record(condition, gearset, fe, run_fe, level, teeth)
        if fe_side is not None:
            condition = fe_side.condition
            records.append(fe_side)
            if math.isnan(shift):
                shift = phase_offset(fe_side, run_lumped(condition, "closed-form", gearset))
                if not math.isnan(shift):
                    logger.warning("tooth pairs placed as the rolling FE's: the lumped "
                                   "model's mesh-in fell %.3f of a period early on %s; its "
                                   "mesh_phase moved by that on every condition", shift,
                                   condition.name)
            if not math.isnan(shift):
                condition = replace(condition, mesh_phase=(condition.mesh_phase + shift) % 1)
        else:
            missing.append(f"rolling FE of {condition.name}")
        wall = time.perf_counter()
        lumped = {"closed-form": run_lumped(condition, "closed-form", gearset)}
        if calibration is not None and calibration.is_file():
            lumped["calibrated"] = run_lumped(condition, "calibrated", gearset, calibration)
            # a diagnostic, not in the goal: the same laws with undamped tip edges, as
            # the elastic FE has them, to tell the mesh-in laws' dissipation apart
            lumped["undamped tip edges"] = run_lumped(condition, "calibrated", gearset,
                                                      calibration, tip_edge_damping=False)
            # a diagnostic too: the mesh cycle's position laws fitted below the
            # calibration's range, where the unloaded conditions' forces lie
            low = low_force_model(condition, gearset, calibration)
            if low is not None:
                lumped["low-force laws"] = run_model(condition, low, gearset, LOW_FORCE_SOURCE)
        logger.info("%s: lumped runs %.1f s", condition.name, time.perf_counter() - wall)
        records.extend(lumped.values())
        if fe_side is not None and "calibrated" in lumped:
            goal[condition.name] = check_goal(mesh_metrics(fe_side),
                                              mesh_metrics(lumped["calibrated"]),
                                              mesh_metrics(lumped["closed-form"]))
    return {"records": records, "goal": goal, "missing": missing, "phase_shift": shift}


def low_force_model(condition: RollingCondition, gearset: GearSet, calibration: Path):
    """The calibrated lumped model of ``condition`` with each mesh-cycle position's law
    fitted to its load-approach curve up to `FIT_MIN_FORCE` (the nominal load, modelled
    as Hertz plus the FE's linear compliance where its patch is narrower than an
    element, and the first FE step at 50 N), not from it up: the forces of the
    unloaded conditions' rattles (3-20 N a pair) lie below the calibration's fits.
    None without the calibration's ``mesh_cycle.json`` or a position law."""
    path = calibration.parent / "mesh_cycle.json"
    model = lumped_model(condition, gearset, calibration)
    laws = model.law_set
    if not path.is_file() or 1 not in laws.positions:
        return None
    curves = {round(p["roll_angle_deg"], 6): p for p in json.loads(path.read_text())["positions"]
              if p["stage"] == condition.stage and not p.get("companion")}
    roll, k, n = laws.positions[1]
    fits = []
    for angle in roll:
        curve = curves.get(round(float(angle), 6))
        if curve is None:
            return None
        force, approach = np.array(curve["forces"]), np.array(curve["approaches"])
        low = force <= FIT_MIN_FORCE * (1.0 + 1e-3)
        fits.append(fit_power_law(force[low], approach[low])[:2])
    k_low, n_low = (np.array(v) for v in zip(*fits, strict=True))
    return model.with_laws(replace(laws, positions={1: (roll, k_low, n_low)},
                                   source=f"{laws.source}; position laws fitted up to "
                                          f"{FIT_MIN_FORCE:g} N"))


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
    parser.add_argument("--fe", type=Path, help="folder of the rolling FE's records, one "
                        "sub-folder per condition (<name>/record.json)")
    parser.add_argument("--run-fe", action="store_true", help="run the rolling FE of the "
                        "conditions whose record is not in --fe yet, and keep it there")
    parser.add_argument("--level", default="coarse", help="mesh level of the rolling FE")
    parser.add_argument("--stage", type=int, default=1)
    parser.add_argument("--teeth", type=int, default=STUDY_TEETH,
                        help=f"teeth of each of the rolling FE's sectors, 4..7 (default "
                        f"{STUDY_TEETH}: three mesh-ins under load after the ramp)")
    parser.add_argument("--cycles", type=float,
                        help=f"mesh periods simulated (default {CYCLES} with 5 teeth and "
                        "one more for each added tooth, what the FE's sectors hold)")
    parser.add_argument("--friction", action="store_true", help="the gear set's flank "
                        "friction in both models (the calibration should have it too)")
    parser.add_argument("--out", type=Path, default=Path("out/rolling_compare"))
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(message)s")
    try:
        gearset = default_gearset() if args.gearset is None else load_gearset(args.gearset)
        if not 1 <= args.stage <= len(gearset.stages):
            raise FeImpactError(f"--stage {args.stage}: the gear set has stages "
                                f"1..{len(gearset.stages)}")
        check_teeth(args.teeth)
        if args.cycles is None:
            args.cycles = cycles_for(args.teeth)
        if not (math.isfinite(args.cycles) and args.cycles >= 2.0):
            raise FeImpactError(f"--cycles {args.cycles}: give 2 or more (a load ramp of "
                                "one period, then one whole period compared)")
        if args.run_fe and args.fe is None:
            raise FeImpactError("--run-fe needs --fe DIR (where the FE records are kept)")
        result = run(gearset, args.calibration, args.fe, args.stage, args.cycles,
                     args.run_fe, args.level, args.friction, args.teeth)
    except FeImpactError as exc:
        print(f"rolling_compare: {exc}", file=sys.stderr)
        return 1
    write_comparison(args.out, result["records"], goal=result["goal"])
    print(markdown_table(comparison_rows(result["records"])))
    print(basis_lines(result["records"]))
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
