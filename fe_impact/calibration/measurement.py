"""Measuring one case: mesh, FE impact, measurements and the fitted laws.

For an impact case, :func:`run_case`

1. meshes the pinion/face-gear tooth pair at the case's contact position
   (cached under ``cache/meshes`` by the case's resume key);
2. runs the FE impact (rigid rotors on both hubs, closing at the impact speed);
3. measures peak force, maximum approach, contact time, restitution and the
   energy lost, and fits ``F = K delta^xi`` on the loading branch;
4. fits the ADAMS IMPACT parameters (k, exponent, cmax, d) so that a
   one-degree-of-freedom model with the same effective mass and impact speed
   reproduces the FE force history and restitution, and puts the seed's
   closed-form values (eq. 12-17) and the hysteresis models' chi beside them.

A mesh-cycle position (:class:`~fe_impact.calibration.meshcycle.PositionCase`)
is measured by :func:`fe_impact.calibration.meshcycle.run_position`. Each
case writes ``cases/<id>/result.json``; where the cases run, and how a run
resumes, is :mod:`fe_impact.calibration.execution`'s business.
"""

from __future__ import annotations

import gc
import logging
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from fe_impact.calibration import meshcycle
from fe_impact.calibration.meshcycle import PositionCase
from fe_impact.calibration.planning import (
    ImpactCase,
    Settings,
    case_contact,
    case_hash,
    mesh_key,
)
from fe_impact.calibration.records import (
    CalibrationRecord,
    ClosedForm,
    Difference,
    FEMeasurements,
    FitQuality,
    HysteresisChi,
    ImpactParameters,
    ModelInfo,
    RestitutionModels,
    write_record,
)
from fe_impact.errors import CalibrationError, ContactError

if TYPE_CHECKING:
    from fe_impact.fe.case import Case
    from fe_impact.gears.pairanalysis import PairAnalysis

logger = logging.getLogger(__name__)

#: Newmark steps per (Hertz-estimated) contact time in the tooth impacts.
STEPS_PER_CONTACT = 60
#: Output-history samples per (Hertz-estimated) contact time: the force and
#: approach histories of summary.json, history.csv and the report's plots.
#: The measurements and the fit read every step's history, not these samples.
HISTORY_PER_CONTACT = 20
#: ParaView frames: the fields at every VTU_FRAME_STRIDE-th output time, about
#: 8 a case (approach, loading, peak, unloading, separation). Each frame of a
#: 120k-DOF tooth pair costs about 0.3 s of CPU (stresses and a compressed
#: VTU): one at each of the 20 output times cost a tenth of a case.
#: ``fe-impact solve`` on the written ``case_newmark_calibration.toml`` gives
#: a frame at every output time.
VTU_FRAME_STRIDE = 4
#: Automatic initial gap: this fraction of the Hertz approach, at most MAX_GAP.
#: The teeth fly this gap before they touch, which at 100 r/min (approach
#: 0.9 um, 0.0125 m/s) took 0.8 contact times with a fixed 2 um gap. Half the
#: approach is still some 20 times the P2 faces' deviation from the flanks.
GAP_FRACTION = 0.5
MAX_GAP = 2e-6
#: Run on after separation for this fraction of the contact duration; the
#: rebound velocity (momentum / mass) is settled once the force has vanished.
STOP_AFTER_SEPARATION = 0.25
#: The impacts' contact zone: the faces whose gap is below ZONE_REACH times the
#: Hertz approach (beyond the initial gap). Hertz: the undeformed separation is
#: delta/2 at the patch's edge, so 1.2 delta covers the whole patch with room to
#: spare. At 1.0 the nine default impacts kept their results, but the three at
#: 1000 r/min grew their zone (a second factorisation), and at 0.9 the 100 r/min
#: one did too (measured 2026-11-27).
ZONE_REACH = 1.2


