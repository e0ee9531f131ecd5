"""The lumped torsional model run on a rolling condition, as a `RollingRecord`.

The rolling FE turns one pinion and one face-gear rotor through mesh at a
constant pinion speed against a load torque on the face gear. The lumped model
(`fe_impact.switching`) is run on the same `RollingCondition`:

- the gear set reduced to the condition's stage (one ring), one pinion
  (``n_pinions = 1``: one mesh, as in the FE);
- the pinion's speed prescribed (constant), the load (at once, or rising as
  ``sin^2`` over the condition's ``load_ramp``) and the drag torque on the output;
  the tooth pairs placed at t = 0 as the condition's ``mesh_phase`` says, and the
  mesh at rest on its drive flank under the load of t = 0 (static equilibrium);
- the face-gear rotor's inertia ``J_g`` split between the ring (``1 - f``) and
  the output that carries the load (``f``, `OUTPUT_SHARE`), joined by the
  model's ring web. The web's mode (about 40 kHz on the seed's stage 1)
  lies far above the mesh harmonics compared, so at those frequencies the two
  turn as one rotor of inertia ``J_g``; an impact sees the ring's ``(1 - f) J_g``;
- the condition's backlash, kinematic transmission error, drag and friction;
- the IMPACT laws of a full calibration (``calibration.json``: flank laws
  against impact speed, the mesh cycle's position law, the tip-edge laws) or
  the closed forms (Hertz stiffness, seed eqs. 13-17), each reduced to the stage.

The record's transmission error is the model's mesh coordinate
``x = r_bp theta_p - r_b2 theta_2`` (ring angle), its flank forces those of the
one mesh, its events the model's impacts (rattle, mesh-in; the model records
no mesh-out).
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np

from fe_impact.errors import CaseError
from fe_impact.gears.gearset import GearSet, default_gearset
from fe_impact.rolling.compare import ContactEvents, RollingCondition, RollingRecord
from fe_impact.switching.calibration import LawSet, closed_form_laws, load_calibration
from fe_impact.switching.model import DriveModel, LoadSeries, Segment, StageSchedule
from fe_impact.switching.simulation import CONTACT_NAMES, KIND_NAMES, simulate

logger = logging.getLogger(__name__)

__all__ = ["LAW_SOURCES", "OUTPUT_SHARE", "lumped_model", "run_lumped", "run_model",
           "stage_gearset", "stage_laws"]

#: Share of the face-gear rotor's inertia put on the lumped model's output (the rest
#: on the ring).
OUTPUT_SHARE = 0.05
#: Samples per mesh period of the record's time series: a peak-to-peak read from samples
#: misses up to ``1 - cos(pi / n)`` of a sine sampled ``n`` times a cycle; the ring after
#: a mesh-in at 1000 r/min (about 2 kHz, 6.3 mesh orders) gets 40 samples a cycle
#: (0.3%; 64 a period gave it 10, 4.9%, and the undamped tip edges' TE peak-to-peak
#: 1.2% below its converged value).
SAMPLES_PER_PERIOD = 256
#: Samples of a load ramp (`load_series`).
RAMP_POINTS = 32
#: The two law sources `run_lumped` takes.
LAW_SOURCES = ("calibrated", "closed-form")


def stage_gearset(gearset: GearSet, stage: int, ring_inertia: float) -> GearSet:
    """``gearset`` with ring ``stage`` (from 1) alone, of inertia ``ring_inertia`` [kg m^2]."""
    n = len(gearset.stages)
    if isinstance(stage, bool) or not isinstance(stage, int) or not 1 <= stage <= n:
        raise CaseError(f"stage = {stage!r}: the gear set {gearset.name!r} has stages 1..{n}")
    ring = replace(gearset.stages[stage - 1], inertia=ring_inertia)
    return replace(gearset, stages=(ring,))


def stage_laws(laws: LawSet, stage: int) -> LawSet:
    """The tables (and position law) of ``stage`` in ``laws``, renumbered as stage 1."""
    tables = {(1, kind): replace(table, stage=1)
              for (s, kind), table in laws.tables.items() if s == stage}
    if not tables:
        raise CaseError(f"stage = {stage}: the laws ({laws.source}) have no table for it")
    positions = {1: laws.positions[stage]} if stage in laws.positions else {}
    return LawSet(tables, f"{laws.source}, stage {stage}", laws.notes, positions)


def lumped_model(condition: RollingCondition, gearset: GearSet | None = None,
                 calibration: str | Path | None = None,
                 output_share: float = OUTPUT_SHARE,
                 tip_edge_damping: bool = True) -> DriveModel:
    """The single-stage, single-mesh `DriveModel` of ``condition``.

    Parameters
    ----------
    condition : RollingCondition
    gearset : GearSet, optional
        Default: the seed's set.
    calibration : path, optional
        A ``calibration.json`` of ``gearset``; None: the closed-form laws.
    output_share : float
        Share ``f`` of the face-gear inertia on the output, in (0, 0.5].
    tip_edge_damping : bool
        False: the tip-edge (corner) laws without their damping (``cmax = 0``),
        as the elastic rolling FE has them; a diagnostic that separates what the
        mesh-in laws' restitution dissipates from the rest of the comparison.
    """
    gearset = default_gearset() if gearset is None else gearset
    if not 0.0 < output_share <= 0.5:
        raise CaseError(f"output_share = {output_share!r} must lie in (0, 0.5]")
    j_gear = condition.gear_inertia
    single = stage_gearset(gearset, condition.stage, (1.0 - output_share) * j_gear)
    model = DriveModel(
        gearset=single, n_pinions=1, pinion_inertia=condition.pinion_inertia,
        output_inertia=output_share * j_gear, backlash=(condition.backlash,),
        transmission_error=condition.transmission_error, drag_torque=condition.drag_torque,
        friction="gearset" if condition.friction else None, drive="speed",
        mesh_phase=condition.mesh_phase, engage_position=1.0)
    if calibration is None:
        return _tip_edges(model.with_laws(closed_form_laws(single, [model.effective_mass(1)])),
                          tip_edge_damping)
    # the file's stages are the full set's: read it on that set, with each stage's
    # effective mass of one mesh on a rotor of its own ring's inertia (the closed-form
    # fallbacks of missing kinds), then keep the condition's stage
    cos = np.cos(model.geometry.pressure_angle)
    masses = [stage.inertia / (0.5 * gearset.module * stage.teeth * cos) ** 2
              for stage in gearset.stages]
    masses[condition.stage - 1] = model.effective_mass(1)
    laws = load_calibration(calibration, gearset, masses)
    return _tip_edges(model.with_laws(stage_laws(laws, condition.stage)), tip_edge_damping)


def _tip_edges(model: DriveModel, damping: bool) -> DriveModel:
    """``model``, or with no damping in its tip-edge (corner) laws."""
    if damping:
        return model
    law_set = model.law_set
    tables = {key: replace(table, cmax=np.zeros_like(table.cmax))
              if key[1].startswith("corner") else table
              for key, table in law_set.tables.items()}
    return model.with_laws(replace(law_set, tables=tables,
                                   source=f"{law_set.source}; tip edges undamped"))


def events_from_run(events) -> ContactEvents:
    """`ContactEvents` of a lumped run's `ImpactEvents`."""
    return ContactEvents(
        time=events.time, kind=[KIND_NAMES[int(k)] for k in events.kind],
        flank=events.flank, closing_speed=events.speed, peak_force=events.force,
        location=[CONTACT_NAMES[int(c)] for c in events.contact], position=events.position)


