"""Calibration pipeline: FE tooth impacts at the operating speeds -> lumped IMPACT laws.

For every stage and impact speed the pipeline

1. meshes the pinion/face-gear tooth pair at the design contact position
   (cached under ``cache/meshes`` by a hash of the parameters);
2. runs the FE impact (rigid rotors on both hubs, closing at the impact speed);
3. measures peak force, maximum approach, contact time, restitution and the
   energy lost, and fits ``F = K delta^xi`` on the loading branch;
4. fits the ADAMS IMPACT parameters (k, exponent, cmax, d) so that a
   one-degree-of-freedom model with the same effective mass and impact speed
   reproduces the FE force history and restitution, and puts the seed's
   closed-form values (eq. 12-17) and the hysteresis models' chi beside them.

Cases run as a sweep on Dask (a local cluster by default, or an existing
``dask.distributed`` scheduler). Each finished case is written to
``cases/<id>/result.json`` at once (atomically), so an interrupted run keeps
its finished cases and a rerun computes only the missing ones.

A case is computed under a lock on its folder (``cases/<id>/.lock``, see
:func:`fe_impact.output.files.folder_lock`): a second run on the same output
folder waits for the cases the first is computing and takes their results.
Holding the lock, a case first deletes the temporary files that a killed
run may have left in its folder. SIGINT (Ctrl-C) or SIGTERM stops the
sweep: the running cases stop within a second or so (:data:`STOP_GRACE` at
most), ``summary.json`` is written with ``status: "stopped"``, the finished
and the missing cases, and the command ends with one line; an earlier
``calibration.json`` is left as it was. The workers ignore both signals
themselves; the parent stops them.

Impact speeds (the seed's eq. 4 and 5): in mesh, the seed's relative sliding
speed ``v12 = sqrt((w_f r_f)^2 + (w_c r_c)^2) - sqrt((w_c r_c)^2 + (w_c r_c
cos a)^2)`` (the middle line of eq. 4; its last line is not dimensionally
consistent); with ``w_f r_f = w_c r_c`` this is ``w_c r_c (sqrt 2 - sqrt(1 +
cos^2 a))``, the same for every stage. A ratio switch into stage ``i``
(``--switch``) is struck at two speeds: eq. 5's ``v_s``, and the rigid
kinematics' ``r_bp w_p |N_i / N_(i-1) - 1|`` with which the torsional model's
teeth close after a switch (`fe_impact.switching.geometry.switching_speed`),
some 8 times lower.
"""

from __future__ import annotations

import contextlib
import gc
import hashlib
import json
import logging
import math
import os
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from fe_impact import __version__
from fe_impact.calibration import meshcycle
from fe_impact.calibration.meshcycle import PositionCase
from fe_impact.calibration.records import (  # noqa: F401 (KINDS, UNITS: importable here)
    KINDS,
    NOTES,
    SCHEMA,
    UNITS,
    Calibration,
    CalibrationRecord,
    ClosedForm,
    Difference,
    FEMeasurements,
    FitQuality,
    HysteresisChi,
    ImpactParameters,
    ModelInfo,
    RestitutionModels,
    write_calibration,
    write_calibration_csv,
    write_record,
)
from fe_impact.errors import CalibrationError
from fe_impact.fe.case import INTEGRATORS
from fe_impact.gears.pairanalysis import LEVEL_NAMES
from fe_impact.inputs import Reader, read_document
from fe_impact.interrupts import Interrupted, handle_signals, ignore_signals
from fe_impact.output.drawing import Draw, draw_here, draw_on
from fe_impact.output.files import folder_lock, remove_temporaries, removed_if_left_empty

if TYPE_CHECKING:
    from fe_impact.fe.case import Case
    from fe_impact.gears.pairanalysis import PairAnalysis

logger = logging.getLogger(__name__)

OPERATING_SPEEDS_RPM = (100.0, 300.0, 1000.0)
LEVELS = LEVEL_NAMES
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
#: Nominal mesh load (N) at which the linearised mesh stiffness is reported.
NOMINAL_LOAD = 100.0
#: Schema of the run's summary.json (status, finished and missing cases).
SUMMARY_SCHEMA = "fe-impact/calibration-run/1"
#: After SIGINT/SIGTERM, wait at most this long [s] for the running cases to
#: stop before the workers are closed regardless. A case checks every
#: STOP_POLL s and stops at the next Python statement, which in a tooth
#: impact is well within a second (one Newmark step is 0.1-0.5 s).
STOP_GRACE = 20.0
STOP_POLL = 0.25
# SCHEMA, KINDS and UNITS of the calibration files: fe_impact.calibration.records.


@dataclass(frozen=True)
class ImpactCase:
    """One FE impact of the sweep."""

    stage: int                 # 1-based stage number
    face_teeth: int
    kind: str                  # "mesh" (eq. 4) or "switch" (into this stage)
    impact_speed: float        # m/s
    speed_rpm: float | None = None
    basis: str = ""            # of a switch's speed: "" eq. 5, "kinematic" rigid kinematics
    #: pinion roll angle [deg] of the contact; None: the run's (Settings.roll_angle_deg)
    roll_angle_deg: float | None = None

    @property
    def id(self) -> str:
        rpm = f"{self.speed_rpm:g}rpm" if self.speed_rpm is not None else \
            f"{self.impact_speed * 1e3:.4g}mms"
        kind = f"{self.kind}_{self.basis}" if self.basis else self.kind
        return f"stage{self.stage}_{kind}_{rpm}".replace(".", "p")


