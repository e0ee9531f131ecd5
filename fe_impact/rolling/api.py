"""One call for a rolling run: check the inputs, mesh, integrate, write the outputs.

:func:`roll` is what ``fe-impact roll`` runs; :func:`check_inputs` refuses, in one
line each, what the model cannot take (the command's bad input).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fe_impact.errors import CaseError

logger = logging.getLogger(__name__)

__all__ = ["RollInputs", "check_inputs", "roll"]

#: Time steps per Hertz contact time of the fastest mesh-in the run can see, at least.
STEPS_PER_CONTACT = 8
#: Largest Hertz pressure of the nominal mesh force, as a multiple of the yield strength
#: (the sectors are elastic: beyond ~1.6 sigma_y the flanks yield, Johnson 1985 s. 6.2).
MAX_PRESSURE_OVER_YIELD = 1.6


@dataclass(frozen=True)
class RollInputs:
    """What a rolling run is asked for (SI units but the speed in r/min).

    ``steps_per_cycle``: time steps per mesh cycle; ``ramp_cycles``: the load
    torque's ``sin^2`` rise; ``te_amplitude`` [m]: a kinematic TE excitation
    (:class:`~fe_impact.rolling.model.RollSettings`); ``stiffen``: Young's
    modulus factor; ``elastic``: False for rigid rotors (Hertz only).
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


def _speed_rad(rpm: float) -> float:
    return rpm * 2.0 * math.pi / 60.0


def check_inputs(gearset, inputs: RollInputs, check_step: bool = True) -> None:
    """Refuse inputs the model cannot take, one line naming the option each.

    Raises
    ------
    CaseError
    """
    from fe_impact.gears.tca import GearPair, contact_ellipse, equivalent_radius
    from fe_impact.meshing.sizing import LEVELS
    from fe_impact.physics import hertz

    n = len(gearset.stages)
    if not (isinstance(inputs.stage, int) and 1 <= inputs.stage <= n):
        raise CaseError(f"--stage {inputs.stage}: the gear set '{gearset.name}' has stages "
                        f"1..{n}; pick one of them")
    for name, value in (("--speed", inputs.speed_rpm), ("--cycles", inputs.cycles)):
        if not (math.isfinite(value) and value > 0.0):
            raise CaseError(f"{name} {value:g}: must be a number > 0")
    if not (math.isfinite(inputs.torque_nm) and inputs.torque_nm >= 0.0):
        raise CaseError(f"--torque {inputs.torque_nm:g}: must be a number >= 0 (N m on the "
                        "face gear, against its rotation)")
    if inputs.level not in LEVELS:
        raise CaseError(f"--level {inputs.level}: pick one of {', '.join(LEVELS)}")
    pair = GearPair.from_gearset(gearset, inputs.stage)
    mat = gearset.material
    e_star = hertz.effective_modulus(mat.youngs_modulus, mat.poisson_ratio)
    r_b2 = pair.face.pitch_radius * math.cos(pair.pinion.pressure_angle)
    force = max(inputs.torque_nm / r_b2, 1.0)
    contact = pair.contact(0.0)
    ellipse = contact_ellipse(contact.relative, force, e_star)
    limit = MAX_PRESSURE_OVER_YIELD * mat.yield_strength
    if ellipse.p0 > limit and inputs.elastic:
        top = inputs.torque_nm * (limit / ellipse.p0) ** 3
        raise CaseError(f"--torque {inputs.torque_nm:g}: its mesh force {force:.4g} N presses "
                        f"the flanks to {ellipse.p0 / 1e6:.0f} MPa, beyond the elastic "
                        f"sectors' {limit / 1e6:.0f} MPa (1.6 x yield); ask for at most "
                        f"{top:.3g} N m")
    # the fastest mesh-in: the closing speed of a corner contact at the tip edge is of
    # order the pitch-line speed times the corner gap's slope; bound it by the
    # rigid-body closing speed of the loaded approach (Hertz approach over the
    # corner's roll) and ask the step to resolve its Hertz contact time
    speed = _speed_rad(inputs.speed_rpm)
    radius = equivalent_radius(contact.relative, e_star)
    delta = (force / (4.0 / 3.0 * e_star * math.sqrt(radius))) ** (2 / 3)
    v_close = speed * pair.pinion.pitch_radius * math.sqrt(2.0 * max(delta, 1e-9)
                                                           / pair.pinion.module)
    m_eff = 1.0 / (r_b2**2 / gearset.stages[inputs.stage - 1].inertia
                   + (pair.pinion.pitch_radius * math.cos(pair.pinion.pressure_angle)) ** 2
                   / gearset.pinion.inertia)
    impact = hertz.impact(m_eff, max(v_close, 1e-6), radius, e_star)
    dt = 2.0 * math.pi / pair.pinion.teeth / speed / inputs.steps_per_cycle
    if check_step and dt > impact.contact_time / STEPS_PER_CONTACT:
        need = math.ceil(inputs.steps_per_cycle * dt * STEPS_PER_CONTACT / impact.contact_time)
        raise CaseError(
            f"--speed {inputs.speed_rpm:g}: at {inputs.steps_per_cycle} steps per mesh cycle "
            f"the step ({dt * 1e6:.3g} us) cannot resolve the mesh-in impacts the gear set's "
            f"inertias take at this speed ({impact.contact_time * 1e6:.3g} us of contact); "
            f"ask for --steps-per-cycle {need} or a lower speed")


