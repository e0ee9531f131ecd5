"""``--to exudyn``: a runnable Exudyn model of one stage on the calibrated laws.

The script is `fe_impact.export.exudyn_model` (a standalone module that
imports Exudyn and NumPy only) with its ``DATA`` filled in from the same
sources fe-impact's switching model uses: the gear set's torsional model
(`fe_impact.switching.DriveModel`: inertias, web couplings, backlash,
transmission error, drag, friction, tolerances), the stage's line-of-action
geometry with its tip-corner gap tables, and the law tables of the
calibration read as the switching model reads them
(`fe_impact.switching.load_calibration`, with its closed-form fallbacks).
"""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fe_impact.atomic import atomic_path
from fe_impact.calibration.records import KINDS
from fe_impact.errors import CalibrationError

logger = logging.getLogger(__name__)

__all__ = ["ExudynOptions", "exudyn_data", "script_text", "write_script"]

#: The template's line that the data replaces.
_MARKER = "DATA: dict = {}  # EXPORT-DATA"
#: Largest ``h omega`` of the stiffest web mode (the switching model's bound for DOPRI5).
_STABLE_STEP = 2.0


@dataclass(frozen=True)
class ExudynOptions:
    """What the exported model runs: stage (from 1), pinion speed [r/min], output load
    [N m], duration [s]."""

    stage: int = 1
    speed_rpm: float = 300.0
    load: float = 0.0
    duration: float = 5.0

    def __post_init__(self) -> None:
        if isinstance(self.stage, bool) or not isinstance(self.stage, int) or self.stage < 1:
            raise CalibrationError(f"--stage {self.stage!r}: must be an integer >= 1")
        for option, value, zero in (("--speed", self.speed_rpm, False),
                                    ("--load", self.load, True),
                                    ("--duration", self.duration, False)):
            if not (math.isfinite(value) and (value >= 0.0 if zero else value > 0.0)):
                raise CalibrationError(f"{option} {value!r}: must be a finite number "
                                       f"{'>= 0' if zero else '> 0'}")


def _drive_model(calibration: Path, gearset):
    from fe_impact.switching import DriveModel, laws_for

    model = DriveModel(gearset=gearset)
    masses = [model.effective_mass(s) for s in range(1, model.n_stages + 1)]
    return model.with_laws(laws_for(gearset, masses, calibration, search=False))


def _table(table) -> dict:
    return {"impact_speed": table.impact_speed.tolist(), "k": np.asarray(table.k).tolist(),
            "exponent": np.asarray(table.exponent).tolist(),
            "cmax": np.asarray(table.cmax).tolist(), "d": np.asarray(table.d).tolist(),
            "source": table.source}


def _corner(gap) -> dict:
    return {"delta_max": float(gap.delta_max), "values": np.asarray(gap.values).tolist(),
            "slopes": np.asarray(gap.slopes).tolist(),
            "law_at": float(gap.reference_delta)}


def _check_operation(gearset, options: ExudynOptions) -> None:
    """Speed and load the gear set can run (unit mistakes: r/min x 1000, N mm as N m)."""
    from fe_impact.switching.schedule import load_problem, speed_problem

    for option, message in (("--speed", speed_problem(gearset, options.speed_rpm)),
                            ("--load", load_problem(gearset, options.stage, options.load))):
        if message:
            raise CalibrationError(f"{option} {message}")