@dataclass(frozen=True)
class Settings:
    """Options shared by all cases of a run (they enter the resume hash)."""

    level: str = "default"
    integrator: str = "newmark"
    order: int = 2
    gap: float | None = None     # m, initial gap at the contact point; None: auto
    roll_angle_deg: float = 0.0
    nominal_load: float = NOMINAL_LOAD
    cycle_level: str | None = None   # mesh level of the mesh-cycle positions; None: below level

    def __post_init__(self) -> None:
        if self.level not in LEVELS:
            raise CalibrationError(f"level = {self.level!r}: pick one of {list(LEVELS)}")
        if self.cycle_level is not None and self.cycle_level not in LEVELS:
            raise CalibrationError(f"mesh-cycle level = {self.cycle_level!r}: pick one of "
                                   f"{list(LEVELS)}")
        if self.integrator not in INTEGRATORS:
            raise CalibrationError(f"integrator = {self.integrator!r}: pick one of "
                                   f"{list(INTEGRATORS)}")
        if self.order not in (1, 2):
            raise CalibrationError(f"order = {self.order!r}: must be 1 or 2")
        if self.gap is not None and not (math.isfinite(self.gap) and 0.0 < self.gap <= 1e-4):
            raise CalibrationError(f"gap = {self.gap!r} m: must be in (0, 1e-4] m")


    @property
    def position_level(self) -> str:
        """Mesh level of the mesh-cycle positions: ``cycle_level``, or one level below
        the impacts' (coarse at the least). The cycle is three positions' worth of
        quasi-static solves for every impact; one level down keeps the main job
        within ten minutes on two cores, at the accuracy the mesh-cycle study
        measures (secant stiffness at 500 N 2.9% above the fine level at the
        coarse level, 1.0% at the default level: validation/mesh_cycle.py)."""
        if self.cycle_level is not None:
            return self.cycle_level
        return LEVELS[max(0, LEVELS.index(self.level) - 1)]

    def to_dict(self) -> dict:
        """The settings as written to summary.json and calibration.json: the fields,
        ``cycle_level`` resolved to the level the positions were meshed at."""
        return {**asdict(self), "cycle_level": self.position_level}

    def impact_key(self) -> dict:
        """The settings an impact case depends on (its resume key)."""
        return {k: v for k, v in asdict(self).items() if k != "cycle_level"}


def mesh_impact_speed(pinion_pitch_radius: float, pressure_angle: float, rpm: float) -> float:
    """Seed eq. 4 (middle line) with ``w_f r_f = w_c r_c``: the in-mesh impact speed, m/s."""
    v = rpm * 2.0 * math.pi / 60.0 * pinion_pitch_radius
    return v * (math.sqrt(2.0) - math.sqrt(1.0 + math.cos(pressure_angle) ** 2))


def plan_cases(gearset, stages: list[int] | None = None, speeds_rpm=None,
               impact_speeds=None, switch: bool | str = False) -> list[ImpactCase]:
    """The sweep: every stage at every speed (r/min via eq. 4, or impact speeds in m/s);
    with ``switch``, also the switches into stages 2.. at each speed's eq. 5
    (``"eq5"``), kinematic (``"kinematic"``) or both (``"both"`` or True) switching
    speeds (module docstring)."""
    if switch is True:
        switch = "both"
    if switch not in (False, None, "eq5", "kinematic", "both"):
        raise CalibrationError(f"--switch {switch!r}: pick eq5, kinematic or both")
    from fe_impact.switching.geometry import mesh_geometry, seed_switching_speed, switching_speed

    n = len(gearset.stages)
    stages = list(stages or range(1, n + 1))
    bad = [s for s in stages if not 1 <= s <= n]
    if bad:
        raise CalibrationError(f"--stages {bad}: the gear set has stages 1..{n}")
    if speeds_rpm is not None and impact_speeds is not None:
        raise CalibrationError("give --speeds (r/min) or --impact-speeds (m/s), not both")
    for name, vals in (("--speeds", speeds_rpm), ("--impact-speeds", impact_speeds)):
        if vals is not None and (not len(vals) or any(not v > 0 or not math.isfinite(v)
                                                      for v in vals)):
            raise CalibrationError(f"{name} {list(vals)}: need positive numbers")
    for name, vals in (("--stages", stages), ("--speeds", speeds_rpm),
                       ("--impact-speeds", impact_speeds)):
        if vals is not None and len(set(vals)) != len(vals):
            raise CalibrationError(f"{name} {list(vals)}: a value is repeated; give each once")
    if switch and impact_speeds is not None:
        raise CalibrationError("--switch with --impact-speeds: a switch's speed follows from "
                               "the shaft speed; give --speeds (r/min) instead")
    if switch and not any(s > 1 for s in stages):
        raise CalibrationError(f"--switch with --stages {stages}: a switch goes into stage 2 "
                               f"or later; add one of stages 2..{n} or drop --switch")
    pin = gearset.pinion
    alpha = math.radians(pin.pressure_angle_deg)
    base_radius = mesh_geometry(gearset).base_radius if switch in ("kinematic", "both") \
        else None
    cases = []
    for s in stages:
        teeth = gearset.stages[s - 1].teeth
        if impact_speeds is not None:
            cases += [ImpactCase(s, teeth, "mesh", float(v)) for v in impact_speeds]
            continue
        for rpm in speeds_rpm or OPERATING_SPEEDS_RPM:
            v = mesh_impact_speed(pin.pitch_radius, alpha, rpm)
            cases.append(ImpactCase(s, teeth, "mesh", v, float(rpm)))
            if switch and s > 1:
                w = rpm * 2.0 * math.pi / 60.0
                r_f = 0.5 * gearset.module * teeth
                if switch in ("eq5", "both"):
                    vs = seed_switching_speed(w, pin.pitch_radius, r_f, teeth / pin.teeth,
                                              alpha)
                    cases.append(ImpactCase(s, teeth, "switch", vs, float(rpm)))
                if switch in ("kinematic", "both"):
                    vk = switching_speed(w, pin.teeth, gearset.stages[s - 2].teeth, teeth,
                                         base_radius)
                    cases.append(ImpactCase(s, teeth, "switch", vk, float(rpm), "kinematic"))
    _check_impact_speeds(cases, impact_speeds is not None)
    ids = [c.id for c in cases]
    if len(set(ids)) != len(ids):
        same = sorted({i for i in ids if ids.count(i) > 1})
        option = "--impact-speeds" if impact_speeds is not None else "--speeds"
        raise CalibrationError(f"{option}: two speeds give the case {same[0]} (ids keep four "
                               "significant digits); give speeds that differ there")
    return cases