def run_case(case: ImpactCase, settings: Settings, gearset_text: str, out: str,
             cache: str, picture: Callable[[CalibrationRecord], None] | None = None
             ) -> CalibrationRecord:
    """Mesh, solve and fit one impact (or measure one mesh-cycle position); writes
    ``cases/<id>/result.json``; returns it.

    ``picture(record)``, if given, renders the impact's pictures once the solver's
    memory is freed; its time enters the record's ``timings_s["picture"]``.
    """
    import tomllib

    from fe_impact.meshing.toothpair import share_solids, solids_folder

    share_solids(solids_folder(cache))   # built once a stage, kept for later runs
    if isinstance(case, PositionCase):
        return _run_position(case, settings, gearset_text, out, cache)

    from fe_impact.fe.linalg import limit_threads
    from fe_impact.gears import gearset_from_dict
    from fe_impact.gears.pairanalysis import hertz_impact_estimate
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.runtime import keep_freed_memory

    keep_freed_memory()

    t0, cpu0 = time.perf_counter(), time.process_time()
    folder = Path(out) / "cases" / case.id
    gearset = gearset_from_dict(tomllib.loads(gearset_text))
    key = case_hash(case, settings, gearset_text)
    mesh_dir = Path(cache) / "meshes" / mesh_key(case, settings, gearset_text)
    timings = {}
    # One worker per core: keep the sparse solver on one thread.
    contact, roll = case_contact(case, settings, gearset)
    with limit_threads(1):
        t = time.perf_counter()
        gap = settings.gap
        if gap is None:
            hit = hertz_impact_estimate(gearset, case.stage, roll, case.impact_speed, contact)
            gap = min(MAX_GAP, GAP_FRACTION * hit.delta_max)
        pair = build_pair(gearset, case.stage, roll, settings.level, settings.order, gap,
                          case.impact_speed, mesh_dir, reuse=True, contact=contact)
        timings["mesh"] = time.perf_counter() - t
        t = time.perf_counter()
        friction = case.friction
        tail = "_frictionless" if case.companion else ""
        try:
            solver, result, output = _impact(calibration_case(
                pair, settings, friction=friction, tail=tail), folder, timings, t)
        except ContactError as exc:
            if friction == (0.0, 0.0):
                raise
            # the frictional solve's own limits: the impact is solved frictionless, and
            # its record says so
            logger.warning("case %s: %s; solved frictionless", case.id, exc)
            friction = (0.0, 0.0)
            solver, result, output = _impact(calibration_case(pair, settings, tail=tail),
                                             folder, timings, time.perf_counter())
        timings["fe"] = time.perf_counter() - t
        timings["fe_output"] = output
        timings["fe_steps"] = timings["fe"] - timings["fe_setup"] - output
    t = time.perf_counter()
    record = measure_and_fit(case, result, solver.effective_mass, settings, pair,
                             gearset.material)
    timings["fit"] = time.perf_counter() - t
    record = replace(record, id=case.id, hash=key, initial_gap=pair.analysis.gap,
                     model=ModelInfo.from_info(result.info), friction=friction,
                     companion=case.companion)
    # the solver's factorisation and fields go before the picture reads a frame
    # (the largest default impact, 157.6k DOFs, alone: peak 3.07 -> 2.83 GB)
    del solver, result
    gc.collect()
    if picture is not None:
        t = time.perf_counter()
        picture(record)
        timings["picture"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    timings["cpu"] = time.process_time() - cpu0   # the process's, all its threads
    record = replace(record, timings_s=timings)
    write_record(folder / "result.json", record)
    return record


def _impact(fe_case, folder: Path, timings: dict, started: float):
    """Solve an impact case, its fields written to ``folder/fe`` every
    :data:`VTU_FRAME_STRIDE`-th output time: the solver, its result and the seconds
    spent writing; ``timings["fe_setup"]`` is set (from ``started``)."""
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.output.results import DynamicWriter
    from fe_impact.solvers.dynamic import DynamicSolver

    solver = DynamicSolver(fe_case, load_mesh(fe_case.mesh_file, fe_case.unit))
    timings["fe_setup"] = time.perf_counter() - started
    writer = DynamicWriter(folder / "fe", fe_case, solver.mesh, solver.model.material)
    output = [0.0]

    def frame(f) -> None:
        t1 = time.perf_counter()
        writer.frame(f)
        output[0] += time.perf_counter() - t1

    result = solver.run(frame_hook=frame, frame_stride=VTU_FRAME_STRIDE)
    t1 = time.perf_counter()
    writer.finish(result)
    output[0] += time.perf_counter() - t1
    return solver, result, output[0]


def _run_position(case: PositionCase, settings: Settings, gearset_text: str, out: str,
                  cache: str) -> meshcycle.PositionRecord:
    from fe_impact.output.files import write_json
    from fe_impact.runtime import keep_freed_memory

    keep_freed_memory()
    record = meshcycle.run_position(case, settings.position_level, settings.order,
                                    gearset_text, cache)
    write_json(Path(out) / "cases" / case.id / "result.json", record.to_dict())
    return record


def calibration_case(pair, settings: Settings,
                     steps_per_contact: float = STEPS_PER_CONTACT,
                     friction: tuple[float, float] = (0.0, 0.0), tail: str = "") -> Case:
    """The tooth pair's impact case with this run's integrator and calibration controls.

    ``friction``: the flanks' Coulomb coefficients ``(mu_static, mu_dynamic)``
    (:func:`~fe_impact.calibration.meshcycle.with_friction`; the case's own
    ``[[contacts]]`` are frictionless); ``tail`` ends the written case file's name
    (a frictionless companion's beside its case's, on the same mesh).

    Sets the contact search distance (where the case leaves it automatic),
    HISTORY_PER_CONTACT output times per contact time (history rows; the run
    writes fields at every VTU_FRAME_STRIDE-th), ``stop_after_separation`` (unless set)
    and (Newmark, automatic step) a step of t_c / ``steps_per_contact``, with
    t_c the Hertz contact time. The flanks are nearly flat along the
    ellipse's major axis (relative radius about 1 m), so a search distance of
    a few element sizes would take in the whole flank; the Hertz estimate of
    the approach bounds the zone instead (it grows by itself if the teeth
    come closer elsewhere). The case is also written next to the mesh as
    ``case_<integrator>_calibration.toml``, for ``fe-impact solve``.
    """
    from fe_impact.fe.casefile import write_case

    case, tca = pair.case, pair.analysis
    t_c = tca.impact.contact_time
    reach = tca.gap + ZONE_REACH * tca.impact.delta_max
    contacts = tuple(c if c.search_distance is not None else replace(c, search_distance=reach)
                     for c in case.contacts)
    a = replace(case.analysis, integrator=settings.integrator,
                output_interval=t_c / HISTORY_PER_CONTACT)
    if a.stop_after_separation is None:
        a = replace(a, stop_after_separation=STOP_AFTER_SEPARATION)
    if settings.integrator == "newmark" and a.time_step is None:
        # 60 steps over the Hertz contact time: the sphere impact benchmark resolves
        # peak force and contact time to 0.4% with 59 steps over the contact; on the
        # tooth pair the law and the restitution are converged to 0.25% but the peak
        # force (the teeth's vibration on top) only to 2-3% (validation/time_step.py).
        a = replace(a, time_step=t_c / steps_per_contact)
    path = pair.case_path.with_name(f"case_{settings.integrator}_calibration{tail}.toml")
    prepared = meshcycle.with_friction(replace(case, path=path, contacts=contacts, analysis=a),
                                       friction)
    write_case(prepared, path, header=f"{pair.case_path.name} with the {settings.integrator} "
               "calibration's controls (fe_impact.calibration.measurement)")
    return prepared


def measure_and_fit(case: ImpactCase, result, mass: float, settings: Settings, pair,
                    material) -> CalibrationRecord:
    """Measurements of one FE impact and the fitted/closed-form law parameters."""
    from fe_impact.calibration import fitting

    m, h = result.measurements, result.history
    if m.peak_force <= 0 or m.contact_duration is None:
        raise CalibrationError(f"case {case.id}: the teeth did not touch and separate within "
                               "the simulated time")
    e_fe = m.restitution
    # An elastic impact can rebound a hair faster than it came in (integrator and
    # penalty-switch error, ~1e-4); the laws take e <= 1.
    e = min(e_fe, 1.0)
    speed = m.impact_velocity
    power = fitting.fit_power_law(h["approach"], h["contact_force"])
    try:
        ks = fitting.mesh_stiffness(h["approach"], h["contact_force"], settings.nominal_load)
        tangent = (ks.from_data, ks.from_power_law)
    except CalibrationError as exc:   # nominal load above the peak force of this impact
        logger.info("case %s: %s", case.id, exc)
        tangent = (None, None)
    fe = FEMeasurements(
        peak_force=m.peak_force, max_approach=m.max_approach, contact_time=m.contact_duration,
        restitution=e, restitution_measured=e_fe, energy_lost=1.0 - e ** 2,
        impact_velocity=speed, energy_error=m.energy_error,
        residual_indentation=m.residual_indentation, stiffness_k=power.K,
        stiffness_exponent=power.exponent, stiffness_fit_r2=power.r2,
        nominal_load=settings.nominal_load, mesh_stiffness=tangent[0],
        mesh_stiffness_power_law=tangent[1],
        friction_dissipation=(float(h["friction_dissipation"][-1])
                              if "friction_dissipation" in h else 0.0))
    fit = fitting.fit_impact_law(h["time"], h["contact_force"], h["approach"], mass, speed, e)
    if not fit.success:    # kept (the report lists it), but said now
        logger.warning("case %s: the impact-law fit did not converge: %s", case.id, fit.message)
    tca = pair.analysis
    # Elliptical Hertz contact: F = k delta^1.5 exactly, k from the TCA ellipse.
    ell = tca.ellipses[-1]
    k_hertz = ell.force / ell.approach ** 1.5
    closed = fitting.closed_form_parameters(tca.equivalent_radius, tca.effective_modulus,
                                            mass, speed, e, k=k_hertz)
    return CalibrationRecord(
        stage=case.stage, face_teeth=case.face_teeth, kind=case.kind,
        restitution_models=restitution_models(material, mass, tca, speed),
        speed_rpm=case.speed_rpm, impact_speed=case.impact_speed,
        effective_mass=mass, fe=fe,
        impact=ImpactParameters.from_source(fit),
        fit_quality=FitQuality.from_source(fit),
        closed_form=ClosedForm.from_source(closed),
        hysteresis_chi={k: HysteresisChi.from_source(v)
                        for k, v in fitting.hysteresis_chis(e).items()},
        differences={k: Difference(**v) for k, v in fitting.compare(fit, closed).items()},
    )


def restitution_models(material, mass: float, tca: PairAnalysis, speed: float
                       ) -> RestitutionModels:
    """The seed's eq. 14 restitution at this impact, with two yield-onset speeds.

    ``v_y_eq15`` is the seed's eq. 15 (a solid sphere of the gear steel,
    independent of size and mass). ``v_y_tooth`` is the speed at which this
    tooth pair's Hertz impact (TCA ellipse, the record's effective ``mass``: the
    rotors with the sectors they carry, as the fit and the closed form take it)
    reaches the yield-onset pressure ``p0 = 1.6 Y``
    (`fe_impact.physics.hertz.ellipse_yield_speed`).
    """
    from fe_impact.physics import hertz, seed

    vy15 = hertz.yield_onset_speed(material.yield_strength, material.density,
                                   tca.effective_modulus)
    relative = tca.contact.relative
    vyt = hertz.ellipse_yield_speed(mass, 1.0 / relative.lambda_max,
                                    1.0 / relative.lambda_min, tca.effective_modulus,
                                    material.yield_strength)
    return RestitutionModels(v_y_eq15=vy15, v_y_tooth=vyt, yield_ratio_eq15=speed / vy15,
                             yield_ratio_tooth=speed / vyt,
                             seed_eq14=seed.restitution(speed / vy15),
                             seed_eq14_tooth=seed.restitution(speed / vyt))

