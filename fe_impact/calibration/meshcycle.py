"""The mesh cycle: single-pair load-approach along the path of contact, loaded TE and
mesh stiffness.

A tooth pair's contact travels along the path of contact over one angular
pitch and more (contact ratio 1.76 for the seed set). At positions from the
first to the last point of contact, :func:`run_position` presses the pinion
tooth on the face-gear tooth quasi-statically (FE, :func:`~fe_impact.meshing.paircase.static_case`:
the face-gear hub held, the pinion hub loaded by the torque of each normal
force) and measures the approach against the force. The approach is the
closing displacement that the pinion's rotation ``q`` makes along the
contact normal at the contact point of the tooth contact analysis, minus the
gap the pair was built with: ``delta = -q l_1 - g`` (``l_1`` the pinion's
signed lever arm there). It holds the bending of both teeth and the contact,
so ``F(delta)`` is the single-pair compliance that the lumped model's pair
law stands for. Each position's curve is fitted by ``F = K delta^e`` over
the forces from :data:`FIT_MIN_FORCE` up, where impacts load the teeth
(:func:`fit_power_law`); below, bending (linear) and Hertz (power 3/2) mix
and no single power holds, so the nominal load's stiffness is read from the
curve's points themselves.

A position's mesh is made for the curve's largest force, and the nominal
load can be so small that its Hertz patch is narrower than one element
(:func:`patch_resolved`). The FE approach there is not the pair's: the
discrete contact first pushes where the weighted gap of a node's support
closes, which lies tens to hundreds of nanometres beyond the exact surfaces'
first touch on a coarse mesh, and a patch inside one element is carried by
the elements' own point-load compliance. On the seed set's stage 2 at the
coarse level (nominal load 2.6 N, three positions from the path's start to
its end) the FE gave 0.147-0.215 um where a mesh made for that load gave
0.103-0.134 um (+32% to +94%; the point moves with the mesh: the middle
position's gave 0.160 um on a mesh made for 2177.8 instead of 2178 N).
Such a point takes :func:`complete_curve`'s
approach instead: the Hertz approach of the contact analysis' ellipse at
that force plus the FE's own compliance beyond Hertz (bending and bodies)
at the smallest resolved force, in proportion to the force; on those three
positions it is within -1.5% to +2.4% of the resolved FE
(``validation/mesh_cycle.py`` checks it at the pitch point; ``--nominal-path 2
--top-force 2178`` repeats these three positions). The FE value
is kept beside it (:attr:`PositionRecord.fe_approaches`).

:func:`mesh_cycle` then shares a pinion torque between the pairs in contact
at each roll angle (pairs one angular pitch apart, unmodified flanks: no
unloaded transmission error), all at the one pinion rotation: the loaded
transmission error and the mesh stiffness over one mesh cycle.

SI units throughout; roll angles in degrees where named so.
"""

from __future__ import annotations

import collections
import functools
import hashlib
import json
import logging
import math
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from fe_impact.errors import CalibrationError, ContactError
from fe_impact.version import __version__

logger = logging.getLogger(__name__)

SCHEMA = "fe-impact/mesh-cycle/2"
#: Positions along the path of contact by default (ends included).
DEFAULT_POSITIONS = 9
#: The end positions are moved inward by this fraction of the path, per mesh
#: level of the positions. At the exact ends the contact runs onto a tooth's
#: edge, where the flank ends (the pinion's form circle at the first point,
#: its tip at the last): the tooth contact analysis has no contact point
#: there, and that first touch on an edge is the corner contact
#: (:func:`plan_corner_positions`). The coarse meshes hold the flank contact
#: 0.5% of the path (0.17 deg of roll) from either end on all three stages of
#: the seed set (at the first end 85k / 101k / 115k DOFs, 12 / 17 / 22 s; 0.2%
#: at stage 1 too). The default level's mesh of the first end has a turned-over
#: element at every stretch factor up to 2% of the path from it (at 0.2%, also
#: isotropic), and meshes at 5% (198k DOFs). The ends cost: measured
#: alternately against 5% on every level, the coarse calibration took 14-15 s
#: longer (its positions 9 and 32 CPU s more).
END_INSETS = {"coarse": 0.005, "default": 0.05, "fine": 0.05}
#: The inset of a level not named in :data:`END_INSETS` (the largest).
END_INSET = max(END_INSETS.values())


def end_inset(level: str | None) -> float:
    """Fraction of the path by which the end positions at mesh ``level`` move inward."""
    return END_INSETS.get(level, END_INSET)
#: Initial gap of the static pair (m): the approach is measured from first
#: touch, so any small gap serves; it keeps the meshes apart.
PAIR_GAP = 1e-6
#: Forces of the load-approach curves besides the nominal one (N): 50 N up
#: to above the largest calibrated impact force of the default calibration
#: (820 N). :func:`curve_forces` extends them to a larger impact.
CURVE_FORCES = (50.0, 100.0, 200.0, 500.0, 1000.0)
#: Smallest force of the power-law fit (N).
FIT_MIN_FORCE = 50.0


