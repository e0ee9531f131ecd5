"""One call for a rolling run: check the inputs, mesh, integrate, write the outputs.

:func:`roll` is what ``fe-impact roll`` runs; :func:`check_inputs` refuses, in one
line each, what the model cannot take (the command's bad input).
"""

from __future__ import annotations

import contextlib
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fe_impact.errors import CaseError

logger = logging.getLogger(__name__)

__all__ = ["RollInputs", "check_inputs", "passed_through", "roll", "sector_mesh"]

#: Time steps per Hertz contact time of the fastest mesh-in the run can see, at least.
STEPS_PER_CONTACT = 8
#: Largest Hertz pressure of the nominal mesh force, as a multiple of the yield strength
#: (the sectors are elastic: beyond ~1.6 sigma_y the flanks yield, Johnson 1985 s. 6.2).
MAX_PRESSURE_OVER_YIELD = 1.6
#: Fewest time steps per mesh cycle: the transmission error's harmonics up to the 5th
#: (the comparison's spectrum) sampled at 4 points a period at least.
MIN_STEPS_PER_CYCLE = 20
#: Largest kinematic TE amplitude, as a fraction of the total normal backlash. A profile
#: error is a few um; half the seed's backlash (69 um) is already about ISO 1328-1:2013's
#: coarsest grade (11: F_alpha = 63 um at m = 3 mm, d = 57 mm), so a larger one is not a
#: gear anyone makes but a unit slip (mm for um).
MAX_TE_OVER_BACKLASH = 0.5


@dataclass(frozen=True)
class RollInputs:
    """What a rolling run is asked for (SI units but the speed in r/min).

    ``steps_per_cycle``: time steps per mesh cycle; ``ramp_cycles``: the load
    torque's ``sin^2`` rise; ``te_amplitude`` [m]: a kinematic TE excitation
    (:class:`~fe_impact.rolling.model.RollSettings`); ``stiffen``: Young's
    modulus factor; ``start_cycles``: where pair 0 starts, in base pitches after
    the path's start (None: the sectors' longest window,
    :class:`~fe_impact.rolling.model.RollSettings`); ``elastic``: False for rigid
    rotors (Hertz only); ``probe_depth``
    [m]: where the sectors' displacement is read below the contact point (None: the
    default, two flank element sizes; 0: on the surface, with the Hertz approach added);
    ``friction``: Coulomb friction between the flanks with the gear set's ``[friction]``
    coefficients (the lumped model's law, :mod:`fe_impact.rolling.friction`; none
    when the set gives 0 and 0), False: frictionless flanks; ``teeth``: teeth of each
    sector (:data:`~fe_impact.rolling.sectors.TEETH_RANGE`; more hold more mesh cycles).
    """

    stage: int
    speed_rpm: float
    torque_nm: float
    cycles: float
    level: str = "coarse"
    steps_per_cycle: int = 240
    ramp_cycles: float = 1.0
    speed_ramp_cycles: float = 0.0
    te_amplitude: float = 0.0
    stiffen: float = 1.0
    elastic: bool = True
    frames_per_cycle: int = 20
    start_cycles: float | None = None
    probe_depth: float | None = None
    friction: bool = True
    teeth: int = 5


def _speed_rad(rpm: float) -> float:
    return rpm * 2.0 * math.pi / 60.0