def _check_impact_speeds(cases: list[ImpactCase], given: bool) -> None:
    """Refuse, before any work starts, speeds the tooth-pair builder would refuse."""
    from fe_impact.gears.pairanalysis import MAX_IMPACT_SPEED

    bad = [c for c in cases if not c.impact_speed <= MAX_IMPACT_SPEED]
    if not bad:
        return
    c = bad[0]
    if given:
        raise CalibrationError(f"--impact-speeds {c.impact_speed:g}: allowed impact speeds "
                               f"are (0, {MAX_IMPACT_SPEED:g}] m/s")
    what = "switching" if c.kind == "switch" else "in-mesh"
    raise CalibrationError(f"--speeds {c.speed_rpm:g}: gives an {what} impact speed of "
                           f"{c.impact_speed:.4g} m/s at stage {c.stage}; allowed impact speeds "
                           f"are (0, {MAX_IMPACT_SPEED:g}] m/s")


def _import_distributed() -> None:
    """Import dask.distributed, keeping the level of its logger.

    Importing it sets that logger to INFO, which would print every worker's
    start and, at shutdown, a closed-connection traceback; the level the
    caller chose stays (the CLI: WARNING unless -vv).
    """
    log = logging.getLogger("distributed")
    level = log.level
    import dask.distributed  # noqa: F401

    log.setLevel(level)


def check_scheduler_address(address: str) -> str:
    """``address`` if it names a Dask scheduler (``[tcp://]host:port``), else a clear error."""
    _import_distributed()
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        _, location = parse_address(address)
        parse_host_port(location)
    except ValueError as exc:
        raise CalibrationError(f"--scheduler {address!r}: not a scheduler address ({exc}); "
                               "give host:port or tcp://host:port") from None
    return address