@dataclass(frozen=True)
class PositionCase:
    """One position of the mesh cycle: a quasi-static load-approach curve."""

    stage: int
    face_teeth: int
    roll_angle_deg: float
    forces: tuple[float, ...]           # normal forces of the load steps, N, rising
    end: str = ""                       # "first" / "last" for the path's ends
    #: "flank", or a tip edge's first touch ("corner-approach", "corner-recess":
    #: :attr:`~fe_impact.gears.pairanalysis.PairSpec.contact`) beyond the path
    contact: str = "flank"
    #: Flank friction ``(mu_static, mu_dynamic)`` of the FE contact (a static solve takes
    #: ``mu_static``); :func:`plan_positions` gives the gear set's
    friction: tuple[float, float] = (0.0, 0.0)
    #: True: a frictionless companion of a position for the report's friction section;
    #: it stays out of the mesh cycle
    companion: bool = False

    def __post_init__(self) -> None:
        from fe_impact.gears.pairanalysis import CONTACTS

        object.__setattr__(self, "friction", tuple(float(m) for m in self.friction))
        if len(self.friction) != 2 or not all(0.0 <= m < 1.0 for m in self.friction):
            raise CalibrationError(f"mesh-cycle friction {list(self.friction)}: need "
                                   "(mu_static, mu_dynamic), each in [0, 1)")
        if self.contact not in CONTACTS:
            raise CalibrationError(f"mesh-cycle contact = {self.contact!r}; pick one of "
                                   f"{list(CONTACTS)}")
        f = np.asarray(self.forces, dtype=float)
        if f.size == 0 or np.any(~np.isfinite(f)) or np.any(f <= 0) or np.any(np.diff(f) <= 0):
            raise CalibrationError(f"mesh-cycle forces {list(self.forces)}: need positive "
                                   "forces in rising order (N)")
        if np.count_nonzero(f >= FIT_MIN_FORCE) < 2:
            raise CalibrationError(f"mesh-cycle forces {list(self.forces)}: the fit of "
                                   f"F = K delta^e needs two or more from {FIT_MIN_FORCE:g} N up")

    @property
    def id(self) -> str:
        where = "" if self.contact == "flank" else f"_{self.contact}"
        tail = "_frictionless" if self.companion else ""
        return f"stage{self.stage}{where}_roll{self.roll_angle_deg:+.3f}deg{tail}".replace(
            ".", "p")

    @property
    def impact_speed(self) -> float:   # the sweep orders cases by size, then speed
        return 0.0


@dataclass(frozen=True)
class PositionRecord:
    """What :func:`run_position` measured at one position (SI units)."""

    id: str
    stage: int
    roll_angle_deg: float
    end: str
    forces: list[float]            # FE contact force per load step, N
    approaches: list[float]        # m, from first touch
    torques: list[float]           # pinion torque, N m
    rotations: list[float]         # pinion rotation, rad
    contact_areas: list[float]     # m^2
    max_pressures: list[float]     # Pa
    hertz_approaches: list[float]  # Hertz (contact alone) approach at each force, m
    stiffness: float               # K of F = K delta^e (forces >= FIT_MIN_FORCE), N/m^e
    exponent: float
    fit_error: float               # largest relative force error of the fit
    nominal_force: float           # N (the smallest force of the curve)
    nominal_stiffness: float       # secant F/delta at the nominal force, N/m
    lever: float                   # |pinion lever arm| at the contact point, m
    #: "" or, in one line, which flank edge the pressure reaches and from which force,
    #: the load steps the law is fitted to and its fit error, and the face ends the Hertz
    #: ellipse runs past (:func:`edge_note`)
    edge: str
    ellipse_outline: list[list[float]]   # Hertz ellipse at the largest force, (L, y) m
    footprint: list[list[float]]   # pressured slave nodes at the largest force: L, y, p
    flank_edges: list[list[float]]  # face-flank boundary segments: L0, y0, L1, y1
    n_dofs: int
    hash: str = ""
    timings_s: dict = field(default_factory=dict)
    contact: str = "flank"         # PositionCase.contact
    #: The FE's own approach at each force (m); ``approaches`` differs where the
    #: patch was not resolved (:func:`complete_curve`).
    fe_approaches: list[float] = field(default_factory=list)
    #: Whether the Hertz patch at each force spans an element (:func:`patch_resolved`).
    resolved: list[bool] = field(default_factory=list)
    #: The FE's compliance beyond Hertz at the smallest resolved force, m/N.
    linear_compliance: float = 0.0
    #: Which flank edge the pressure reaches at each load step ("" none).
    step_edges: list[str] = field(default_factory=list)
    #: The load steps' forces (N) the law ``F = K delta^e`` is fitted to.
    fit_forces: list[float] = field(default_factory=list)
    #: How far (m) the Hertz ellipse of the contact analysis at the largest force runs
    #: past each edge of the working flanks (negative: inside;
    #: :func:`~fe_impact.gears.report.ellipse_edges`); empty for a corner.
    ellipse_overhang: dict = field(default_factory=dict)
    #: Flank friction ``[mu_static, mu_dynamic]`` the position was solved with.
    friction: list[float] = field(default_factory=lambda: [0.0, 0.0])
    #: Whether the position is a frictionless companion (:attr:`PositionCase.companion`).
    companion: bool = False
    #: "" or why the position was solved without the friction its case asked for
    #: (the frictional static solve's limits: :func:`run_position`).
    friction_note: str = ""

    @property
    def nominal_modelled(self) -> bool:
        """Whether the nominal load's approach is :func:`complete_curve`'s model (its
        Hertz patch narrower than an element), not the FE point."""
        return bool(self.resolved) and not self.resolved[int(np.argmin(self.forces))]

    def to_dict(self) -> dict:
        return {"schema": SCHEMA, "fe_impact_version": __version__, **asdict(self)}

    @classmethod
    def from_dict(cls, data: dict) -> PositionRecord:
        names = {f.name for f in fields(cls)}
        missing = names - set(data) - {"hash", "timings_s", "contact", "fe_approaches",
                                       "resolved", "linear_compliance", "step_edges",
                                       "fit_forces", "ellipse_overhang", "friction",
                                       "companion", "friction_note"}
        if data.get("schema") != SCHEMA or missing:
            raise CalibrationError(f"not a {SCHEMA} record (missing {sorted(missing)})")
        return cls(**{k: v for k, v in data.items() if k in names})