def check_inputs(gearset, inputs: RollInputs, check_step: bool = True) -> None:
    """Refuse inputs the model cannot take, one line naming the option each.

    In order: the stage; the sectors' teeth; the speed, cycles and torque as numbers; the speed
    against the fastest pitch-line speed a gear set may run at (as the
    switching schedules do); the level; the steps per cycle; the ramps (the
    load must reach its torque within the run); the TE amplitude against the
    backlash; the torque against the flanks' static contact strength (all
    modes) and, for elastic sectors, their yield; last the time step against
    the mesh-in impacts (``check_step``).

    Raises
    ------
    CaseError
    """
    from fe_impact.gears.kinematics import default_backlash
    from fe_impact.gears.tca import GearPair
    from fe_impact.meshing.sizing import LEVELS
    from fe_impact.rolling.sectors import check_teeth
    from fe_impact.switching.schedule import speed_problem

    n = len(gearset.stages)
    if not (isinstance(inputs.stage, int) and 1 <= inputs.stage <= n):
        raise CaseError(f"--stage {inputs.stage}: the gear set '{gearset.name}' has stages "
                        f"1..{n}; pick one of them")
    check_teeth(inputs.teeth)
    for name, value in (("--speed", inputs.speed_rpm), ("--cycles", inputs.cycles)):
        if not (math.isfinite(value) and value > 0.0):
            raise CaseError(f"{name} {value:g}: must be a number > 0")
    if not (math.isfinite(inputs.torque_nm) and inputs.torque_nm >= 0.0):
        raise CaseError(f"--torque {inputs.torque_nm:g}: must be a number >= 0 (N m on the "
                        "face gear, against its rotation)")
    message = speed_problem(gearset, inputs.speed_rpm)
    if message:
        raise CaseError(f"--speed {message}")
    if inputs.level not in LEVELS:
        raise CaseError(f"--level {inputs.level}: pick one of {', '.join(LEVELS)}")
    steps = inputs.steps_per_cycle
    if not (isinstance(steps, int | np.integer) and steps >= MIN_STEPS_PER_CYCLE):
        raise CaseError(f"--steps-per-cycle {steps}: must be a whole number >= "
                        f"{MIN_STEPS_PER_CYCLE} (the TE's first 5 harmonics at 4 steps a "
                        "period); ask for 240, the default")
    for name, value in (("--ramp-cycles", inputs.ramp_cycles),
                        ("speed_ramp_cycles", inputs.speed_ramp_cycles)):
        if name == "--ramp-cycles" and inputs.torque_nm == 0.0 and math.isfinite(value) \
                and value >= 0.0:
            continue        # no load to ramp
        if not (math.isfinite(value) and 0.0 <= value < inputs.cycles):
            raise CaseError(f"{name} {value:g}: must be >= 0 and below --cycles "
                            f"{inputs.cycles:g}, so that the run reaches its full load "
                            "and speed; ask for fewer ramp cycles or more --cycles")
    pair = GearPair.from_gearset(gearset, inputs.stage)
    backlash = default_backlash(gearset.module, pair.pinion.pitch_radius,
                                pair.face.pitch_radius)
    top = MAX_TE_OVER_BACKLASH * backlash
    if not (math.isfinite(inputs.te_amplitude) and abs(inputs.te_amplitude) <= top):
        raise CaseError(f"--te-amplitude {inputs.te_amplitude * 1e6:g} um: at most "
                        f"{top * 1e6:.4g} um, half the stage's backlash "
                        f"({backlash * 1e6:.4g} um): a profile error is a few um (the "
                        "option is in um)")
    ellipse, force = _nominal_ellipse(gearset, inputs, pair)
    _check_torque(gearset, inputs, ellipse, force)
    if check_step:
        _check_step(gearset, inputs, pair, force)


def _nominal_ellipse(gearset, inputs: RollInputs, pair):
    """The Hertz ellipse at the pitch point under the load torque's mesh force (>= 1 N)."""
    from fe_impact.gears.tca import contact_ellipse
    from fe_impact.physics import hertz

    mat = gearset.material
    e_star = hertz.effective_modulus(mat.youngs_modulus, mat.poisson_ratio)
    r_b2 = pair.face.pitch_radius * math.cos(pair.pinion.pressure_angle)
    force = max(inputs.torque_nm / r_b2, 1.0)
    return contact_ellipse(pair.contact(0.0).relative, force, e_star), force