def case_hash(case: ImpactCase | PositionCase, settings: Settings, gearset_text: str) -> str:
    """Resume key: the case, the run's settings, the gear set, the schema, the
    fe-impact version and the mesh format (a result from another version or on
    meshes made otherwise is computed again)."""
    if isinstance(case, PositionCase):
        return meshcycle.case_hash(case, settings.position_level, settings.order, gearset_text)
    from fe_impact.meshing.toothpair import MESH_FORMAT

    blob = json.dumps([asdict(case), settings.impact_key(), gearset_text, SCHEMA, __version__,
                       MESH_FORMAT], sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


# -- one case (runs on a worker) -----------------------------------------------------


def run_case(case: ImpactCase, settings: Settings, gearset_text: str, out: str,
             cache: str) -> CalibrationRecord:
    """Mesh, solve and fit one impact (or measure one mesh-cycle position); writes
    ``cases/<id>/result.json``; returns it."""
    import tomllib

    from fe_impact.meshing.toothpair import share_solids, solids_folder

    share_solids(solids_folder(cache))   # built once a stage, kept for later runs
    if isinstance(case, PositionCase):
        return _run_position(case, settings, gearset_text, out, cache)

    from fe_impact.fe.linalg import limit_threads
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.gears import gearset_from_dict
    from fe_impact.gears.pairanalysis import hertz_impact_estimate
    from fe_impact.meshing.toothpair import build_pair
    from fe_impact.output.results import DynamicWriter
    from fe_impact.runtime import keep_freed_memory
    from fe_impact.solvers.dynamic import DynamicSolver

    keep_freed_memory()

    t0 = time.perf_counter()
    folder = Path(out) / "cases" / case.id
    gearset = gearset_from_dict(tomllib.loads(gearset_text))
    key = case_hash(case, settings, gearset_text)
    mesh_dir = Path(cache) / "meshes" / key
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
        fe_case = calibration_case(pair, settings)
        solver = DynamicSolver(fe_case, load_mesh(fe_case.mesh_file, fe_case.unit))
        timings["fe_setup"] = time.perf_counter() - t
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
        timings["fe"] = time.perf_counter() - t
        timings["fe_output"] = output[0]
        timings["fe_steps"] = timings["fe"] - timings["fe_setup"] - output[0]
    t = time.perf_counter()
    record = measure_and_fit(case, result, solver.effective_mass, settings, pair,
                             gearset.material)
    timings["fit"] = time.perf_counter() - t
    record = replace(record, id=case.id, hash=key, initial_gap=pair.analysis.gap,
                     model=ModelInfo.from_info(result.info))
    # the solver's factorisation and fields go before the picture reads a frame
    # (the largest default impact, 157.6k DOFs, alone: peak 3.07 -> 2.83 GB)
    del solver, result
    gc.collect()
    t = time.perf_counter()
    _contact_picture(out, record)
    timings["picture"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0
    record = replace(record, timings_s=timings)
    write_record(folder / "result.json", record)
    return record


def case_contact(case: ImpactCase, settings: Settings, gearset) -> tuple[str, float]:
    """Where an impact strikes: ``("flank", the case's or settings' roll angle)``, or for a corner
    kind the rounded tip edge's first touch at the closed-form corner laws' roll
    angle (:func:`~fe_impact.switching.calibration.corner_reference_roll`, deg)."""
    if not case.kind.startswith("corner-"):
        return "flank", (settings.roll_angle_deg if case.roll_angle_deg is None
                         else case.roll_angle_deg)
    from fe_impact.switching.calibration import corner_reference_roll

    return case.kind, math.degrees(corner_reference_roll(gearset, case.kind.removeprefix(
        "corner-")))


def _contact_picture(out: str, record: CalibrationRecord) -> None:
    """The case's row of the report's stress picture, rendered here on the worker
    (0.5 s an impact, off the report's serial end); a failure only costs the
    report the rendering."""
    from fe_impact.calibration.report import write_contact_picture

    try:
        write_contact_picture(Path(out), record)
    except (OSError, ValueError, RuntimeError) as exc:
        logger.warning("contact picture of %s not rendered: %s", record.id, exc)


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
                     steps_per_contact: float = STEPS_PER_CONTACT) -> Case:
    """The tooth pair's impact case with this run's integrator and calibration controls.

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
    path = pair.case_path.with_name(f"case_{settings.integrator}_calibration.toml")
    prepared = replace(case, path=path, contacts=contacts, analysis=a)
    write_case(prepared, path, header=f"{pair.case_path.name} with the {settings.integrator} "
               "calibration's controls (fe_impact.calibration.sweep)")
    return prepared


def measure_and_fit(case: ImpactCase, result, mass: float, settings: Settings, pair,
                    material) -> CalibrationRecord:
    """Measurements of one FE impact and the fitted/closed-form law parameters."""
    from fe_impact.calibration import fitting

    m, h = result.measurements, result.history
    if m["peak_force"] <= 0 or m["contact_duration"] is None:
        raise CalibrationError(f"case {case.id}: the teeth did not touch and separate within "
                               "the simulated time")
    e_fe = m["restitution"]
    # An elastic impact can rebound a hair faster than it came in (integrator and
    # penalty-switch error, ~1e-4); the laws take e <= 1.
    e = min(e_fe, 1.0)
    speed = m["impact_velocity"]
    power = fitting.fit_power_law(h["approach"], h["contact_force"])
    fe = {"peak_force": m["peak_force"], "max_approach": m["max_approach"],
          "contact_time": m["contact_duration"], "restitution": e,
          "restitution_measured": e_fe,
          "energy_lost": 1.0 - e ** 2, "impact_velocity": speed,
          "energy_error": m["energy_error"],
          "residual_indentation": m["residual_indentation"],
          "stiffness_k": power.K, "stiffness_exponent": power.exponent,
          "stiffness_fit_r2": power.r2,
          "nominal_load": settings.nominal_load}
    try:
        ks = fitting.mesh_stiffness(h["approach"], h["contact_force"], settings.nominal_load)
        fe["mesh_stiffness"] = ks.from_data
        fe["mesh_stiffness_power_law"] = ks.from_power_law
    except CalibrationError as exc:   # nominal load above the peak force of this impact
        logger.info("case %s: %s", case.id, exc)
        fe["mesh_stiffness"] = fe["mesh_stiffness_power_law"] = None
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
        restitution_models=RestitutionModels(**restitution_models(material, mass, tca, speed)),
        speed_rpm=case.speed_rpm, impact_speed=case.impact_speed,
        effective_mass=mass, fe=FEMeasurements(**fe),
        impact=ImpactParameters.from_source(fit),
        fit_quality=FitQuality.from_source(fit),
        closed_form=ClosedForm.from_source(closed),
        hysteresis_chi={k: HysteresisChi.from_source(v)
                        for k, v in fitting.hysteresis_chis(e).items()},
        differences={k: Difference(**v) for k, v in fitting.compare(fit, closed).items()},
    )


def restitution_models(material, mass: float, tca: PairAnalysis, speed: float) -> dict:
    """The seed's eq. 14 restitution at this impact, with two yield-onset speeds.

    ``v_y_eq15`` is the seed's eq. 15 (a solid sphere of the gear steel,
    independent of size and mass). ``v_y_tooth`` is the speed at which this
    tooth pair's Hertz impact (TCA ellipse, the record's effective ``mass``: the
    rotors with the sectors they carry, as the fit and the closed form take it)
    reaches the yield-onset pressure ``p0 = 1.6 Y``
    (`fe_impact.physics.hertz.ellipse_yield_speed`).
    """
    from fe_impact.physics import hertz

    vy15 = hertz.yield_onset_speed(material.yield_strength, material.density,
                                   tca.effective_modulus)
    relative = tca.contact.relative
    vyt = hertz.ellipse_yield_speed(mass, 1.0 / relative.lambda_max,
                                    1.0 / relative.lambda_min, tca.effective_modulus,
                                    material.yield_strength)
    return {"v_y_eq15": vy15, "v_y_tooth": vyt,
            "yield_ratio_eq15": speed / vy15, "yield_ratio_tooth": speed / vyt,
            "seed_eq14": hertz.seed_restitution(speed / vy15),
            "seed_eq14_tooth": hertz.seed_restitution(speed / vyt)}


# -- the sweep -----------------------------------------------------------------------


@dataclass
class Sweep:
    """Cases of a run, split into finished (loaded from disk) and to do."""

    cases: list[ImpactCase]
    done: dict[str, CalibrationRecord] = field(default_factory=dict)

    @property
    def todo(self) -> list[ImpactCase]:
        return [c for c in self.cases if c.id not in self.done]


def load_finished(out: Path, cases: list[ImpactCase], settings: Settings,
                  gearset_text: str) -> Sweep:
    """Finished cases of an earlier run with the same parameters (resume)."""
    sweep = Sweep(cases)
    for c in cases:
        record = finished_record(out, c, settings, gearset_text)
        if record is not None:
            sweep.done[c.id] = record
    return sweep


def finished_record(out: Path, case: ImpactCase, settings: Settings,
                    gearset_text: str) -> CalibrationRecord | None:
    """``cases/<id>/result.json`` if it holds this case with these settings, else None."""
    path = Path(out) / "cases" / case.id / "result.json"
    if not path.is_file():
        return None
    try:
        data = read_document(path, "calibration result", CalibrationError, "json")
        if data.get("hash") != case_hash(case, settings, gearset_text):
            return None   # another version, gear set or settings: computed again
        if isinstance(case, PositionCase):
            return meshcycle.PositionRecord.from_dict(data)
        return CalibrationRecord.from_dict(data, Reader(str(path), CalibrationError, "json"))
    except CalibrationError as exc:   # cut short or edited: computed again
        logger.warning("%s; case %s is computed again", exc, case.id)
        return None


def calibrate(gearset_text: str, cases: list[ImpactCase], settings: Settings, out: Path,
              cache: Path, workers: int | None = None, scheduler: str | None = None,
              progress: Callable[[int, int, str], None] | None = None,
              studies: Sequence[str] = (), numba: Path | None = None) -> Path:
    """Run the sweep (resuming), then write calibration.json/.csv, the report and summary.json.

    ``studies``: the seed's switching condition sets
    (:data:`~fe_impact.switching.study.SEED_STUDIES`) to run on the finished
    calibration, each into ``switching/<name>/`` (on the sweep's workers while
    the report is written); the report lists them. ``numba``: the folder of the
    local workers' compiled kernels, held by the caller (:func:`numba_folder`);
    None: one is taken for the run.

    ``summary.json`` says how the run ended (``status``), which cases are
    finished and which are missing. On SIGINT or SIGTERM
    (:class:`KeyboardInterrupt`) only it is written, with ``status:
    "stopped"`` (calibration.json and the report need every case, and a
    complete calibration.json from an earlier run stays), and the interrupt
    is raised again.
    """
    # a run that fails before writing anything (a scheduler that never answered)
    # leaves no empty --out
    with removed_if_left_empty(out) as out:
        return _calibrate(gearset_text, cases, settings, out, cache, workers, scheduler,
                          progress, studies, numba)


def _calibrate(gearset_text: str, cases: list[ImpactCase], settings: Settings, out: Path,
               cache, workers, scheduler, progress, studies: Sequence[str],
               numba: Path | None) -> Path:
    """:func:`calibrate` in its ``out`` folder."""
    t0 = time.perf_counter()
    sweep = load_finished(out, cases, settings, gearset_text)
    if sweep.done:
        logger.info("resuming: %d of %d cases already finished", len(sweep.done), len(cases))
    if progress is not None:
        progress(len(sweep.done), len(cases), "")
    todo = sweep.todo
    busy = [c.id for c in todo if _held_elsewhere(out / "cases" / c.id)]
    if busy:
        logger.warning("cases %s are being computed by another run on %s: this run waits for "
                       "them and takes their results", busy, out)
    written = []      # the calibration's files are complete once this holds their path

    def finish(draw: Draw) -> Path:
        """The files of a completed sweep, the pictures drawn by ``draw``, and the
        switching studies run by ``draw``: on the workers (``draw_on``) the studies
        start as soon as calibration.json is written and run beside the report's
        pictures (no idle worker between the two); drawn here they run after."""
        started: list[Callable[[], None]] = []

        def start(calibration: Path) -> None:
            started.append(_start_studies(out, calibration, gearset_text, studies, draw))

        path = _write_summary(out, cases, sweep, settings, time.perf_counter() - t0,
                              "completed", gearset_text, draw,
                              None if draw is draw_here else start)
        written.append(path)
        if started:
            started[0]()
        else:
            _run_studies(out, path, gearset_text, studies, draw)
        return path

    try:
        if not todo:
            return finish(draw_here)
        # the report's pictures and the studies are run on the sweep's workers before
        # they stop
        return _run_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
                         progress, finish, numba)
    except KeyboardInterrupt:
        if not written:    # an interrupted study leaves the calibration complete
            _write_summary(out, cases, sweep, settings, time.perf_counter() - t0, "stopped",
                           gearset_text)
        raise


def _held_elsewhere(folder: Path) -> bool:
    """True if another process holds the case folder's lock."""
    if not folder.is_dir():
        return False
    with folder_lock(folder, wait=False) as held:
        return not held