# -- planning ----------------------------------------------------------------------------
# The gear set is frozen (hashable): the planning, the sweep's cases and the
# report ask for the same stages' path ends and nominal force again and again
# (18 path searches of 0.4 s each where 3 are needed, measured).
@functools.lru_cache(maxsize=64)
def path_of_contact(gearset, stage: int) -> tuple[float, float]:
    """First and last point of contact of a stage, pinion roll angle in degrees."""
    from fe_impact.gears.report import contact_path_ends
    from fe_impact.gears.tca import GearPair

    ends = contact_path_ends(GearPair.from_gearset(gearset, stage))
    return math.degrees(ends["first_roll_rad"]), math.degrees(ends["last_roll_rad"])


def path_positions(gearset, stage: int, n: int = DEFAULT_POSITIONS,
                   level: str | None = None) -> list[float]:
    """``n`` evenly spaced roll angles (deg) from the first to the last point of contact,
    the ends moved inward by :func:`end_inset` of the path for mesh ``level`` (None:
    :data:`END_INSET`, which every level meshes)."""
    if n < 2:
        raise CalibrationError(f"--positions {n}: need at least 2 (the path's ends)")
    first, last = path_of_contact(gearset, stage)
    inset = end_inset(level) * (last - first)
    return [float(v) for v in np.linspace(first + inset, last - inset, n)]


@functools.lru_cache(maxsize=64)
def nominal_force(gearset, stage: int) -> float:
    """Normal force per mesh (N) at the seed presets' largest load torque on the output
    (:func:`~fe_impact.gears.report.stage_geometry`'s, for this stage alone)."""
    from fe_impact.defaults import SEED_LOAD_TORQUE
    from fe_impact.gears.report import pitch_point

    return float(pitch_point(gearset, stage, SEED_LOAD_TORQUE)[1]["pitch_point"]
                 ["normal_force_N"])


def curve_forces(top: float | None = None) -> tuple[float, ...]:
    """:data:`CURVE_FORCES`, or five forces from 50 N to ``top`` (N) evenly in log if
    ``top`` exceeds them (the largest impact force the calibration expects)."""
    if top is None or top <= CURVE_FORCES[-1]:
        return CURVE_FORCES
    return tuple(float(f) for f in np.geomspace(CURVE_FORCES[0], top, len(CURVE_FORCES)))


def stage_forces(gearset, stage: int, top_force: float | None = None) -> tuple[float, ...]:
    """A position's default forces (N): the stage's nominal force and
    :func:`curve_forces` up to ``top_force``."""
    return tuple(sorted({round(nominal_force(gearset, stage), 3), *curve_forces(top_force)}))


def plan_positions(gearset, stages: list[int] | None = None, positions: int | list[float]
                   = DEFAULT_POSITIONS, forces: tuple[float, ...] | None = None,
                   top_force: float | None = None, level: str | None = None
                   ) -> list[PositionCase]:
    """The mesh-cycle cases: every stage at every position, with the gear set's flank
    friction (:func:`gearset_friction`).

    ``positions``: a count (evenly along the path, the ends :func:`end_inset`
    of the path inside it for mesh ``level``) or roll
    angles in degrees, each checked against the path of contact; together
    they must span one angular pitch (the cycle shares the load between the
    pairs one pitch apart). ``forces`` default: the stage's nominal force and
    :func:`curve_forces` up to ``top_force``.
    """
    n_stages = len(gearset.stages)
    stages = list(stages or range(1, n_stages + 1))
    pitch = 360.0 / gearset.pinion.teeth
    cases = []
    for s in stages:
        first, last = path_of_contact(gearset, s)
        lo, hi = sorted((first, last))
        if hi - lo < pitch:
            raise CalibrationError(
                f"stage {s}: the path of contact spans {hi - lo:.3f} deg of pinion roll, less "
                f"than one angular pitch ({pitch:.3f} deg; contact ratio "
                f"{(hi - lo) / pitch:.3f}): no two-pair zone, so there is no mesh cycle to "
                "measure; widen the face gear's teeth (addendum) or run with --no-mesh-cycle")
        if isinstance(positions, int):
            rolls = path_positions(gearset, s, positions, level)
        else:
            rolls = [float(r) for r in positions]
            bad = [r for r in rolls if not lo < r < hi]
            if bad:
                raise CalibrationError(
                    f"--positions {bad[0]:g}: stage {s}'s path of contact runs from "
                    f"{first:.3f} to {last:.3f} deg of pinion roll (ends excluded)")
            given = collections.Counter(f"{r:+.3f}" for r in rolls)
            same = sorted(angle for angle, n in given.items() if n > 1)
            if same:    # one case id, one folder and one point of the cycle for both
                raise CalibrationError(
                    f"--positions {','.join(f'{r:g}' for r in rolls)}: the angle {same[0]} "
                    "deg is given twice (angles are kept to 0.001 deg); give each once")
            if max(rolls) - min(rolls) < pitch:
                raise CalibrationError(
                    f"--positions {','.join(f'{r:g}' for r in rolls)}: span "
                    f"{max(rolls) - min(rolls):.3f} deg, less than one angular pitch "
                    f"({pitch:.3f} deg): the mesh cycle needs positions over the path of "
                    f"contact ({first:.3f} to {last:.3f} deg)")
        f = forces if forces is not None else stage_forces(gearset, s, top_force)
        ends = {0: "first", len(rolls) - 1: "last"} if isinstance(positions, int) else {}
        teeth = gearset.stages[s - 1].teeth
        cases += [PositionCase(s, teeth, r, tuple(f), ends.get(i, ""),
                               friction=gearset_friction(gearset))
                  for i, r in enumerate(rolls)]
    return cases