def _check_torque(gearset, inputs: RollInputs, ellipse, force: float) -> None:
    """The load torque against the flanks' static contact strength (as the switching
    schedules' `load_problem`, for one mesh) and, for elastic sectors, their yield."""
    from fe_impact.switching.schedule import STATIC_CONTACT_FACTOR

    if inputs.torque_nm <= 0.0:
        return
    mat = gearset.material
    limits = [(STATIC_CONTACT_FACTOR * mat.contact_stress_limit,
               f"the flanks' static contact strength ({STATIC_CONTACT_FACTOR:g} x "
               "contact_stress_limit_pa, ISO 6336-2)")]
    if inputs.elastic:
        limits.append((MAX_PRESSURE_OVER_YIELD * mat.yield_strength,
                       f"the elastic sectors' limit ({MAX_PRESSURE_OVER_YIELD:g} x yield)"))
    for limit, what in limits:
        if ellipse.p0 > limit:
            top = inputs.torque_nm * (limit / ellipse.p0) ** 3    # p0 ~ force^(1/3)
            raise CaseError(f"--torque {inputs.torque_nm:g}: its mesh force {force:.4g} N "
                            f"presses the flanks to p0 = {ellipse.p0 / 1e6:.0f} MPa, beyond "
                            f"{what} {limit / 1e6:.0f} MPa; ask for at most {top:.4g} N m "
                            "(N m on the face gear, one mesh)")


def _contact_time(gearset, inputs: RollInputs, pair, force: float, speed_rpm: float
                  ) -> tuple[float, float]:
    """``(dt, t_c)``: the time step at ``speed_rpm`` and the Hertz contact time of the
    fastest mesh-in it can see [s].

    The closing speed of a corner contact at the tip edge is of order the
    pitch-line speed times the corner gap's slope; it is bounded by the
    rigid-body closing speed of the loaded approach (Hertz approach over the
    corner's roll). ``dt / t_c`` falls as ``speed^-0.8`` (``t_c ~ v^-1/5``).
    """
    from fe_impact.gears.tca import equivalent_radius
    from fe_impact.physics import hertz

    mat = gearset.material
    e_star = hertz.effective_modulus(mat.youngs_modulus, mat.poisson_ratio)
    speed = _speed_rad(speed_rpm)
    radius = equivalent_radius(pair.contact(0.0).relative, e_star)
    delta = (force / (4.0 / 3.0 * e_star * math.sqrt(radius))) ** (2 / 3)
    v_close = speed * pair.pinion.pitch_radius * math.sqrt(2.0 * max(delta, 1e-9)
                                                           / pair.pinion.module)
    r_b2 = pair.face.pitch_radius * math.cos(pair.pinion.pressure_angle)
    m_eff = 1.0 / (r_b2**2 / gearset.stages[inputs.stage - 1].inertia
                   + (pair.pinion.pitch_radius * math.cos(pair.pinion.pressure_angle)) ** 2
                   / gearset.pinion.inertia)
    impact = hertz.impact(m_eff, max(v_close, 1e-6), radius, e_star)
    dt = 2.0 * math.pi / pair.pinion.teeth / speed / inputs.steps_per_cycle
    return dt, impact.contact_time