def _write_summary(out: Path, cases: list[ImpactCase | PositionCase], sweep: Sweep,
                   settings: Settings, wall: float, status: str, gearset_text: str,
                   draw: Draw = draw_here,
                   written: Callable[[Path], None] | None = None) -> Path:
    """summary.json and, for a completed run, calibration.json/.csv and report.md (its
    pictures drawn by ``draw`` while the tables are written); ``written(path)`` is
    called once calibration.json is complete (it must not block)."""
    from fe_impact.calibration.report import write_calibration_report
    from fe_impact.output.files import write_json

    summary = {"schema": SUMMARY_SCHEMA, "fe_impact_version": __version__, "status": status,
               "finished": [c.id for c in cases if c.id in sweep.done],
               "missing": [c.id for c in cases if c.id not in sweep.done],
               "settings": settings.to_dict(), "wall_time_s": wall,
               "calibration": "calibration.json" if status == "completed" else None}
    with ignore_signals():   # the files belong together: a second Ctrl-C waits for them
        path = None
        if status == "completed":
            records = [sweep.done[c.id] for c in cases if isinstance(c, ImpactCase)]
            positions = [sweep.done[c.id] for c in cases if isinstance(c, PositionCase)]
            cycle, drawing = None, None
            if positions:
                from fe_impact.calibration.meshcycle_report import write_mesh_cycle

                cycle, drawing = write_mesh_cycle(out, positions, gearset_text, draw)
            calibration = Calibration(cases=records, settings=settings.to_dict(),
                                      wall_time_s=wall, fe_impact_version=__version__,
                                      notes=NOTES, mesh_cycle=cycle)
            path = write_calibration(out / "calibration.json", calibration)
            if written is not None:
                written(path)
            write_calibration_csv(out / "calibration.csv", records)
            write_calibration_report(out, calibration, draw)
            if drawing is not None:
                drawing()
        summary_path = write_json(out / "summary.json", summary)
    return path or summary_path