def plan_corner_positions(gearset, stages: list[int] | None = None,
                          forces: tuple[float, ...] | None = None,
                          top_force: float | None = None) -> list[PositionCase]:
    """The corner cases: per stage, each rounded tip edge at its first touch.

    The roll angle is where the closed-form corner laws take the touch
    (:func:`~fe_impact.gears.kinematics.corner_reference_roll`); the
    forces are those of the flank positions (:func:`plan_positions`). A sharp
    edge (radius 0) has no corner case.
    """
    from fe_impact.gears.corner import CORNER_SIDES, touching_edge
    from fe_impact.gears.kinematics import corner_reference_roll

    stages = list(stages or range(1, len(gearset.stages) + 1))
    cases = []
    for side in CORNER_SIDES:
        if touching_edge(gearset, side)[0] <= 0.0:
            continue
        roll = math.degrees(corner_reference_roll(gearset, side))
        for s in stages:
            f = forces if forces is not None else stage_forces(gearset, s, top_force)
            cases.append(PositionCase(s, gearset.stages[s - 1].teeth, roll, tuple(f),
                                      contact=f"corner-{side}",
                                      friction=gearset_friction(gearset)))
    return cases


def gearset_friction(gearset) -> tuple[float, float]:
    """The gear set's flank friction ``(mu_static, mu_dynamic)``
    (:class:`~fe_impact.gears.gearset.FlankFriction`)."""
    return (float(gearset.friction.mu_static), float(gearset.friction.mu_dynamic))


def key_fields(case) -> dict:
    """A case's fields for its resume key: ``friction`` and ``companion`` only where they
    are set (a frictionless case keys as it did before cases had friction)."""
    fields_ = asdict(case)
    if not fields_.get("companion"):
        fields_.pop("companion", None)
    if tuple(fields_.get("friction", ())) == (0.0, 0.0):
        fields_.pop("friction")
    return fields_