def _check_step(gearset, inputs: RollInputs, pair, force: float) -> None:
    """The time step against the fastest mesh-in's Hertz contact time."""
    from fe_impact.switching.schedule import top_speed_rpm

    dt, t_c = _contact_time(gearset, inputs, pair, force, inputs.speed_rpm)
    ratio = dt * STEPS_PER_CONTACT / t_c
    if ratio <= 1.0:
        return
    need = math.ceil(inputs.steps_per_cycle * ratio)
    # the speed at which the same steps resolve it: dt / t_c ~ speed^-0.8, then made
    # sure of (a few per cent up at most)
    faster = inputs.speed_rpm * ratio ** 1.25
    for _ in range(20):
        dt2, t_c2 = _contact_time(gearset, inputs, pair, force, faster)
        if dt2 * STEPS_PER_CONTACT <= t_c2:
            break
        faster *= 1.01
    speed_hint = (f", or a --speed of at least {math.ceil(faster):d} r/min (the step "
                  "shrinks faster than the contact time)"
                  if faster <= top_speed_rpm(gearset) else "")
    raise CaseError(
        f"--steps-per-cycle {inputs.steps_per_cycle}: at --speed {inputs.speed_rpm:g} r/min "
        f"its step ({dt * 1e6:.3g} us) cannot resolve the mesh-in impacts the gear set's "
        f"inertias take ({t_c * 1e6:.3g} us of Hertz contact, {STEPS_PER_CONTACT} steps "
        f"each); ask for --steps-per-cycle {need}{speed_hint}; a quasi-static run (no "
        "impacts to resolve) takes --quasi-static")