def _run_studies(out: Path, calibration: Path, gearset_text: str, studies: Sequence[str],
                 draw: Draw) -> None:
    """Run the switching ``studies`` on the finished ``calibration`` (one ``draw`` job
    each), table them in report.md and list them in summary.json. A study that fails
    is logged and left out. Interrupted, the studies finished are kept (each study
    writes what it ran), summary.json says ``"switching": "stopped"``, and the
    interrupt is raised again: the calibration itself is complete."""
    try:
        finish = _start_studies(out, calibration, gearset_text, studies, draw)
    except KeyboardInterrupt:   # a draw that runs its jobs at once
        _studies_stopped(out)
        raise
    finish()


def _start_studies(out: Path, calibration: Path, gearset_text: str, studies: Sequence[str],
                   draw: Draw) -> Callable[[], None]:
    """Hand the ``studies`` to ``draw``; returns what waits for them and then tables
    them (:func:`_run_studies`: summary.json must exist by then)."""
    if not studies:
        return lambda: None
    from fe_impact.calibration.report import add_switching_section
    from fe_impact.output.files import write_json
    from fe_impact.switching.study import seed_study_job

    wait = draw([(f"switching study {name}", seed_study_job,
                  (gearset_text, name, str(calibration), str(out / "switching" / name)))
                 for name in studies])

    def finish() -> None:
        try:
            done = wait()
        except KeyboardInterrupt:
            _studies_stopped(out)
            raise
        with ignore_signals():   # the report's table and the summary belong together
            summary_path = out / "summary.json"
            summary = json.loads(summary_path.read_text())
            add_switching_section(out, done)
            write_json(summary_path, {**summary, "switching": [
                f"switching/{job.removeprefix('switching study ')}" for job in done]})

    return finish


def _studies_stopped(out: Path) -> None:
    """Mark the studies stopped in summary.json (the calibration stays complete)."""
    from fe_impact.output.files import write_json

    summary_path = out / "summary.json"
    with ignore_signals():
        write_json(summary_path, {**json.loads(summary_path.read_text()),
                                  "switching": "stopped"})


class CaseStopped(CalibrationError):
    """A case stopped part-way because the sweep was interrupted."""


def _run_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
              progress, finish: Callable[[Draw], Path] | None = None,
              numba: Path | None = None) -> Path | None:
    _import_distributed()
    with contextlib.ExitStack() as stack:
        return _sweep_on_dask(todo, settings, gearset_text, out, cache, workers, scheduler,
                              sweep, progress, stack, finish, numba)


def _sweep_on_dask(todo, settings, gearset_text, out, cache, workers, scheduler, sweep,
                   progress, stack: contextlib.ExitStack,
                   finish: Callable[[Draw], Path] | None = None,
                   numba: Path | None = None) -> Path | None:
    """Run ``todo`` on a local cluster or ``scheduler``; then, every case done, return
    ``finish(draw)`` with a :data:`~fe_impact.output.drawing.Draw` on the same workers."""
    from dask.distributed import Client, Event

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, ValueError) as exc:
            raise CalibrationError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
        cluster = None
    else:
        if numba is None:
            numba = stack.enter_context(numba_folder(Path(cache)))
        cluster, client = _local_cluster(workers or max(1, min(len(todo), _cores())), numba)
    stop_name = f"fe-impact-stop-{uuid.uuid4().hex}"
    try:
        order = _sweep_order(todo)
        futures = {client.submit(run_locked_case, c, settings, gearset_text, str(out),
                                 str(cache), stop_name,
                                 key=f"fe-impact-{c.id}-{case_hash(c, settings, gearset_text)}",
                                 priority=len(order) - i, pure=False): c
                   for i, c in enumerate(order)}
        failures: list[str] = []
        with _interrupt_flag() as interrupted:
            try:
                _collect(futures, sweep, failures, progress, interrupted)
            except KeyboardInterrupt:
                with ignore_signals():   # stopping is bounded by STOP_GRACE
                    _stop_cases(Event(stop_name, client=client), futures)
                raise
        if failures:
            raise CalibrationError(f"{len(failures)} case(s) failed (finished cases are kept; "
                                   "rerun to retry): " + "; ".join(failures))
        return None if finish is None else finish(draw_on(client))
    finally:
        with ignore_signals():
            client.close()
            if cluster is not None:
                cluster.close()
        _clean_cases(out, todo)


def _sweep_order(cases: list) -> list:
    """The order the cases are handed out in.

    Largest models first (impacts before the quasi-static positions, slower
    impacts: finer meshes), so the last case to finish is a small one; the
    impacts' stages taken in turn (the slowest of each stage, then the next
    speed), so that the workers start on different stages and build different
    sector solids, which they then share (:func:`~fe_impact.meshing.toothpair.share_solids`):
    with the stages one after the other both workers built stage 3's at once.
    The corner cases (``--corners``, ``--corner-impacts``) go before everything:
    a tip edge's contact zone is long and finely meshed (a coarse approach
    corner: 223k DOFs, 6 minutes static), the face gear's edge (approach)
    before the pinion's.
    """
    rank: dict[int, list] = {}
    for c in sorted((c for c in cases if not isinstance(c, PositionCase)),
                    key=lambda c: c.impact_speed):
        rank.setdefault(c.stage, []).append(c.id)

    def group(c) -> int:
        where = c.contact if isinstance(c, PositionCase) else c.kind
        return {"corner-approach": 0, "corner-recess": 1}.get(
            where, 3 if isinstance(c, PositionCase) else 2)

    return sorted(cases, key=lambda c: (
        group(c), 0 if isinstance(c, PositionCase) else rank[c.stage].index(c.id),
        -c.face_teeth, c.impact_speed))