def case_hash(case: PositionCase, level: str, order: int, gearset_text: str,
              refinement: float = 1.0) -> str:
    """Resume key of a position: the case (its friction included), its mesh level,
    refinement and order, the gear set, the record schema, the fe-impact version and
    the mesh format (a result on meshes made otherwise is computed again)."""
    from fe_impact.meshing.toothpair import MESH_FORMAT

    blob = json.dumps([key_fields(case), level, refinement, order, gearset_text, SCHEMA,
                       __version__, MESH_FORMAT], sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def mesh_hash(case: PositionCase, level: str, order: int, gearset_text: str,
              refinement: float = 1.0) -> str:
    """The key of a position's mesh folder (``meshes/static_<key>``): :func:`case_hash`
    of the case without friction and not a companion, so that a position and its
    frictionless companion share one mesh (the mesh does not depend on friction).
    For a frictionless case it is :func:`case_hash`."""
    from dataclasses import replace

    return case_hash(replace(case, friction=(0.0, 0.0), companion=False), level, order,
                     gearset_text, refinement)


# -- one position (FE) --------------------------------------------------------------------
def run_position(case: PositionCase, level: str, order: int, gearset_text: str,
                 cache: str | Path, refinement: float = 1.0) -> PositionRecord:
    """Mesh the pair at ``case``'s roll angle and measure its load-approach curve
    (``refinement``: :attr:`~fe_impact.gears.pairanalysis.PairSpec.refinement`).

    With the case's flank friction; where the frictional static solve refuses the
    position (a contact zone too large to condense the friction on:
    :class:`~fe_impact.errors.ContactError`), it is solved frictionless with a
    warning, and the record's ``friction`` and ``friction_note`` say so."""
    import tomllib

    from fe_impact.fe.linalg import limit_threads
    from fe_impact.gears import gearset_from_dict
    from fe_impact.meshing.toothpair import build_pair

    t0, cpu0 = time.perf_counter(), time.process_time()
    gearset = gearset_from_dict(tomllib.loads(gearset_text))
    key = case_hash(case, level, order, gearset_text, refinement)
    folder = f"static_{mesh_hash(case, level, order, gearset_text, refinement)}"
    timings = {}
    with limit_threads(1):
        pair_mesh = build_pair(gearset, case.stage, case.roll_angle_deg, level, order, PAIR_GAP,
                               0.1, Path(cache) / "meshes" / folder, reuse=True,
                               design_force=max(case.forces), contact=case.contact,
                               refinement=refinement)
    timings["mesh"] = time.perf_counter() - t0
    t = time.perf_counter()
    friction, note = case.friction, ""
    try:
        solver, result = solve_static_pair(gearset, pair_mesh, case.forces, friction)
    except ContactError as exc:
        if friction == (0.0, 0.0):
            raise
        # the frictional solve's own limits (a contact zone too large to condense the
        # friction on): the position is solved frictionless, and says so
        friction, note = (0.0, 0.0), f"solved frictionless: {exc}"
        logger.warning("stage %d, roll %+.3f deg%s: %s", case.stage, case.roll_angle_deg,
                       f" ({case.contact})" if case.contact != "flank" else "", note)
        solver, result = solve_static_pair(gearset, pair_mesh, case.forces)
    timings["fe"] = time.perf_counter() - t
    timings.update({f"fe_{k}": v for k, v in result.timings.items()})
    record = _measure(case, solver, result, pair_mesh.analysis, key,
                      pair_mesh.stats.element_sizes["minor"], gearset)
    timings["total"] = time.perf_counter() - t0
    timings["cpu"] = time.process_time() - cpu0   # the process's, all its threads
    if record.edge:
        logger.warning("stage %d, roll %+.3f deg%s: %s", case.stage, case.roll_angle_deg,
                       f" ({case.end} end)" if case.end else "", record.edge)
    return PositionRecord(**{**asdict(record), "timings_s": timings,
                             "friction": list(friction), "companion": case.companion,
                             "friction_note": note})


def solve_static_pair(gearset, pair_mesh, forces: tuple[float, ...],
                      friction: tuple[float, float] = (0.0, 0.0)):
    """The quasi-static case of a meshed pair, solved on one thread without stresses:
    the solver and its result (:func:`~fe_impact.meshing.paircase.static_pair_case`:
    the pinion pressed by the torque of each normal force in ``forces``), the flanks'
    contact with the Coulomb ``friction`` ``(mu_static, mu_dynamic)`` (a static solve
    takes ``mu_static``; :mod:`fe_impact.contact.friction`)."""
    from fe_impact.fe.linalg import limit_threads
    from fe_impact.fe.mesh import load_mesh
    from fe_impact.meshing.paircase import static_pair_case
    from fe_impact.solvers.static import StaticSolver

    with limit_threads(1):
        fe_case = with_friction(static_pair_case(gearset, pair_mesh, tuple(forces)), friction)
        solver = StaticSolver(fe_case, load_mesh(fe_case.mesh_file, fe_case.unit),
                              stress=False)
        return solver, solver.run()


def with_friction(fe_case, friction: tuple[float, float]):
    """``fe_case`` with the Coulomb ``friction`` ``(mu_static, mu_dynamic)`` on every
    contact pair (the FE's default transition speed between them); unchanged when both
    are 0."""
    from dataclasses import replace

    mu_s, mu_d = friction
    if mu_s == 0.0 and mu_d == 0.0:
        return fe_case
    return replace(fe_case, contacts=tuple(replace(c, mu_static=mu_s, mu_dynamic=mu_d)
                                           for c in fe_case.contacts))


def hub_approaches(result, analysis) -> np.ndarray:
    """The approach at each load step (m): the pinion hub's closing rotation times its
    lever arm at the contact point, minus the gap the pair was built with,
    ``-q l_1 - g`` (zero at the contact analysis' first touch)."""
    q = np.array([s.rigid_values[0] for s in result.steps])
    return -q * analysis.masses.pinion_lever - analysis.gap


def _measure(case: PositionCase, solver, result, analysis, key: str,
             across: float, gearset=None) -> PositionRecord:
    """Approach, fit, edge contact and the footprint of a solved position; ``across``
    the mesh's element size across the ellipse at the contact (m); ``gearset`` (if
    given) for the Hertz ellipse's overhang of the flank edges (:func:`ellipse_overhang`)."""
    from fe_impact.gears.tca import contact_ellipse

    steps = result.steps
    q = np.array([s.rigid_values[0] for s in steps])
    fe_approach = hub_approaches(result, analysis)
    force = np.array([s.contact_force[0] for s in steps])
    hertz = [contact_ellipse(analysis.contact.relative, float(f), analysis.effective_modulus)
             for f in force]
    resolved = np.array([patch_resolved(h.b, across) for h in hertz])
    approach, compliance = complete_curve(force, fe_approach,
                                          np.array([h.approach for h in hertz]), resolved)
    step_edges = [_edge_contact(solver, s) for s in steps]
    fitted = fit_steps(case.forces, step_edges)
    K, e, err = fit_power_law(force[fitted], approach[fitted])
    overhang = ({} if gearset is None or case.contact != "flank"
                else ellipse_overhang(gearset, case.stage, analysis, hertz[-1]))
    i_nom = int(np.argmin(force))
    top = steps[int(np.argmax(force))]
    mesh = solver.mesh
    return PositionRecord(
        id=case.id, stage=case.stage, roll_angle_deg=case.roll_angle_deg, end=case.end,
        forces=force.tolist(), approaches=approach.tolist(),
        torques=[s.rigid_reactions[0] for s in steps], rotations=q.tolist(),
        contact_areas=[s.contact_area[0] for s in steps],
        max_pressures=[s.max_pressure for s in steps],
        hertz_approaches=[h.approach for h in hertz],
        stiffness=K, exponent=e, fit_error=err, nominal_force=float(force[i_nom]),
        nominal_stiffness=float(force[i_nom] / approach[i_nom]),
        lever=abs(analysis.masses.pinion_lever),
        edge=edge_note(case.forces, step_edges, fitted, err, overhang),
        ellipse_outline=_cylindrical(_ellipse_points(analysis.contact.point, hertz[-1])),
        footprint=_footprint(mesh, top.pressure),
        flank_edges=_flank_edges(mesh), n_dofs=int(result.info["n_dofs"]), hash=key,
        contact=case.contact, fe_approaches=fe_approach.tolist(),
        resolved=[bool(r) for r in resolved], linear_compliance=compliance,
        step_edges=step_edges, fit_forces=force[fitted].tolist(), ellipse_overhang=overhang)


def fit_steps(requested, step_edges: list[str]) -> np.ndarray:
    """The load steps the law ``F = K delta^e`` is fitted to (a boolean mask).

    Those asked for :data:`FIT_MIN_FORCE` or more (:func:`fit_load_steps`) where the
    pressure stays off the flanks' edges: a power law describes a contact patch that
    grows on whole flanks, not one cut off by an edge (where the pair stiffens or
    softens by the edge's own compliance; an exponent of 0.88 with a 13.6% fit error
    was seen on such an end position). If fewer than two such steps remain, every
    step from :data:`FIT_MIN_FORCE` up (the note then says the fit holds edge loading).
    """
    fitted = np.asarray(requested, dtype=float) >= FIT_MIN_FORCE
    clean = fitted & ~np.array([bool(e) for e in step_edges])
    return clean if clean.sum() >= 2 else fitted


def edge_note(requested, step_edges: list[str], fitted: np.ndarray, fit_error: float,
              overhang: dict[str, float]) -> str:
    """One line on a position's edge loading, "" where there is none: which flank edge the
    pressure reaches from which load step, the steps the law is fitted to and its fit
    error, and which edge of the working flanks (a face end of the pinion or the ring,
    a tip) the Hertz ellipse of the largest force runs past and by how much."""
    forces = np.asarray(requested, dtype=float)
    parts = []
    reached = [i for i, e in enumerate(step_edges) if e]
    if reached:
        first = reached[0]
        kept = forces[fitted]
        whole = bool(np.all([step_edges[i] for i in np.flatnonzero(fitted)]))
        span = (f"{kept.min():.4g}-{kept.max():.4g} N" if kept.size else "-")
        parts.append(
            f"the pressure reaches the {step_edges[first]} from {forces[first]:.4g} N; "
            + (f"the law is fitted to all {kept.size} steps {span}, every one with edge "
               "loading" if whole else
               f"the law is fitted to the {kept.size} steps {span} without it")
            + f" (fit error {fit_error:.1%})")
    past = {name: v for name, v in overhang.items() if v > 0.0}
    if past:
        parts.append("the Hertz ellipse of the largest force runs past the " + ", ".join(
            f"{name} by {v * 1e3:.3g} mm" for name, v in sorted(past.items(),
                                                               key=lambda kv: -kv[1])))
    return "; ".join(parts)


def ellipse_overhang(gearset, stage: int, analysis, ellipse) -> dict[str, float]:
    """:func:`~fe_impact.gears.report.ellipse_edges` of ``ellipse`` at the position's
    contact (``analysis.contact``), m per edge (> 0: past it)."""
    from fe_impact.gears.report import ellipse_edges
    from fe_impact.gears.tca import GearPair

    pair = GearPair.from_gearset(gearset, stage)
    return ellipse_edges(pair, analysis.contact, ellipse.a, ellipse.b)


def patch_resolved(b: float, across: float) -> bool:
    """Whether a Hertz patch of semi-minor axis ``b`` spans at least one element of
    size ``across`` (the mesh's size across the ellipse), ``2 b >= across``.

    Narrower, the patch lies within one row of elements: its pressure sits on
    the few nodes of one element and the FE approach is the discrete
    contact's (see the module's notes), not the pair's. A position's mesh is
    made for its largest force ``F_d`` with ``across = f b_d`` (``f`` the
    level's ``minor_fraction``), and ``b`` grows as ``F^(1/3)``: the forces
    from ``F_d (f/2)^3`` up are resolved (coarse: ``F_d / 64``).
    """
    return 2.0 * b >= across


def complete_curve(force: np.ndarray, fe_approach: np.ndarray, hertz: np.ndarray,
                   resolved: np.ndarray) -> tuple[np.ndarray, float]:
    """The load-approach curve with the unresolved points' approaches modelled.

    ``delta = delta_H(F) + c F`` where the patch is not resolved: ``delta_H``
    the Hertz approach of the contact analysis' ellipse at ``F`` (``hertz``),
    ``c`` the FE's compliance beyond Hertz at the smallest resolved force
    ``F_r``, ``(delta_FE(F_r) - delta_H(F_r)) / F_r`` (the bending of the teeth
    and the bodies, linear in the force; 0 if the FE there is stiffer than the
    Hertz approach alone). Small patches make this a good split: the Hertz
    approach of two half-spaces holds the better the smaller the patch is
    against the tooth. Returns the approaches (the FE's where resolved) and
    ``c`` (m/N).

    Raises
    ------
    CalibrationError
        If no force's patch is resolved.
    """
    force, fe_approach = np.asarray(force, float), np.asarray(fe_approach, float)
    hertz, resolved = np.asarray(hertz, float), np.asarray(resolved, bool)
    if not resolved.any():
        raise CalibrationError("no force of the load-approach curve has a Hertz patch as "
                               "wide as an element: refine the mesh or raise the forces")
    r = np.flatnonzero(resolved)[np.argmin(force[resolved])]
    compliance = max(float((fe_approach[r] - hertz[r]) / force[r]), 0.0)
    return np.where(resolved, fe_approach, hertz + compliance * force), compliance


def fit_power_law(force: np.ndarray, approach: np.ndarray) -> tuple[float, float, float]:
    """``F = K delta^e`` by least squares on ``log F`` against ``log delta``.

    Returns ``K``, ``e`` and the largest relative force error of the fit.
    Needs two or more positive approaches.
    """
    ok = (approach > 0) & (force > 0)
    if ok.sum() < 2:
        raise CalibrationError("the load-approach curve has fewer than two points with a "
                               "positive approach: the pair did not touch")
    e, logk = np.polyfit(np.log(approach[ok]), np.log(force[ok]), 1)
    K = float(np.exp(logk))
    err = float(np.max(np.abs(K * approach[ok] ** e / force[ok] - 1.0)))
    return K, float(e), err


def fit_load_steps(requested, force: np.ndarray,
                   approach: np.ndarray) -> tuple[float, float, float]:
    """:func:`fit_power_law` over the load steps asked for :data:`FIT_MIN_FORCE` or more.

    The steps are chosen by the force ``requested`` of them, not by the FE's
    contact ``force``: that differs from the requested one by up to about 0.2%
    (the torque is applied at the contact analysis' point), which would leave a
    step asked for exactly 50 N out of the fit.
    """
    fitted = np.asarray(requested, dtype=float) >= FIT_MIN_FORCE
    return fit_power_law(np.asarray(force)[fitted], np.asarray(approach)[fitted])


def _boundary_nodes(faces: np.ndarray) -> np.ndarray:
    """Corner nodes on the boundary edges (edges of one face only) of a surface."""
    edges = np.sort(faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    return np.unique(uniq[count == 1])


def _edge_contact(solver, step) -> str:
    """Which flank edge the pressure at ``step`` reaches: "" if none.

    The pinion's: a pressured node on its flank's boundary; the face gear's:
    a pressured pinion node within one face size of the face flank's boundary.
    """
    from scipy.spatial import cKDTree

    from fe_impact.contact.zone import face_size

    pair = solver.pairs[0]
    mesh = solver.mesh
    on = np.flatnonzero(step.pressure > 0)
    where = []
    if np.isin(on, _boundary_nodes(pair.slave.faces)).any():
        where.append("pinion flank edge")
    master_edge = _boundary_nodes(pair.master.faces)
    if len(on) and len(master_edge):
        d, _ = cKDTree(mesh.points[master_edge]).query(mesh.points[on])
        if d.min() < face_size(mesh, pair.master, np.min, None) + 1e-12:
            where.append("face-gear flank edge")
    return ", ".join(where)


def _ellipse_points(centre: np.ndarray, ellipse, n: int = 48) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n)
    return (centre[None, :] + ellipse.a * np.cos(t)[:, None] * ellipse.major[None, :]
            + ellipse.b * np.sin(t)[:, None] * ellipse.minor[None, :])


def _cylindrical(x: np.ndarray) -> list[list[float]]:
    """(L, y): distance from the face-gear axis (y) and height along it, m."""
    return np.column_stack([np.hypot(x[:, 0], x[:, 2]), x[:, 1]]).tolist()


def _footprint(mesh, pressure: np.ndarray) -> list[list[float]]:
    on = np.flatnonzero(pressure > 0)
    L_y = np.asarray(_cylindrical(mesh.points[on])).reshape(-1, 2)
    return np.column_stack([L_y, pressure[on]]).tolist()


def _flank_edges(mesh) -> list[list[float]]:
    faces = mesh.surface("face_flank")
    edges = np.sort(faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    seg = uniq[count == 1]
    a = np.asarray(_cylindrical(mesh.points[seg[:, 0]])).reshape(-1, 2)
    b = np.asarray(_cylindrical(mesh.points[seg[:, 1]])).reshape(-1, 2)
    return np.column_stack([a, b]).tolist()


# -- the cycle ----------------------------------------------------------------------------
@dataclass(frozen=True)
class CycleResult:
    """Loaded transmission error and mesh stiffness over one mesh cycle at one torque."""

    stage: int
    torque: float                  # pinion torque, N m
    roll_deg: np.ndarray           # roll angle of the reference pair, deg
    transmission_error: np.ndarray  # loaded TE along the line of action, m
    mesh_stiffness: np.ndarray     # tangent mesh stiffness along the line of action, N/m
    pairs: np.ndarray              # pairs in contact
    load_share: np.ndarray         # the reference pair's share of the load

    def to_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v)
                for k, v in asdict(self).items()}