def load_series(condition: RollingCondition, points: int = RAMP_POINTS) -> LoadSeries:
    """The load torque over the run: ``T sin^2(pi t / 2 t_r)`` up to the ramp's end
    ``t_r``, then ``T`` (linear between ``points`` samples of the ramp; its largest
    departure from the sine, ``T (pi / 2 points)^2 / 8`` about, is 3e-4 T for 32)."""
    torque, ramp = condition.torque, condition.load_ramp
    if ramp <= 0.0:
        return LoadSeries(np.array([0.0, condition.duration]), np.array([torque, torque]),
                          "constant load")
    t = np.linspace(0.0, ramp, points + 1)
    values = torque * np.sin(0.5 * np.pi * t / ramp) ** 2
    if ramp < condition.duration:
        t, values = np.append(t, condition.duration), np.append(values, torque)
    return LoadSeries(t, values, f"sin^2 ramp over {ramp:g} s")


def run_lumped(condition: RollingCondition, laws: str = "closed-form",
               gearset: GearSet | None = None, calibration: str | Path | None = None,
               output_share: float = OUTPUT_SHARE,
               tip_edge_damping: bool = True) -> RollingRecord:
    """Run the lumped model on ``condition`` and return its `RollingRecord`.

    Parameters
    ----------
    condition : RollingCondition
    laws : {"calibrated", "closed-form"}
        The IMPACT laws: ``calibration``'s, or the closed forms.
    gearset : GearSet, optional
        Default: the seed's set.
    calibration : path, optional
        The ``calibration.json`` for ``laws = "calibrated"``.
    output_share, tip_edge_damping
        See `lumped_model`.

    Returns
    -------
    RollingRecord
        Sampled `SAMPLES_PER_PERIOD` times per mesh period.
    """
    if laws not in LAW_SOURCES:
        raise CaseError(f"laws = {laws!r}; pick one of {list(LAW_SOURCES)}")
    if laws == "calibrated" and calibration is None:
        raise CaseError("laws = 'calibrated' needs a calibration file (calibration=PATH, "
                        "written by fe-impact calibrate)")
    gearset = default_gearset() if gearset is None else gearset
    model = lumped_model(condition, gearset, calibration if laws == "calibrated" else None,
                         output_share, tip_edge_damping)
    record = run_model(condition, model, gearset,
                       f"lumped, {laws}" + ("" if tip_edge_damping else ", tip edges undamped"))
    record.info.update(laws=laws, output_share=output_share)
    return record


def run_model(condition: RollingCondition, model: DriveModel, gearset: GearSet,
              source: str) -> RollingRecord:
    """Run ``model`` (a `lumped_model`, its laws changed as a study needs) on
    ``condition``; the record is named ``source``."""
    schedule = StageSchedule((Segment(condition.duration, 1, condition.speed_rpm,
                                      load_series=load_series(condition)),))
    period = 1.0 / condition.mesh_frequency(gearset.pinion.teeth)
    run = simulate(model, schedule, sample_interval=period / SAMPLES_PER_PERIOD)
    s = run.series
    info = {key: run.info[key] for key in ("steps", "rejected_steps", "wall_s",
                                           "clamped_low", "clamped_high", "law_source")}
    info.update(ring_inertia=float(model.ring_inertias[0]), output_inertia=model.output_j,
                web_stiffness=float(model.couplings[0]), law_notes=list(model.law_set.notes))
    logger.info("lumped %s, %s: %d steps, %.1f s, %d impacts", condition.name, source,
                info["steps"], info["wall_s"], len(run.events))
    return RollingRecord(
        source=source, condition=condition, pinion_teeth=gearset.pinion.teeth,
        time=s["time_s"], te=s["mesh_displacement_m"], drive_force=s["drive_force_N"],
        coast_force=s["coast_force_N"], events=events_from_run(run.events), info=info)