def roll(gearset, inputs: RollInputs, out: str | Path | None = None, *, progress=None,
         stop=None, mesh_dir: str | Path | None = None, check_step: bool = True,
         while_stepping=None):
    """Run the rolling mesh; write its outputs to ``out`` if given.

    Parameters
    ----------
    gearset : GearSet
    inputs : RollInputs
    out : path, optional
        Output folder (:func:`fe_impact.rolling.output.write_outputs`); nothing is
        written there before the time loop starts.
    progress : callable(step, n_steps), optional
    stop : callable() -> bool, optional
        True ends the run after the current step (Ctrl-C); what is done is written.
    mesh_dir : path, optional
        Where the sector mesh is (re)used: ``sectors.msh`` there if present with a
        matching ``sectors.json``; default ``out/mesh``. A mesh interrupted while
        being made leaves nothing there.
    check_step : bool
        Refuse a step that cannot resolve the mesh-in impacts (:func:`check_inputs`);
        False for a quasi-static run, where the step follows the load's variation.
    while_stepping : context manager, optional
        Entered around the time loop alone (the command's Ctrl-C handler, which
        turns a signal into ``stop``); during the set-up a signal ends the run at
        once.

    Returns
    -------
    RollResult
    """
    import contextlib

    from fe_impact.fe.linalg import limit_threads
    from fe_impact.rolling.friction import friction_of
    from fe_impact.rolling.model import ContactGeometry, Roller, RollSettings, rigid_body
    from fe_impact.rolling.run import integrate
    from fe_impact.rolling.sectors import tooth_range

    check_inputs(gearset, inputs, check_step)
    settings = RollSettings(speed=_speed_rad(inputs.speed_rpm), torque=inputs.torque_nm,
                            cycles=inputs.cycles, steps_per_cycle=inputs.steps_per_cycle,
                            ramp_cycles=inputs.ramp_cycles,
                            speed_ramp_cycles=inputs.speed_ramp_cycles,
                            te_amplitude=inputs.te_amplitude,
                            start_cycles=inputs.start_cycles,
                            probe_depth=inputs.probe_depth)
    geo = ContactGeometry.build(gearset, inputs.stage, stiffen=inputs.stiffen)
    pair = geo.pair
    rigid = (rigid_body("pinion", gearset.pinion.inertia, *pair.pinion_axis),
             rigid_body("face_gear", gearset.stages[inputs.stage - 1].inertia,
                        *pair.face_axis))
    pinion, face = rigid
    try:    # on rigid rotors first: cycles beyond the sectors refused before any meshing
        roller = Roller(geo, pinion, face, tooth_range(inputs.teeth), 0.0,
                        pair.nominal_face_angle(0.0), settings)
    except CaseError as exc:
        raise CaseError(f"{_window_options(inputs)}: {exc}") from exc
    mesh = None
    if inputs.elastic:
        mesh = sector_mesh(gearset, inputs, Path(mesh_dir) if mesh_dir else (
            Path(out) / "mesh" if out else Path("rolling_mesh")))
        _ellipse_resolution(gearset, inputs, pair, mesh)
        from fe_impact.rolling.bodies import sector_bodies
        pinion, face = sector_bodies(mesh["mesh_path"], gearset, inputs.stage, inputs.stiffen,
                                     inputs.teeth)
        try:
            roller = Roller(geo, pinion, face, tooth_range(inputs.teeth),
                            mesh["pinion_roll_placed"],
                            mesh["face_angle_placed"], settings)
        except CaseError as exc:
            raise CaseError(f"{_window_options(inputs)}: {exc}") from exc
    frames = None
    if out is not None and inputs.elastic:
        from fe_impact.rolling.output import FrameWriter
        frames = FrameWriter(Path(out), roller, mesh["mesh_path"],
                             max(1, inputs.steps_per_cycle // inputs.frames_per_cycle))
    if out is not None:     # the set-up is done: an earlier run's frames go now
        from fe_impact.rolling.output import clear_frames
        clear_frames(Path(out))
    with limit_threads(1), (while_stepping or contextlib.nullcontext()):
        result = integrate(roller, progress=progress, stop=stop,
                           frame=frames.write if frames else None,
                           friction=friction_of(gearset) if inputs.friction else None)
    result.info.update(inputs=inputs.__dict__, gearset=gearset.name,
                       backlash_m=geo.backlash, mesh=mesh, probe_depth_m=roller.depth,
                       probe_depth_range_m=getattr(roller, "depth_range", None),
                       flank_element_m=max(pinion.flank_size, face.flank_size),
                       inertial_terms=_inertial(roller, result))
    result.info["passed_through"] = passed_through(result, geo.backlash)
    if result.info["passed_through"]:
        logger.warning("%s", result.info["passed_through"])
    if out is not None:
        from fe_impact.rolling.output import write_outputs
        write_outputs(Path(out), result, roller)
    return result


def passed_through(result, backlash: float) -> str:
    """"" or why the teeth went through each other: flanks overlapping with no force.

    The TE is 0 where the drive flanks touch unloaded and ``-backlash`` where the
    coast flanks do. A TE a quarter of the backlash beyond either while that
    flank carries no force at all is an overlap the contact did not find (a
    loaded flank's approach and bending are what the force explains).
    """
    te = result.te_m
    force = np.nan_to_num(result.pair_force_n).sum(axis=1)      # (n, 2) drive, coast
    drive = (te > 0.25 * backlash) & (force[:, 0] <= 0.0)
    coast = (te < -1.25 * backlash) & (force[:, 1] <= 0.0)
    if not (drive.any() or coast.any()):
        return ""
    n = int(np.flatnonzero(drive | coast)[0])
    return (f"the teeth went through each other: TE {te[n] * 1e6:.4g} um at "
            f"{result.time_s[n] * 1e3:.4g} ms with no force on that flank (backlash "
            f"{backlash * 1e6:.4g} um); the contact was not found on this gear set: the "
            "results are not valid")


def _window_options(inputs: RollInputs) -> str:
    """The options that place the run in the sectors' window, as the message names them."""
    if inputs.start_cycles is None:
        return f"--cycles {inputs.cycles:g}"
    return (f"--cycles {inputs.cycles:g} from start_cycles {inputs.start_cycles:g} (pair 0 "
            "that many base pitches after the path's start; None: the window's start)")


def _ellipse_resolution(gearset, inputs: RollInputs, pair, mesh: dict) -> None:
    """Say (log, and ``mesh['ellipse']``) whether the flank elements are smaller than the
    Hertz ellipse's major semi-axis at the load torque.

    Not a refusal: the pair's local compliance is Hertz's closed form, the
    sectors carry the force spread along the ellipse; and at no load (the
    rattle cases) the ellipse of any impact is smaller than every level's
    flank element (0.29 mm at 1 N against the fine level's 0.75 mm).
    """
    ellipse, force = _nominal_ellipse(gearset, inputs, pair)
    from fe_impact.rolling.sectors import FLANK_FRACTION

    element = FLANK_FRACTION * mesh["size_m"]
    mesh["ellipse"] = {"force_n": force, "major_semi_axis_m": ellipse.a,
                       "flank_element_m": element, "resolved": bool(element <= ellipse.a)}
    if inputs.torque_nm > 0.0 and element > ellipse.a:
        logger.warning("--level %s: its flank elements (%.3g mm) are larger than the Hertz "
                       "ellipse's major semi-axis at --torque %g (%.3g mm): the sectors see "
                       "the pair force spread over less than an element", inputs.level,
                       element * 1e3, inputs.torque_nm, ellipse.a * 1e3)


def sector_mesh(gearset, inputs: RollInputs, folder: Path) -> dict:
    """The sector mesh of ``inputs``' stage and level, reused when already written.

    ``mesh_path`` is ``folder / "sectors.msh"`` (``sectors.json`` stores it relative
    to the folder, so the folder may be reused from anywhere). A new mesh is made in
    a temporary folder beside ``folder`` and moved in whole: an interrupted meshing
    leaves nothing (the folders it made are removed again).
    """
    import hashlib
    import json
    import os
    import shutil
    import tempfile
    from dataclasses import asdict

    from fe_impact.atomic import write_json
    from fe_impact.rolling.sectors import build_sectors, split_teeth

    loaded, neighbours = split_teeth(inputs.teeth)
    key = hashlib.sha256(json.dumps(
        {"gearset": asdict(gearset), "stage": inputs.stage, "level": inputs.level,
         "teeth": loaded, "neighbours": neighbours, "format": 1}, sort_keys=True,
        default=repr).encode()).hexdigest()[:16]
    folder = Path(folder)
    summary = folder / "sectors.json"
    if summary.exists() and (folder / "sectors.msh").exists():
        data = json.loads(summary.read_text())
        if data.get("key") == key:
            return {**data, "mesh_path": str(folder / "sectors.msh")}
    made = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}-", dir=folder.parent))
    try:
        mesh = build_sectors(gearset, inputs.stage, inputs.level, tmp, teeth=inputs.teeth)
        data = {**mesh.to_dict(), "mesh_path": "sectors.msh", "key": key}
        write_json(tmp / "sectors.json", data)
        folder.mkdir(exist_ok=True)
        for name in ("sectors.msh", "sectors.json"):    # the mesh first, its summary last
            os.replace(tmp / name, folder / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if not (folder / "sectors.json").exists():     # interrupted or failed
            for p in made:      # innermost first; only what this call made, if empty
                with contextlib.suppress(OSError):
                    p.rmdir()
    return {**data, "mesh_path": str(folder / "sectors.msh")}


def _inertial(roller, result) -> dict:
    """Centrifugal and Coriolis forces left out, against the mean mesh force."""
    from fe_impact.rolling.model import inertial_terms

    force = result.pair_force_n.sum(axis=(1, 2))
    mean = float(np.mean(force[len(force) // 2:])) if len(force) > 1 else 0.0
    mesh_force = max(mean, roller.set.torque / roller.r_b2, 1e-300)
    pair = roller.geo.pair
    speed = roller.set.speed
    out = {}
    for body, radius, w in ((roller.p, pair.pinion.pitch_radius, speed),
                            (roller.f, pair.face.pitch_radius, speed * roller.ratio)):
        mass = getattr(body, "mass", 0.0)
        te_rate = np.diff(result.te_m) / max(roller.dt, 1e-300)
        elastic_speed = float(np.abs(te_rate).max(initial=0.0))
        tooth_mass = mass / (2 * (max(roller.teeth) - min(roller.teeth) + 1))
        out[body.name] = {**inertial_terms(tooth_mass, radius, w, mesh_force, elastic_speed),
                          "centrifugal_included": bool(getattr(body, "centrifugal", None)
                                                       is not None),
                          "coriolis_included": False}
    return out