def pair_force(record: PositionRecord, approach: float) -> tuple[float, float]:
    """Force (N) and ``dF/d delta`` (N/m) of a position's FE curve at ``approach`` (m).

    Piecewise power laws between the FE points (linear in ``log F`` against
    ``log delta``), continued beyond the first and last point with the end
    segments' powers.
    """
    log_f, slope = _power_pieces(_log_curve(record), np.array([math.log(approach)]))
    force = math.exp(log_f[0])
    return force, float(slope[0]) * force / approach


def _log_curve(record: PositionRecord) -> tuple[np.ndarray, np.ndarray]:
    """``(log delta, log F)`` of a position's FE points with a positive approach, in
    increasing approach.

    A point at or below zero approach is left out: where the pair first touches at a
    flank's edge rather than at the contact analysis' point (a position at the path's
    end), the smallest forces close less than the gap to that point.

    Raises
    ------
    CalibrationError
        If fewer than two points remain.
    """
    approach, force = np.asarray(record.approaches, float), np.asarray(record.forces, float)
    ok = (approach > 0.0) & (force > 0.0)
    if ok.sum() < 2:
        raise CalibrationError(
            f"{record.id}: fewer than two load steps with a positive approach (the pair "
            "touches at an edge before the contact point at every force); it cannot enter "
            "the mesh cycle")
    order = np.argsort(approach[ok])
    return np.log(approach[ok][order]), np.log(force[ok][order])


