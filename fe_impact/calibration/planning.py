"""Planning a calibration run: its cases, their options and their resume keys.

A run is a list of :class:`ImpactCase` (and, for the mesh cycle,
:class:`~fe_impact.calibration.meshcycle.PositionCase`) with the
:class:`Settings` they share. :func:`case_hash` keys each case's stored result,
so that a rerun computes only what is missing or was made otherwise.

Impact speeds (the seed's eq. 4 and 5): in mesh, the seed's relative sliding
speed ``v12 = sqrt((w_f r_f)^2 + (w_c r_c)^2) - sqrt((w_c r_c)^2 + (w_c r_c
cos a)^2)`` (the middle line of eq. 4; its last line is not dimensionally
consistent); with ``w_f r_f = w_c r_c`` this is ``w_c r_c (sqrt 2 - sqrt(1 +
cos^2 a))``, the same for every stage. A ratio switch into stage ``i``
(``--switch``) is struck at two speeds: eq. 5's ``v_s``, and the rigid
kinematics' ``r_bp w_p |N_i / N_(i-1) - 1|`` with which the torsional model's
teeth close after a switch (`fe_impact.gears.kinematics.switching_speed`),
some 8 times lower.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

from fe_impact.calibration import meshcycle
from fe_impact.calibration.meshcycle import PositionCase
from fe_impact.calibration.records import SCHEMA
from fe_impact.errors import CalibrationError
from fe_impact.fe.case import INTEGRATORS
from fe_impact.gears.gearset import GearSet
from fe_impact.gears.pairanalysis import LEVEL_NAMES
from fe_impact.version import __version__

logger = logging.getLogger(__name__)

OPERATING_SPEEDS_RPM = (100.0, 300.0, 1000.0)
LEVELS = LEVEL_NAMES
#: Nominal mesh load (N) at which the linearised mesh stiffness is reported.
NOMINAL_LOAD = 100.0


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
    #: Flank friction ``(mu_static, mu_dynamic)`` of the FE contact; :func:`plan_cases`
    #: gives the gear set's (:func:`~fe_impact.calibration.meshcycle.gearset_friction`)
    friction: tuple[float, float] = (0.0, 0.0)
    #: True: a frictionless companion of the case for the report's friction section
    #: (:func:`friction_companions`); it stays out of the calibration's laws
    companion: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "friction", tuple(float(m) for m in self.friction))
        if len(self.friction) != 2 or not all(0.0 <= m < 1.0 for m in self.friction):
            raise CalibrationError(f"impact friction {list(self.friction)}: need "
                                   "(mu_static, mu_dynamic), each in [0, 1)")

    @property
    def id(self) -> str:
        rpm = f"{self.speed_rpm:g}rpm" if self.speed_rpm is not None else \
            f"{self.impact_speed * 1e3:.4g}mms"
        kind = f"{self.kind}_{self.basis}" if self.basis else self.kind
        tail = "_frictionless" if self.companion else ""
        return f"stage{self.stage}_{kind}_{rpm}{tail}".replace(".", "p")


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
    speeds (module docstring). Every case has the gear set's flank friction."""
    if switch is True:
        switch = "both"
    if switch not in (False, None, "eq5", "kinematic", "both"):
        raise CalibrationError(f"--switch {switch!r}: pick eq5, kinematic or both")
    from fe_impact.gears.kinematics import mesh_geometry, seed_switching_speed, switching_speed

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
    mu = meshcycle.gearset_friction(gearset)
    cases = [replace(c, friction=mu) for c in cases]
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