def exudyn_data(calibration: str | Path, gearset, options: ExudynOptions) -> dict:
    """The exported model's data (SI units): everything the script needs.

    Parameters
    ----------
    calibration : path
        ``calibration.json``.
    gearset : GearSet
        The gear set the calibration is of.
    options : ExudynOptions
    """
    from fe_impact.switching.model import RPM

    model = _drive_model(Path(calibration), gearset)
    if options.stage > model.n_stages:
        raise CalibrationError(f"--stage {options.stage}: the gear set {gearset.name!r} has "
                               f"stages 1..{model.n_stages}; give one of them")
    _check_operation(gearset, options)
    i = options.stage - 1
    path, corners = model.geometry, model.stage_geometry(options.stage)
    laws = model.law_set
    omega = options.speed_rpm * RPM
    # the switching model's largest step: 8 per tooth-pair passing, inside DOPRI5's
    # stability limit for the stiffest web mode
    passing = path.base_pitch / (path.base_radius * max(omega, 1e-9))
    web = float(np.sqrt(model.couplings / model.ring_inertias
                        * (1.0 + model.ring_inertias / model.output_j)).max())
    friction = model.friction
    positions = laws.positions.get(options.stage)
    return {
        "format": "fe-impact/exudyn-stage/2",
        "stage": options.stage,
        "units": "SI: m, kg, s, N, rad; k in N/m^exponent, cmax in N s/m, d in m",
        "law_source": laws.source,
        "law_notes": list(laws.notes),
        "geometry": {
            "base_radius": path.base_radius, "base_pitch": path.base_pitch,
            "s_start": path.s_start, "s_end": path.s_end, "s_pitch": path.s_pitch,
            "lever": float(model.base_levers[i]), "backlash": float(model.backlashes[i]),
            "transmission_error": model.transmission_error, "mesh_phase": model.mesh_phase,
            "friction_lever": float(model.pitch_radii[i] * math.sin(path.pressure_angle)),
            "approach": _corner(corners.approach), "recess": _corner(corners.recess),
            "corner_source": model.corner_source},
        "inertia": {
            "pinions": model.pinions, "pinion_total": model.pinions * model.pinion_j,
            "rings": model.ring_inertias.tolist(), "output": model.output_j,
            "couplings": model.couplings.tolist(),
            "coupling_damping": model.coupling_damping.tolist()},
        "operation": {"speed_rpm": options.speed_rpm, "speed_rad_s": omega,
                      "load": options.load, "drag": model.drag_torque,
                      "duration": options.duration},
        "friction": None if friction is None else {
            "static": friction.static, "dynamic": friction.dynamic,
            "stiction_speed": friction.stiction_speed,
            "transition_speed": friction.transition_speed},
        "laws": {kind: _table(laws.table(options.stage, kind)) for kind in KINDS
                 if laws.has(options.stage, kind)},
        "positions": None if positions is None else {
            "roll_angle_deg": np.asarray(positions[0]).tolist(),
            "k": np.asarray(positions[1]).tolist(),
            "exponent": np.asarray(positions[2]).tolist()},
        "tolerances": {"length": model.length_tol, "speed": model.speed_tol,
                       "relative": model.rtol,
                       "max_step": min(model.max_step, passing / 8.0, _STABLE_STEP / web)},
    }


def script_text(data: dict) -> str:
    """The template's source with ``data`` in place of its empty ``DATA`` (one line per
    top-level key)."""
    template = Path(__file__).with_name("exudyn_model.py").read_text()
    if template.count(_MARKER) != 1:
        raise AssertionError("the Exudyn template lost its data marker")
    text = "{\n" + ",\n".join(f"{json.dumps(k)}: {json.dumps(v, allow_nan=False)}"
                               for k, v in data.items()) + "\n}"
    if "'''" in text:
        raise AssertionError("the data holds a triple quote")
    return template.replace(_MARKER, f"DATA: dict = json.loads(r'''{text}''')")


README = """fe-impact calibration as an Exudyn model
========================================

{script}   a runnable Exudyn model of stage {stage} at {rpm:g} r/min, load {load:g} N m,
{pad}   {duration:g} s, on the calibrated laws (data inside the script, SI units).

Run:   python {script} [--duration S] [--out DIR]
       (needs exudyn and numpy: pip install exudyn). It prints the impacts'
       count and peak-force statistics and writes series.csv (mesh force per
       mesh against time) and impacts.csv.
Use:   import it and call build(DATA) for the Exudyn system (SC, mbs, mesh, nodes)
       to extend, or simulate(DATA, duration) for the recorder (impacts, series).

Model: rotors (Node1D + ObjectRotationalMass1D) for the pinions (lumped, speed
held by a CoordinateConstraint), each ring on the output through its web
(ObjectConnectorCoordinateSpringDamper), the output with the load and drag
(LoadCoordinate), and the mesh as an ObjectGenericODE2 whose forceUserFunction
sums the IMPACT forces of the tooth pairs (backlash, tip-corner gaps,
transmission error, position law, Coulomb friction). Coordinates are angles
relative to the nominal rotation [rad]. Integrator: DOPRI5 with automatic step
size, tolerances 1/32 of fe-impact's switching model's (see the script).

An unloaded mesh rattles chaotically: runs that differ by round-off (another
tolerance, a 1e-11 m change of the start) part after some tenths of a second,
and their impact counts over 5 s can differ by a factor of four. Compare such
statistics over ensembles of runs, not run by run.
"""


def write_script(data: dict, out: Path) -> list[Path]:
    """Write ``exudyn_stage<N>.py`` and README.txt to ``out``; returns them."""
    stage, op = data["stage"], data["operation"]
    script = out / f"exudyn_stage{stage}.py"
    with atomic_path(script) as tmp:
        tmp.write_text(script_text(data))
    readme = out / "README.txt"
    with atomic_path(readme) as tmp:
        tmp.write_text(README.format(script=script.name, pad=" " * len(script.name),
                                     stage=stage, rpm=op["speed_rpm"], load=op["load"],
                                     duration=op["duration"]))
    return [script, readme]