def _power_pieces(curve: tuple[np.ndarray, np.ndarray], x: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``log F`` and ``d log F / d log delta`` of a curve from :func:`_log_curve` at
    ``x = log delta`` (an array)."""
    d, f = curve
    j = np.clip(np.searchsorted(d, x) - 1, 0, len(d) - 2)
    slope = (f[j + 1] - f[j]) / (d[j + 1] - d[j])
    return f[j] + slope * (x - d[j]), slope


#: Bisections of ``log delta`` in :func:`mesh_cycle`: the bracket is at most about
#: 40 wide (1e-15 m up to metres), so 60 halvings leave 4e-17 of ``log delta``, a
#: relative error in the approach far below the FE curves' own.
_BISECTIONS = 60


def mesh_cycle(records: list[PositionRecord], pitch_deg: float, torque: float,
               n: int = 200, path: tuple[float, float] | None = None) -> CycleResult:
    """Share ``torque`` (pinion, N m) between the pairs in contact over one mesh cycle.

    The pairs sit one angular pitch apart; a pair is in contact while its
    roll angle lies on the path of contact: ``path`` (first and last point of
    contact, deg), or else the span of ``records`` (the positions of one
    stage). Between the path's ends and the outermost positions (which
    :func:`end_inset` moves inward) a pair follows the nearest position's
    curve. At each roll angle every pair in contact closes by
    the same approach ``delta`` (one pinion rotation, unmodified flanks: no
    unloaded transmission error), its force follows the FE curves of the
    neighbouring positions (:func:`pair_force`, ``log F`` interpolated
    linearly in roll angle between them), and the forces times the lever arms
    carry the torque, ``sum_i l_i F_i(delta) = T``, solved for ``delta``: the
    loaded TE along the line of action. The mesh stiffness is
    ``sum_i dF_i/d delta``. The root is bracketed and bisected in ``log delta``
    for all roll angles at once (the moment grows with ``delta``).
    """
    if not torque > 0.0:
        raise CalibrationError(f"torque = {torque!r} N m: must be > 0 (no load, or one that "
                               "separates the pairs, has no loaded transmission error)")
    recs = sorted(records, key=lambda r: r.roll_angle_deg)
    roll = np.array([r.roll_angle_deg for r in recs])
    levers = np.array([r.lever for r in recs])
    curves = [_log_curve(r) for r in recs]
    lo, hi = (roll[0], roll[-1]) if path is None else sorted(path)
    if hi - lo < pitch_deg:
        raise CalibrationError(
            f"stage {recs[0].stage}: the positions span {hi - lo:.3f} deg of roll, less than "
            f"one angular pitch ({pitch_deg:.3f} deg): no two-pair zone to share the load; "
            "the mesh cycle needs positions over the whole path of contact")
    theta = np.linspace(lo, lo + pitch_deg, n, endpoint=False)
    # every pair in contact at each roll angle: (roll angle index, the pair's roll)
    shifted = theta[:, None] + pitch_deg * np.arange(-4, 5)[None, :]
    row, col = np.nonzero((lo <= shifted) & (shifted <= hi))
    t = shifted[row, col]
    j = np.clip(np.searchsorted(roll, t) - 1, 0, len(roll) - 2)
    w = np.clip((t - roll[j]) / (roll[j + 1] - roll[j]), 0.0, 1.0)
    lever = (1.0 - w) * levers[j] + w * levers[j + 1]

    def pairs(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Force and ``d log F / d log delta`` of every pair at ``log delta = x[row]``."""
        log_f, slope = np.empty((2, len(t))), np.empty((2, len(t)))
        for side, jj in enumerate((j, j + 1)):
            for k in np.unique(jj):
                m = jj == k
                log_f[side, m], slope[side, m] = _power_pieces(curves[k], x[row[m]])
        return (np.exp((1.0 - w) * log_f[0] + w * log_f[1]),
                (1.0 - w) * slope[0] + w * slope[1])

    def excess(x: np.ndarray) -> np.ndarray:
        return np.bincount(row, lever * pairs(x)[0], minlength=n) - torque

    low = np.full(n, math.log(1e-15))
    high = np.full(n, math.log(1e-7))
    for _ in range(200):
        short = excess(high) < 0.0
        if not short.any():
            break
        high[short] += math.log(2.0)
    for _ in range(_BISECTIONS):
        mid = 0.5 * (low + high)
        above = excess(mid) >= 0.0
        high = np.where(above, mid, high)
        low = np.where(above, low, mid)
    x = 0.5 * (low + high)
    te = np.exp(x)
    force, slope = pairs(x)
    km = np.bincount(row, slope * force / te[row], minlength=n)
    count = np.bincount(row, minlength=n).astype(float)
    # the pair nearest the cycle's own roll angle (offset 0: column 4)
    share = np.zeros(n)
    ref = col == 4
    share[row[ref]] = lever[ref] * force[ref] / torque
    return CycleResult(recs[0].stage, torque, theta, te, km, count, share)