def case_hash(case: ImpactCase | PositionCase, settings: Settings, gearset_text: str) -> str:
    """Resume key: the case (its flank friction included), the run's settings, the gear
    set, the schema, the fe-impact version and the mesh format (a result from another
    version, with other friction or on meshes made otherwise is computed again)."""
    if isinstance(case, PositionCase):
        return meshcycle.case_hash(case, settings.position_level, settings.order, gearset_text)
    from fe_impact.meshing.toothpair import MESH_FORMAT

    blob = json.dumps([meshcycle.key_fields(case), settings.impact_key(), gearset_text, SCHEMA,
                       __version__, MESH_FORMAT], sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def mesh_key(case: ImpactCase, settings: Settings, gearset_text: str) -> str:
    """The key of an impact's mesh folder (``meshes/<key>``): :func:`case_hash` of the
    case without friction and not a companion, so that an impact and its
    frictionless companion share one mesh (the mesh does not depend on friction)."""
    return case_hash(replace(case, friction=(0.0, 0.0), companion=False), settings,
                     gearset_text)


def friction_companions(gearset: GearSet, impacts: Sequence[ImpactCase],
                        positions: Sequence[PositionCase]) -> list:
    """The frictionless companions of one representative impact and one mesh-cycle
    position, for the report's friction section (none when the gear set's flanks are
    frictionless).

    The impact: the lowest stage's in-mesh impact at the median of its planned
    speeds (the main job's 300 r/min of 100, 300 and 1000). The position: that
    stage's flank position nearest the middle of its path of contact (the
    single-pair zone, where one pair carries the torque and its approach is the
    loaded transmission error).
    """
    if not gearset.friction.active:
        return []
    out: list = []
    mesh = [c for c in impacts if c.kind == "mesh" and not c.companion]
    if mesh:
        stage = min(c.stage for c in mesh)
        row = sorted((c for c in mesh if c.stage == stage), key=lambda c: c.impact_speed)
        out.append(replace(row[(len(row) - 1) // 2], friction=(0.0, 0.0), companion=True))
    flank = [p for p in positions if p.contact == "flank" and not p.companion]
    if flank:
        stage = min(p.stage for p in flank)
        first, last = meshcycle.path_of_contact(gearset, stage)
        middle = 0.5 * (first + last)
        near = min((p for p in flank if p.stage == stage),
                   key=lambda p: abs(p.roll_angle_deg - middle))
        out.append(replace(near, friction=(0.0, 0.0), companion=True))
    return out


def case_contact(case: ImpactCase, settings: Settings, gearset) -> tuple[str, float]:
    """Where an impact strikes: ``("flank", the case's or settings' roll angle)``, or for a corner
    kind the rounded tip edge's first touch at the closed-form corner laws' roll
    angle (:func:`~fe_impact.gears.kinematics.corner_reference_roll`, deg)."""
    if not case.kind.startswith("corner-"):
        return "flank", (settings.roll_angle_deg if case.roll_angle_deg is None
                         else case.roll_angle_deg)
    from fe_impact.gears.kinematics import corner_reference_roll

    return case.kind, math.degrees(corner_reference_roll(gearset, case.kind.removeprefix(
        "corner-")))


# -- the plan adjusted to what the lumped model asks (a first pass's Demand) ----------------
# ``demand`` below is a :class:`fe_impact.switching.demand.Demand`, the first switching
# pass's closing speeds per stage and law; it is read, not imported (the lumped model
# is downstream of the calibration).

#: The closing speed of an FE case added at the top of a stage's range is the
#: largest the closed-form presets produce times this margin, rounded up to two
#: significant digits: the presets rerun on the calibrated laws close somewhat
#: faster or slower (measured on the seed set: 175-183 mm/s on the coarse
#: calibration against 196 mm/s with the closed forms).
TOP_MARGIN = 1.2


def top_speed(speed: float) -> float:
    """``speed`` times `TOP_MARGIN`, rounded up to two significant digits [m/s]."""
    v = speed * TOP_MARGIN
    scale = 10.0 ** (math.floor(math.log10(v)) - 1)
    return math.ceil(v / scale - 1e-9) * scale


def cover(demand, planned: Sequence, gearset: GearSet) -> tuple[list, list[str]]:
    """The planned FE impacts adjusted to the closing speeds the presets produce.

    A stage whose flank impacts (mesh and switch laws) close faster than its fastest
    planned impact gets an impact at `top_speed` of their fastest, in place of its
    fastest planned one when it has three or more (the main job's 100, 300 and
    1000 r/min: the calibration then spans 100 r/min to what the presets ask, at
    the same cost), else beside them. Returns the cases and one line per change.
    """
    cases, lines = list(planned), []
    for stage in sorted({c.stage for c in planned}):
        need = demand.top_speed(stage)
        mesh = [c for c in cases if c.stage == stage and c.kind == "mesh"]
        if need is None or not mesh or need <= max(c.impact_speed for c in mesh):
            continue
        case = ImpactCase(stage, gearset.stages[stage - 1].teeth, "mesh", top_speed(need),
                          friction=meshcycle.gearset_friction(gearset))
        fastest = max(mesh, key=lambda c: c.impact_speed)
        what = f"stage {stage}: flank impacts up to {need * 1e3:.4g} mm/s: an FE impact at " \
               f"{case.impact_speed * 1e3:.4g} mm/s"
        if len(mesh) >= 3:
            cases[cases.index(fastest)] = case
            what += f" in place of {fastest.id} ({fastest.impact_speed * 1e3:.4g} mm/s)"
        else:
            cases.append(case)
        lines.append(what)
    return cases, lines


def _two_digits(speed: float) -> float:
    """``speed`` rounded to two significant digits [m/s]."""
    return float(f"{speed:.2g}")


def corner_impacts(demand, gearset: GearSet, stages: Sequence[int]
                   ) -> tuple[list, list[str]]:
    """FE impacts on the rounded tip edges at the closing speeds the presets produce
    there: per stage and edge, the median and the largest closing speed of the
    impacts whose onset took that edge's corner law, to two significant digits
    (one case when they round alike). An edge the presets never struck, or a
    sharp one, gets none. Returns the cases and one line per stage and edge."""
    from fe_impact.gears.corner import CORNER_SIDES, touching_edge

    cases, lines = [], []
    for stage in stages:
        teeth = gearset.stages[stage - 1].teeth
        for side in CORNER_SIDES:
            kind = f"corner-{side}"
            if touching_edge(gearset, side)[0] <= 0.0:
                lines.append(f"stage {stage}, {kind}: sharp edge, no corner impact")
                continue
            row = demand.stages.get(stage, {}).get(kind)
            if row is None or row.count == 0:
                lines.append(f"stage {stage}, {kind}: the presets never struck it, no FE "
                             "impact")
                continue
            speeds = sorted({_two_digits(row.speed_median), _two_digits(row.speed_max)})
            cases += [ImpactCase(stage, teeth, kind, v,
                                 friction=meshcycle.gearset_friction(gearset)) for v in speeds]
            lines.append(f"stage {stage}, {kind}: {row.count} impacts in the presets, "
                         f"median {row.speed_median * 1e3:.3g} and largest "
                         f"{row.speed_max * 1e3:.3g} mm/s: FE impacts at "
                         f"{', '.join(f'{v * 1e3:.2g}' for v in speeds)} mm/s")
    return cases, lines


def place_switches(demand, planned: Sequence, gearset: GearSet
                   ) -> tuple[list, list[str]]:
    """The planned switch impacts moved to where the presets' first contacts after a
    ratio switch touched: the median place of a stage's switch impacts on the line of
    action, as a pinion roll angle (`fe_impact.gears.kinematics.MeshGeometry.roll_at`;
    the coast flank's place is the mirror of
    the drive flank's, which the FE pair models). A place beyond the path's ends
    (a first touch on a tip edge) is taken at the nearest end of the FE path
    (`fe_impact.calibration.meshcycle.path_positions`' ends at the inset that every
    mesh level can make), and said so. Returns
    the cases and one line per stage moved."""
    from fe_impact.gears.kinematics import mesh_geometry

    line = mesh_geometry(gearset)
    cases, lines = list(planned), []
    for stage in sorted({c.stage for c in planned if c.kind == "switch"}):
        row = demand.stages.get(stage, {}).get("switch")
        if row is None or not math.isfinite(row.position_median):
            lines.append(f"stage {stage}: the presets made no switch impact, the switch "
                         "cases strike at the pitch point")
            continue
        roll = math.degrees(float(line.roll_at(row.position_median)))
        ends = meshcycle.path_positions(gearset, stage, 2)
        lo, hi = min(ends), max(ends)
        where = f"{roll:+.3f} deg of pinion roll"
        if not lo <= roll <= hi:
            roll = min(max(roll, lo), hi)
            where += f" (beyond the FE path: taken at {roll:+.3f} deg)"
        for i, c in enumerate(cases):
            if c.stage == stage and c.kind == "switch":
                cases[i] = replace(c, roll_angle_deg=roll)
        lines.append(f"stage {stage}: the presets' {row.count} switch impacts touched at "
                     f"s = {row.position_median * 1e3:.3f} mm on the line of action, "
                     f"{where}: the switch cases strike there")
    return cases, lines