def roll(gearset, inputs: RollInputs, out: str | Path | None = None, *, progress=None,
         stop=None, mesh_dir: str | Path | None = None, check_step: bool = True):
    """Run the rolling mesh; write its outputs to ``out`` if given.

    Parameters
    ----------
    gearset : GearSet
    inputs : RollInputs
    out : path, optional
        Output folder (:func:`fe_impact.rolling.output.write_outputs`).
    progress : callable(step, n_steps), optional
    stop : callable() -> bool, optional
        True ends the run after the current step (Ctrl-C); what is done is written.
    mesh_dir : path, optional
        Where the sector mesh is (re)used: ``sectors.msh`` there if present with a
        matching ``sectors.json``; default ``out/mesh``.
    check_step : bool
        Refuse a step that cannot resolve the mesh-in impacts (:func:`check_inputs`);
        False for a quasi-static run, where the step follows the load's variation.

    Returns
    -------
    RollResult
    """
    from fe_impact.fe.linalg import limit_threads
    from fe_impact.rolling.model import ContactGeometry, Roller, RollSettings, rigid_body
    from fe_impact.rolling.run import integrate
    from fe_impact.rolling.sectors import tooth_range

    check_inputs(gearset, inputs, check_step)
    settings = RollSettings(speed=_speed_rad(inputs.speed_rpm), torque=inputs.torque_nm,
                            cycles=inputs.cycles, steps_per_cycle=inputs.steps_per_cycle,
                            ramp_cycles=inputs.ramp_cycles,
                            speed_ramp_cycles=inputs.speed_ramp_cycles,
                            te_amplitude=inputs.te_amplitude)
    geo = ContactGeometry.build(gearset, inputs.stage, stiffen=inputs.stiffen)
    pair = geo.pair
    mesh = None
    if inputs.elastic:
        mesh = _sector_mesh(gearset, inputs, mesh_dir or (Path(out) / "mesh" if out else
                                                          Path("rolling_mesh")))
        from fe_impact.rolling.bodies import sector_bodies
        pinion, face = sector_bodies(mesh["mesh_path"], gearset, inputs.stage, inputs.stiffen)
        roll_placed, face_placed = mesh["pinion_roll_placed"], mesh["face_angle_placed"]
    else:
        pinion = rigid_body("pinion", gearset.pinion.inertia, *pair.pinion_axis)
        face = rigid_body("face_gear", gearset.stages[inputs.stage - 1].inertia,
                          *pair.face_axis)
        roll_placed, face_placed = 0.0, pair.nominal_face_angle(0.0)
    try:
        roller = Roller(geo, pinion, face, tooth_range(), roll_placed, face_placed, settings)
    except CaseError as exc:
        raise CaseError(f"--cycles {inputs.cycles:g}: {exc}") from exc
    frames = None
    if out is not None and inputs.elastic:
        from fe_impact.rolling.output import FrameWriter
        frames = FrameWriter(Path(out), roller, mesh["mesh_path"],
                             max(1, inputs.steps_per_cycle // inputs.frames_per_cycle))
    with limit_threads(1):
        result = integrate(roller, progress=progress, stop=stop,
                           frame=frames.write if frames else None)
    result.info.update(inputs=inputs.__dict__, gearset=gearset.name,
                       backlash_m=geo.backlash, mesh=mesh,
                       inertial_terms=_inertial(roller, result))
    if out is not None:
        from fe_impact.rolling.output import write_outputs
        write_outputs(Path(out), result, roller)
    return result


def _sector_mesh(gearset, inputs: RollInputs, folder: Path) -> dict:
    """The sector mesh of ``inputs``' stage and level, reused when already written."""
    import hashlib
    import json
    from dataclasses import asdict

    from fe_impact.atomic import write_json
    from fe_impact.rolling.sectors import NEIGHBOURS, TEETH, build_sectors

    key = hashlib.sha256(json.dumps(
        {"gearset": asdict(gearset), "stage": inputs.stage, "level": inputs.level,
         "teeth": TEETH, "neighbours": NEIGHBOURS, "format": 1}, sort_keys=True,
        default=repr).encode()).hexdigest()[:16]
    summary = folder / "sectors.json"
    if summary.exists() and (folder / "sectors.msh").exists():
        data = json.loads(summary.read_text())
        if data.get("key") == key:
            return data
    mesh = build_sectors(gearset, inputs.stage, inputs.level, folder)
    data = {**mesh.to_dict(), "key": key}
    write_json(summary, data)
    return data


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