def _collect(futures: dict, sweep: Sweep, failures: list[str], progress,
             interrupted: threading.Event) -> None:
    """Wait for the cases, recording each as it finishes."""
    pending = dict(futures)
    while pending:
        # Poll rather than block in the client: a Ctrl-C that lands while
        # dask's machinery runs can be swallowed there, the flag is not.
        if interrupted.is_set():
            raise Interrupted(interrupted.signum)
        finished = [f for f in pending if f.done()]
        if not finished:
            time.sleep(0.2)
            continue
        for fut in finished:
            c = pending.pop(fut)
            try:
                record = fut.result()
                if record is None:   # stopped (only after an interrupt)
                    continue
                sweep.done[c.id] = record
            except Exception as exc:  # a failed case does not stop the others
                failures.append(f"{c.id}: {exc}")
                logger.error("case %s failed: %s", c.id, exc)
            if progress is not None:
                progress(len(sweep.done), len(sweep.cases), c.id)


def _stop_cases(stop, futures: dict) -> None:
    """Tell every case to stop (:func:`run_locked_case` watches ``stop``) and wait for them.

    Cases not started yet end at once; running ones at their next Python
    statement. At most :data:`STOP_GRACE` seconds.
    """
    try:
        stop.set()
    except Exception as exc:   # scheduler gone: the workers are going too
        logger.info("could not signal the workers to stop: %s", exc)
        return
    deadline = time.monotonic() + STOP_GRACE
    while time.monotonic() < deadline and not all(f.done() for f in futures):
        time.sleep(0.1)
    running = [c.id for f, c in futures.items() if not f.done()]
    if running:
        logger.warning("cases %s did not stop within %g s; their workers are closed", running,
                       STOP_GRACE)


def _clean_cases(out, cases: list[ImpactCase]) -> None:
    """Delete temporary files in the folders of ``cases`` that no process is writing."""
    for c in cases:
        folder = Path(out) / "cases" / c.id
        if not folder.is_dir():
            continue
        with folder_lock(folder, wait=False) as free:
            if free:
                for path in remove_temporaries(folder):
                    logger.info("removed the unfinished file %s", path)


@contextlib.contextmanager
def numba_folder(cache: Path) -> Iterator[Path]:
    """Where this run's local workers keep their compiled numba kernels, held for the run.

    The user's cache (``$XDG_CACHE_HOME`` or ``~/.cache``, then
    ``fe-impact/numba/slotK``), so that a run with a new mesh cache does not
    compile them again (about 7 s a worker at its first case, measured on
    the coarse calibration); ``cache/numba`` if that cannot be written. A
    run holds its slot's lock while it lives: runs at the same time take
    different slots (two processes compiling into one folder at once can
    leave files that crash a later load), later runs the first free one.
    """
    from fe_impact.runtime import user_cache

    root = user_cache("numba") or Path(cache) / "numba"
    for k in range(64):
        with folder_lock(root / f"slot{k}", wait=False) as held:
            if held:
                yield root / f"slot{k}"
                return
    yield Path(cache) / "numba"   # 64 runs at once: share the mesh cache's folder


def _local_cluster(n: int, numba_cache: Path | None = None):
    """A local Dask cluster of ``n`` single-thread worker processes and its client.

    The workers are started with SIGINT and SIGTERM ignored (they keep
    that): Ctrl-C in a terminal signals the whole process group, and a
    worker that got it printed tracebacks and stopped mid-write. The
    scheduler's HTTP server (the dashboard's) takes a free port, so a second
    run never finds 8787 taken. With ``numba_cache``, each worker compiles
    its numba kernels into a folder of its own (``numba_cache/wN``): two
    processes compiling one cached kernel into one folder at once can leave
    an index and a data file that do not belong together, and a process
    that loads them crashes (numba/numba#4807, #10128). The folders are
    stable per worker name, so a later run loads its compiled kernels.

    Each worker may use the machine's memory divided by ``n``: Dask's
    default divides it by the number of cores whatever ``n`` is, so a single
    worker on two cores was restarted at half the memory (a stage-3
    approach corner, ``--corners --workers 1``, at 11.7 GB of 23).
    """
    from dask.distributed import Client, LocalCluster
    from distributed.system import MEMORY_LIMIT

    class _Cluster(LocalCluster):
        def new_worker_spec(self):
            spec = super().new_worker_spec()
            if numba_cache is None:
                return spec
            out = {}
            for name, s in spec.items():
                options = dict(s.get("options", {}))
                options["env"] = {**options.get("env", {}),
                                  "NUMBA_CACHE_DIR": str(Path(numba_cache) / f"w{name}")}
                out[name] = {**s, "options": options}
            return out

    cluster = _Cluster(n_workers=0, threads_per_worker=1, processes=True,
                           memory_limit=int(MEMORY_LIMIT // max(n, 1)),
                           dashboard_address=None, silence_logs=logging.ERROR,
                           scheduler_kwargs={"dashboard_address": ":0"})
    try:
        before = _spawned_children()
        with ignore_signals():
            cluster.scale(n)
            _wait_spawned(cluster, n, before)
        client = Client(cluster)
    except BaseException:
        cluster.close()
        raise
    return cluster, client


def _spawned_children() -> int | None:
    """How many child processes run multiprocessing's spawn entry point (Linux), or None."""
    try:
        pids = {pid for task in Path("/proc/self/task").iterdir()
                for pid in (task / "children").read_text().split()}
    except OSError:
        return None
    count = 0
    for pid in pids:
        with contextlib.suppress(OSError):
            count += b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()
    return count


def _wait_spawned(cluster, n: int, before: int | None, timeout: float = 60.0) -> None:
    """Wait until the ``n`` worker processes exist (a started process keeps ``SIG_IGN``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        count = _spawned_children()
        if count is not None and before is not None:
            if count >= before + n:
                return
        elif len(cluster.workers) >= n and all(
                getattr(getattr(w, "process", None), "pid", None)
                for w in cluster.workers.values()):
            return
        time.sleep(0.02)


@contextlib.contextmanager
def _interrupt_flag():
    """An event set by SIGINT (Ctrl-C) or SIGTERM while the sweep waits.

    The handler also raises :class:`~fe_impact.interrupts.Interrupted` at
    once; the event (with the signal number as ``flag.signum``) keeps the
    interrupt if some library code in between catches it. The old handlers
    are restored at the end.
    """
    flag = threading.Event()
    flag.signum = None

    def note(signum: int) -> None:
        flag.signum = signum
        flag.set()

    with handle_signals(note):
        yield flag


# -- one case under its lock (runs on a worker) -------------------------------------------


def run_locked_case(case: ImpactCase, settings: Settings, gearset_text: str, out: str,
                    cache: str, stop_name: str | None = None) -> CalibrationRecord | None:
    """:func:`run_case` holding the case folder's lock; stops when ``stop_name`` is set.

    Waits while another process holds the lock (a second run on the same
    output folder) and then returns that run's result if it finished the
    case. Before computing, deletes the temporary files a killed run left in
    the case folder. ``stop_name`` names a ``distributed.Event``: once it is
    set the case stops and None is returned (a stop is not a failure: the
    worker logs nothing).
    """
    folder = Path(out) / "cases" / case.id
    _quiet_asyncio()
    try:
        with _stop_watch(stop_name, case.id), _case_lock(folder, case.id):
            record = finished_record(Path(out), case, settings, gearset_text)
            if record is not None:
                logger.info("case %s: finished by another run", case.id)
                return record
            for path in remove_temporaries(folder):
                logger.info("removed the unfinished file %s", path)
            return run_case(case, settings, gearset_text, out, cache)
    except (KeyboardInterrupt, CaseStopped):
        # A stopped case ends as an ordinary return, not by unwinding the worker.
        return None


class _UnretrievedTimeout(logging.Filter):
    """Drops asyncio's "Future exception was never retrieved" records of a ``TimeoutError``."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not (isinstance(exc, TimeoutError)
                    and str(record.msg).startswith("Future exception was never retrieved"))


def _quiet_asyncio() -> None:
    """Filter one kind of record out of this process's ``asyncio`` logger, once.

    A stop, or a scheduler closing, can leave one of Dask's internal futures
    with a ``TimeoutError`` nobody retrieves; in a worker process, whose
    ``asyncio`` logger has no handler, Python's last-resort handler then
    printed "Future exception was never retrieved" into the user's terminal
    in the middle of a clean Ctrl-C (seen once, in the interrupt test under
    the test suite's load). Only that record is dropped: a case's own failure
    reaches the user through its future, and other asyncio errors still show.
    """
    log = logging.getLogger("asyncio")
    if not any(isinstance(f, _UnretrievedTimeout) for f in log.filters):
        log.addFilter(_UnretrievedTimeout())


@contextlib.contextmanager
def _case_lock(folder: Path, case_id: str):
    """Hold the case folder's lock, polling (a stop request must get through the wait)."""
    waited = False
    while True:
        with folder_lock(folder, wait=False) as held:
            if held:
                yield
                return
        if not waited:
            logger.info("case %s: another run is computing it; waiting", case_id)
            waited = True
        time.sleep(STOP_POLL)


@contextlib.contextmanager
def _stop_watch(stop_name: str | None, case_id: str):
    """Raise KeyboardInterrupt in this thread once the event ``stop_name`` is set.

    A watcher thread polls the event (and the worker's status: a closing
    worker stops its case too) every :data:`STOP_POLL` s and raises the
    exception asynchronously in the case's thread, which gets it at its next
    Python statement. Outside a Dask worker nothing is watched.
    """
    import ctypes

    try:
        from distributed import Event, get_client, get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        worker = None
    if stop_name is None or worker is None:
        yield
        return
    event = Event(stop_name, client=get_client())
    if event.is_set():
        raise CaseStopped(f"case {case_id}: stopped before it started")
    target = threading.get_ident()
    guard = threading.Lock()
    finished = threading.Event()

    def raise_in_target(exc) -> None:
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target),
                                                   None if exc is None else ctypes.py_object(exc))

    def watch() -> None:
        while not finished.wait(STOP_POLL):
            try:
                stop = event.is_set() or worker.status.name not in ("running", "paused")
            except Exception:   # the scheduler is gone: the run is over
                stop = True
            if stop:
                with guard:
                    if not finished.is_set():
                        logger.info("case %s: stopping", case_id)
                        raise_in_target(Interrupted)
                return

    thread = threading.Thread(target=watch, name=f"stop-watch-{case_id}", daemon=True)
    thread.start()
    try:
        yield
    finally:
        with guard:
            finished.set()
            raise_in_target(None)   # one raised too late would hit the worker's own code


def _cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else \
        (os.cpu_count() or 1)
