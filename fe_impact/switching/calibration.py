"""IMPACT-law parameters per stage and impact speed: calibration file or closed forms.

The torsional model applies the ADAMS ``IMPACT`` law (seed eq. 11,
`fe_impact.physics.laws.ImpactLaw`) to every tooth pair. Its parameters
``(k, exponent, cmax, d)`` depend on the stage and on the impact speed, so
the model keeps, for each stage and each kind of contact (`KINDS`:
``"mesh"``, tooth contact on the flanks at mesh-in or rattle within the
backlash; ``"switch"``, the first contact after a ratio switch;
``"corner-approach"`` and ``"corner-recess"``, contact on a rounded tip edge
before or after the path of contact), a table of parameters against impact
speed (`LawTable`). At each contact onset the kernel interpolates the table
of the onset's kind at the measured closing speed, linearly in
``log(speed)``, and clamps outside the table's range. While the pair stays
in contact, its stiffness and exponent follow where it touches: the corner
law's on a tip edge, the flank's (or the mesh cycle's position law) on the
flanks; its damping and penetration stay those of its onset's law.

A stage's corner tables are optional: with sharp tip edges there is no
rounding to touch with, and corner contacts take the flank's law.

Sources, in order of preference (`laws_for`):

1. a calibration file written by the calibration pipeline, schema
   ``fe-impact/calibration/1`` (`load_calibration`)::

       {"schema": "fe-impact/calibration/1",
        "units": {"k": "N/m^exponent", "cmax": "N s/m", "d": "m", ...},
        "cases": [{"stage": 1, "face_teeth": 56, "kind": "mesh",
                   "impact_speed": 0.12, "effective_mass": 0.05,
                   "fe": {...}, "impact": {"k": ..., "exponent": ...,
                   "cmax": ..., "d": ...}, "closed_form": {...}}, ...]}

   Only ``stage``, ``kind``, ``impact_speed`` and ``impact`` are used;
   ``face_teeth``, when given, must match the gear set.
2. closed forms (`closed_form_laws`): Hertz stiffness of the contact ellipse
   (`fe_impact.physics.hertz.ellipse_contact`), exponent 1.5, ``cmax`` from seed eq.
   13 (`fe_impact.physics.seed.damping`) with the restitution of seed eq. 14
   (`fe_impact.physics.seed.restitution`) and the approach of eq. 16
   (`fe_impact.physics.hertz.impact_from_stiffness`), ``d`` from eq. 17
   (`fe_impact.physics.seed.penetration_depth`). On the flanks the ellipse is
   the design point's (`contact_radii`); on a tip edge it is the rounded
   edge's first touch on the mating flank (`corner_radii`,
   `fe_impact.gears.corner.corner_contact`), where the rounding's radius
   across the edge makes the contact narrow and 2-3 times softer.

A calibration file without corner cases takes the closed-form corner laws
(when the edges are rounded) beside its calibrated flank laws; the notes of
the `LawSet` say so, and the switching report shows which law each impact
used.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from fe_impact.calibration.records import KINDS, SCHEMA, CalibrationRecord, read_calibration
from fe_impact.errors import CalibrationError
from fe_impact.gears.gearset import GearSet
from fe_impact.gears.kinematics import corner_reference_roll
from fe_impact.inputs import Reader
from fe_impact.physics import hertz, laws, seed

logger = logging.getLogger(__name__)

__all__ = [
    "CALIBRATION_FILE",
    "KINDS",
    "SCHEMA",
    "LawSet",
    "LawTable",
    "closed_form_laws",
    "contact_radii",
    "corner_radii",
    "corner_reference_roll",
    "load_calibration",
    "laws_for",
]

#: File name looked for in the working directory when no file is given.
CALIBRATION_FILE = "calibration.json"
_PARAMETERS = ("k", "exponent", "cmax", "d")
#: Impact speeds of the closed-form tables [m/s]: rattle at 1e-5 m/s up to
#: switching impacts at several m/s, 4 points per decade.
CLOSED_FORM_SPEEDS = np.logspace(-5.0, 1.0, 25)
#: Reference load for the Hertz stiffness: any load gives the same K.
_REFERENCE_LOAD = 100.0
#: Shortest contact a law may give [s]: the undamped contact time at a table's
#: impact speed, and the damping time m / cmax. The seed's tooth contacts last
#: 1e-5 to 1e-3 s; a law far below (e.g. k = 1e300, a unit slip) would need
#: steps so small that the run cannot finish (its force overflows first).
MIN_CONTACT_TIME = 1e-9
#: Largest approach [m] a law may give at its own calibrated impact: elastic tooth
#: contacts approach by micrometres (the seed's FE impacts: 0.9-6 um); 1 mm, a third of
#: the seed's addendum, is beyond any elastic tooth contact of module 1-10 mm, and a law
#: that gives more is soft by orders of magnitude (k in the wrong units).
MAX_APPROACH = 1e-3
#: The kinds every stage has a table of (flank contact), and the tip-edge kinds by
#: corner side (a stage has them only when that edge is rounded).
FLANK_KINDS = ("mesh", "switch")
CORNER_KINDS = {"approach": "corner-approach", "recess": "corner-recess"}


@dataclass(frozen=True, eq=False)
class LawTable:
    """IMPACT-law parameters against impact speed, for one stage and kind.

    Attributes
    ----------
    stage : int
        Stage number, from 1.
    kind : str
        One of `KINDS`.
    impact_speed : ndarray, shape (n,)
        Increasing closing speeds [m/s], > 0.
    k, exponent, cmax, d : ndarray, shape (n,)
        Parameters of `fe_impact.physics.laws.ImpactLaw` at those speeds (SI).
    source : str
        Where the numbers come from (file name or "closed form").
    """

    stage: int
    kind: str
    impact_speed: np.ndarray
    k: np.ndarray
    exponent: np.ndarray
    cmax: np.ndarray
    d: np.ndarray
    source: str

    def __post_init__(self) -> None:
        speed = np.asarray(self.impact_speed, dtype=float)
        if speed.ndim != 1 or speed.size == 0 or np.any(speed <= 0) or np.any(np.diff(speed) <= 0):
            raise CalibrationError(
                f"stage {self.stage} {self.kind!r}: impact speeds must be positive and strictly "
                f"increasing, got {speed.tolist()}"
            )

    @property
    def speed_range(self) -> tuple[float, float]:
        """Lowest and highest tabulated impact speed [m/s]."""
        return float(self.impact_speed[0]), float(self.impact_speed[-1])

    def as_rows(self) -> np.ndarray:
        """Kernel layout, shape (n, 5): ``log(speed), k, exponent, cmax, d``."""
        return np.column_stack([np.log(self.impact_speed), self.k, self.exponent,
                                self.cmax, self.d])

    def law(self, impact_speed: float) -> laws.ImpactLaw:
        """Parameters at ``impact_speed`` [m/s], linear in ``log(speed)``.

        Outside the tabulated range the nearest end is used and a warning is
        logged.
        """
        if not impact_speed > 0.0:
            raise CalibrationError(f"impact_speed = {impact_speed!r} m/s must be > 0")
        low, high = self.speed_range
        if not low <= impact_speed <= high:
            logger.warning(
                "stage %d %s impact at %.4g m/s is outside the calibrated range "
                "[%.4g, %.4g] m/s (%s): parameters clamped to the nearest case",
                self.stage, self.kind, impact_speed, low, high, self.source,
            )
        x = math.log(min(max(impact_speed, low), high))
        log_speed = np.log(self.impact_speed)
        values = [float(np.interp(x, log_speed, getattr(self, p))) for p in _PARAMETERS]
        return laws.ImpactLaw(*values)


@dataclass(frozen=True)
class LawSet:
    """Law tables for every stage and kind of a gear set.

    Attributes
    ----------
    tables : dict
        ``(stage, kind) -> LawTable``, stage from 1, kind in `KINDS`.
    source : str
        Summary of the sources, for reports.
    """

    tables: Mapping[tuple[int, str], LawTable]
    source: str
    notes: tuple[str, ...] = field(default=())
    #: Position-dependent pair stiffness per stage (from the mesh cycle of a
    #: calibration file): ``stage -> (roll_deg, k, exponent)``, roll angles
    #: rising. While a pair touches, its ``k`` and exponent follow its roll
    #: angle; ``cmax`` and ``d`` stay those of its impact's law.
    positions: Mapping[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=dict)

    def has(self, stage: int, kind: str) -> bool:
        """Whether ``stage`` (from 1) has a table of ``kind`` (corner kinds are optional)."""
        return (stage, kind) in self.tables

    def table(self, stage: int, kind: str = "mesh") -> LawTable:
        """The table of ``stage`` (from 1) and ``kind``."""
        try:
            return self.tables[(stage, kind)]
        except KeyError:
            known = sorted({s for s, _ in self.tables})
            raise CalibrationError(
                f"no law table for stage {stage!r}, kind {kind!r}; stages {known}, "
                f"kinds {list(KINDS)}"
            ) from None

    def law(self, stage: int, impact_speed: float, kind: str = "mesh") -> laws.ImpactLaw:
        """IMPACT law of ``stage`` and ``kind`` at ``impact_speed`` [m/s]."""
        return self.table(stage, kind).law(impact_speed)

    @property
    def n_stages(self) -> int:
        return len({s for s, _ in self.tables})

    def pitch_point_only(self) -> LawSet | None:
        """These laws as the calibration had them before the mesh cycle and the corner
        laws: the flank kinds' impact laws at every position and on the tip edges. None
        when that is what these laws are already."""
        flank = {key: t for key, t in self.tables.items() if key[1] in FLANK_KINDS}
        if len(flank) == len(self.tables) and not self.positions:
            return None
        return LawSet(flank, f"{self.source}, pitch-point laws only (no mesh cycle, no "
                             "corner laws)", self.notes)

    def position_arrays(self, s_pitch: float, base_radius: float, size: int) -> np.ndarray:
        """The position tables in the kernel's path coordinate, shape (n_stages, 3, size).

        Rows: ``s = s_pitch - r_b roll`` (rising), ``k``, exponent; NaN-padded, and
        NaN throughout for a stage without a position law.
        """
        out = np.full((self.n_stages, 3, size), np.nan)
        for stage, (roll, k, e) in self.positions.items():
            if len(roll) > size:
                raise CalibrationError(f"stage {stage}: {len(roll)} mesh-cycle positions; the "
                                       f"lumped model takes at most {size}")
            s = s_pitch - base_radius * np.radians(np.asarray(roll, dtype=float))
            order = np.argsort(s)
            out[stage - 1, :, : len(s)] = np.stack([s[order], np.asarray(k)[order],
                                                   np.asarray(e)[order]])
        return out

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Tables padded into one array, shape (n_stages, len(KINDS), n_max, 5), and row
        counts (0 for a kind the stage has no table of)."""
        n_stages = self.n_stages
        rows = {key: t.as_rows() for key, t in self.tables.items()}
        n_max = max(r.shape[0] for r in rows.values())
        out = np.zeros((n_stages, len(KINDS), n_max, 5))
        counts = np.zeros((n_stages, len(KINDS)), dtype=np.int64)
        for (stage, kind), r in rows.items():
            j = KINDS.index(kind)
            out[stage - 1, j, : r.shape[0]] = r
            counts[stage - 1, j] = r.shape[0]
        return out, counts


# -- closed forms ---------------------------------------------------------------------
def contact_radii(gearset: GearSet, stage_index: int) -> tuple[float, float]:
    """Principal relative radii ``(Rx, Ry)`` [m] of the design contact point.

    Profile direction: the pinion involute at the pitch point,
    ``r_p sin(alpha0)``, against the face gear, which is flat like a rack.
    Lengthwise: the curvature mismatch from the shaper, about
    ``(1/r_p - 1/r_s) sin^2(psi_c) / sin(alpha0)`` with
    ``tan(psi_c) = (N_s / N_2) cos(alpha0)`` (an estimate; Litvin,
    NASA/CR-2000-209909), plus the pinion's parabolic lengthwise crowning
    ``delta_l (2u/b)^2``, curvature ``8 delta_l / b^2``.
    """
    p, stage = gearset.pinion, gearset.stages[stage_index]
    alpha = math.radians(p.pressure_angle_deg)
    r_p = p.pitch_radius
    r_s = 0.5 * p.module * stage.shaper_teeth
    psi_c = math.atan(stage.shaper_teeth / stage.teeth * math.cos(alpha))
    mismatch = (1.0 / r_p - 1.0 / r_s) * math.sin(psi_c) ** 2 / math.sin(alpha)
    crowning = 8.0 * p.lengthwise_crowning / p.face_width**2
    curvature = mismatch + crowning
    if curvature <= 0.0:
        raise CalibrationError(
            f"stage {stage_index + 1}: no lengthwise curvature (shaper_teeth = pinion teeth "
            "and no crowning): line contact has no Hertz point-contact stiffness"
        )
    return r_p * math.sin(alpha), 1.0 / curvature


@lru_cache(maxsize=64)
def corner_radii(gearset: GearSet, stage_index: int, side: str) -> tuple[float, float] | None:
    """Principal relative radii ``(Rx, Ry)`` [m] of a rounded tip edge's first touch.

    The edge of ``side`` (``"approach"``: the face gear's on the pinion's
    involute; ``"recess"``: the pinion's on the face gear's flank) touches
    first at the roll angle where the torsional model's planar corner gap is
    `fe_impact.gears.corner.REFERENCE_GAP` (`fe_impact.gears.corner.corner_contact`,
    whole face).
    ``Rx`` is about the rounding's radius, ``Ry`` the radius along the edge
    against the flank's. None for a sharp edge (radius 0): no rounding, no
    Hertz contact. About 0.05 s.
    """
    from fe_impact.gears.corner import corner_contact, touching_edge
    from fe_impact.gears.tca import GearPair

    radius, _, edge = touching_edge(gearset, side)
    if radius <= 0.0:
        return None
    roll = corner_reference_roll(gearset, side)
    pair = GearPair.from_gearset(gearset, stage_index + 1)
    touch = corner_contact(pair, edge(pair, radius), side, roll)
    return 1.0 / touch.relative.lambda_max, 1.0 / touch.relative.lambda_min


def _closed_form_table(gearset: GearSet, stage_index: int, effective_mass: float,
                       kind: str, radii: tuple[float, float] | None = None,
                       stiffness: tuple[float, float] | None = None,
                       source: str = "closed form") -> LawTable:
    """Seed eqs. 12-17 at the speeds `CLOSED_FORM_SPEEDS` for the contact of principal
    relative radii ``radii`` (default: the flanks' design point, `contact_radii`).

    ``stiffness``: ``(K, exponent)`` measured (an FE corner position) instead of the
    Hertz ellipse's; the impact's approach then follows the energy balance of
    ``F = K delta^exponent`` (``m v^2 / 2 = K delta^(n+1) / (n+1)``), and the
    penetration depth ``d`` is that approach at the impact's peak force (for the
    Hertz law, eq. 17 gives the sphere's).

    The flanks' restitution is the seed's: eq. 14 with eq. 15's yield-onset speed
    (a sphere's, 0.087 m/s for the seed's steel). A tip edge's (``radii`` given)
    takes eq. 14 with its own (`fe_impact.physics.hertz.ellipse_yield_speed`: the
    effective mass on the rounding's ellipse reaching 1.6 Y): a 0.1 mm rounding
    reaches 1.6 Y under a few newtons, at a closing speed of about 1 mm/s, where
    eq. 15 would call the corner elastic up to 87 mm/s.
    """
    material = gearset.material
    E_star = hertz.effective_modulus(material.youngs_modulus, material.poisson_ratio)
    Rx, Ry = radii if radii is not None else contact_radii(gearset, stage_index)
    contact = hertz.ellipse_contact(_REFERENCE_LOAD, Rx, Ry, E_star)
    k = _REFERENCE_LOAD / contact.delta**1.5
    v_y = (seed.yield_speed(material.yield_strength, material.density, E_star)
           if radii is None else
           hertz.ellipse_yield_speed(effective_mass, Rx, Ry, E_star, material.yield_strength))
    speeds = CLOSED_FORM_SPEEDS
    n = speeds.size
    if stiffness is None:
        hits = hertz.impact_from_stiffness(effective_mass, speeds, k)  # eq. 16, per speed
        cmax = [seed.damping(k, seed.restitution(v / v_y), v, dm)
                for v, dm in zip(speeds, hits.delta_max, strict=True)]
        d = [seed.penetration_depth(f, math.sqrt(Rx * Ry), E_star) for f in hits.force_max]
        return LawTable(stage_index + 1, kind, speeds, np.full(n, k), np.full(n, 1.5),
                        np.asarray(cmax), np.asarray(d), source)
    k, a = stiffness
    delta = ((a + 1.0) * effective_mass * speeds**2 / (2.0 * k)) ** (1.0 / (a + 1.0))
    cmax = [seed.damping(k, seed.restitution(v / v_y), v, dm, a)
            for v, dm in zip(speeds, delta, strict=True)]
    return LawTable(stage_index + 1, kind, speeds, np.full(n, k), np.full(n, a),
                    np.asarray(cmax), delta, source)


def closed_form_corner_tables(gearset: GearSet, effective_masses: Sequence[float],
                              measured: Mapping[tuple[int, str], tuple[float, float]]
                              | None = None) -> dict[tuple[int, str], LawTable]:
    """Closed-form tables of the corner kinds, for every stage and rounded edge.

    ``measured``: ``(stage, kind) -> (K, exponent)`` of FE corner positions
    (a calibration's ``mesh_cycle`` corners), which replace the Hertz
    stiffness of the rounding in those tables (`_closed_form_table`).
    """
    tables = {}
    for i, mass in enumerate(effective_masses):
        for side, kind in CORNER_KINDS.items():
            radii = corner_radii(gearset, i, side)
            if radii is None:
                continue
            law = (measured or {}).get((i + 1, kind))
            tables[(i + 1, kind)] = _closed_form_table(
                gearset, i, mass, kind, radii, law,
                "closed form" if law is None else
                "FE corner position (K, exponent) with the closed-form restitution")
    return tables


def closed_form_laws(gearset: GearSet, effective_masses: Sequence[float]) -> LawSet:
    """Closed-form IMPACT parameters (seed eqs. 12-17) for every stage and kind.

    The flank kinds take the Hertz ellipse of the design point; the corner kinds,
    for each rounded tip edge, that of the edge's first touch (`corner_radii`).

    Parameters
    ----------
    gearset : GearSet
    effective_masses : sequence of float
        Per stage, the effective mass along the line of action of one mesh
        [kg] (seed eq. 16's ``m_k``).
    """
    if len(effective_masses) != len(gearset.stages):
        raise ValueError(f"need {len(gearset.stages)} effective masses, got "
                         f"{len(effective_masses)}")
    tables = {}
    for i, mass in enumerate(effective_masses):
        for kind in FLANK_KINDS:
            tables[(i + 1, kind)] = _closed_form_table(gearset, i, mass, kind)
    corners = closed_form_corner_tables(gearset, effective_masses)
    tables.update(corners)
    source = "closed form (seed eqs. 12-17, Hertz ellipse"
    source += ("; on the tip edges, the rounding's first touch)" if corners else
               "; sharp tip edges: corner contacts take the flank's law)")
    return LawSet(tables, source)


# -- calibration file ---------------------------------------------------------------------
def _parse_case(record: CalibrationRecord, index: int, gearset: GearSet, r: Reader) -> None:
    """Check a case against the gear set: its stage exists and has its ``face_teeth``."""
    where, n = f"cases[{index}]", len(gearset.stages)
    if record.stage > n:
        raise r.fail(where, "stage", record.stage, f"must be an integer in 1..{n}")
    expected = gearset.stages[record.stage - 1].teeth
    if record.face_teeth is not None and record.face_teeth != expected:
        raise r.fail(where, "face_teeth", record.face_teeth, f"stage {record.stage} of gear "
                     f"set {gearset.name!r} has {expected} teeth")


def _tables_from_cases(records: Sequence[CalibrationRecord], source: str
                       ) -> dict[tuple[int, str], LawTable]:
    grouped: dict[tuple[int, str], list[CalibrationRecord]] = {}
    for rec in records:
        grouped.setdefault((rec.stage, rec.kind), []).append(rec)
    tables = {}
    for (stage, kind), rows in grouped.items():
        rows.sort(key=lambda rec: rec.impact_speed)
        speeds = np.array([rec.impact_speed for rec in rows])
        repeated = speeds[1:][np.diff(speeds) <= 0.0]
        if repeated.size:
            raise CalibrationError(
                f"{source}: two stage {stage} {kind!r} cases at impact_speed = "
                f"{repeated[0]!r} m/s; keep one per speed"
            )
        columns = np.array([[getattr(rec.impact, p) for p in _PARAMETERS] for rec in rows]).T
        tables[(stage, kind)] = LawTable(stage, kind, speeds, *columns, source=source)
    return tables


def contact_time(k: float, exponent: float, mass: float, speed: float) -> float:
    """Undamped duration of an impact under ``F = k delta^exponent`` [s].

    The approach peaks at ``delta_m = ((n+1) m v^2 / (2 k))^(1/(n+1))`` and
    the contact lasts ``2 delta_m / v * sqrt(pi) G(1 + 1/(n+1)) / G(1/2 + 1/(n+1))``
    (energy conservation, ``n`` the exponent; 2.943 delta_m / v for Hertz's
    1.5, Johnson's *Contact Mechanics* eq. 11.24). Worked in logarithms, so
    that ``k = 1e300`` gives a tiny time rather than an overflow.
    """
    n1 = exponent + 1.0
    log_delta = (math.log(n1 * mass * speed**2 / 2.0) - math.log(k)) / n1
    factor = 2.0 * math.sqrt(math.pi) * math.gamma(1.0 + 1.0 / n1) / math.gamma(0.5 + 1.0 / n1)
    return factor * math.exp(log_delta) / speed


def peak_approach(k: float, exponent: float, mass: float, speed: float) -> float:
    """Largest approach of an undamped impact under ``F = k delta^exponent`` [m]:
    ``((n+1) m v^2 / (2 k))^(1/(n+1))`` (energy conservation; `contact_time`)."""
    n1 = exponent + 1.0
    return math.exp((math.log(n1 * mass * speed**2 / 2.0) - math.log(k)) / n1)


def check_integrable(table: LawTable, mass: float) -> None:
    """Refuse a law whose contacts are too short to integrate (`MIN_CONTACT_TIME`) or
    whose approach at its own impact exceeds `MAX_APPROACH` (a unit slip).

    ``mass`` is the stage's effective mass of one mesh [kg].
    """
    for v, k, n, cmax in zip(table.impact_speed, table.k, table.exponent, table.cmax,
                             strict=True):
        approach = peak_approach(float(k), float(n), mass, float(v))
        if approach > MAX_APPROACH:
            raise CalibrationError(
                f"{table.source}: stage {table.stage} {table.kind!r} at {v:.4g} m/s: k = "
                f"{k:.4g}, exponent = {n:.4g}: the teeth would approach by "
                f"{approach * 1e3:.3g} mm in that impact (effective mass {mass:.4g} kg), "
                f"more than the {MAX_APPROACH * 1e3:g} mm no elastic tooth contact reaches; "
                "check the units (k in N/m^exponent)")
        t_c = contact_time(float(k), float(n), mass, float(v))
        t_d = mass / cmax if cmax > 0.0 else math.inf
        if min(t_c, t_d) < MIN_CONTACT_TIME:
            what = (f"its contact would last {t_c:.3g} s" if t_c <= t_d
                    else f"its damping time m/cmax would be {t_d:.3g} s")
            raise CalibrationError(
                f"{table.source}: stage {table.stage} {table.kind!r} at {v:.4g} m/s: k = "
                f"{k:.4g}, exponent = {n:.4g}, cmax = {cmax:.4g}: {what} (effective mass "
                f"{mass:.4g} kg), below {MIN_CONTACT_TIME:g} s: the law cannot be integrated; "
                "check the units (k in N/m^exponent, cmax in N s/m)")


def load_calibration(path: str | Path, gearset: GearSet,
                     effective_masses: Sequence[float] | None = None) -> LawSet:
    """Read a calibration file (schema `SCHEMA`, or the older ``fe-impact/calibration/1``).

    A stage with flank cases of one kind only (``mesh`` or ``switch``) uses them
    for the other kind too; a stage without any flank case falls back to the
    closed forms (which need ``effective_masses``). A corner kind without cases
    takes the closed-form law of its rounded tip edge (with ``effective_masses``),
    else none: its contacts then take the flank's law. Each is logged as a
    warning and kept in the notes.

    Raises
    ------
    CalibrationError
        Missing file, invalid JSON, wrong schema, or an invalid case; the
        message names the file, the case and the key.
    """
    path = Path(path)
    calibration = read_calibration(path, law_only=True)
    parsed = calibration.cases
    r = Reader(str(path), CalibrationError, "json")
    for i, record in enumerate(parsed):
        _parse_case(record, i, gearset, r)
    tables = _tables_from_cases(parsed, path.name)
    if effective_masses is not None:
        for (stage, _), table in tables.items():
            if 1 <= stage <= len(effective_masses):
                check_integrable(table, float(effective_masses[stage - 1]))
    notes = []
    fallback = None
    measured = _measured_corners(calibration.mesh_cycle, len(gearset.stages))
    corners = ({} if effective_masses is None
               else closed_form_corner_tables(gearset, effective_masses, measured))
    for stage in range(1, len(gearset.stages) + 1):
        present = [k for k in FLANK_KINDS if (stage, k) in tables]
        if not present:
            if effective_masses is None:
                raise CalibrationError(f"{path}: no flank case ('mesh' or 'switch') for "
                                       f"stage {stage}")
            if fallback is None:
                fallback = closed_form_laws(gearset, effective_masses)
            for kind in FLANK_KINDS:
                tables[(stage, kind)] = fallback.table(stage, kind)
            notes.append(f"stage {stage}: no calibrated flank case, closed-form parameters "
                         "used")
        for kind in FLANK_KINDS:
            if (stage, kind) not in tables:
                other = tables[(stage, present[0])]
                tables[(stage, kind)] = replace(
                    other, kind=kind,
                    source=f"{other.source}, its {present[0]} cases (no {kind} case)")
                notes.append(f"stage {stage}: no {kind!r} case, {present[0]!r} cases used")
        for kind in CORNER_KINDS.values():
            if (stage, kind) in tables:
                continue
            if (stage, kind) in corners:
                tables[(stage, kind)] = corners[(stage, kind)]
                if (stage, kind) in measured:
                    k, a = measured[(stage, kind)]
                    notes.append(f"stage {stage}: no {kind!r} impact case; the FE corner "
                                 f"position's K = {k:.4g} N/m^{a:.4g} with the closed-form "
                                 "restitution of the rounded tip edge used")
                else:
                    notes.append(f"stage {stage}: no {kind!r} case, the closed-form law of "
                                 "the rounded tip edge used")
            else:
                notes.append(f"stage {stage}: no {kind!r} law (no case, and a sharp tip edge "
                             "or no effective masses for the closed form): corner contacts "
                             "take the flank's law")
    positions = _positions(calibration.mesh_cycle, len(gearset.stages))
    if not positions:
        notes.append("no position dependence: the file has no mesh cycle (schema "
                     f"{calibration.schema}), so every tooth pair takes its impact's law "
                     "at every position along the path of contact")
    else:
        missing = [s for s in range(1, len(gearset.stages) + 1) if s not in positions]
        logger.info("position-dependent pair stiffness for stages %s (%s positions)",
                    sorted(positions), [len(v[0]) for v in positions.values()])
        if missing:
            notes.append(f"stages {missing}: no mesh cycle, the impact's law at every "
                         "position")
    for note in notes:
        logger.warning("%s: %s", path, note)
    logger.info("read %d calibration cases from %s", len(parsed), path)
    source = f"calibration file {path}"
    if positions:
        source += (" (pair stiffness and exponent along the path of contact from its mesh "
                   f"cycle, stages {sorted(positions)}; damping from the impacts)")
    return LawSet(tables, source, tuple(notes), positions)


def _measured_corners(mesh_cycle, n_stages: int) -> dict[tuple[int, str], tuple[float, float]]:
    """The mesh cycle's FE corner laws: ``(stage, kind) -> (K, exponent)``."""
    out = {}
    for key, law in (mesh_cycle or {}).items():
        if int(key) <= n_stages:
            for side, corner in (law.get("corners") or {}).items():
                out[(int(key), CORNER_KINDS[side])] = (float(corner["k"]),
                                                       float(corner["exponent"]))
    return out


def _positions(mesh_cycle, n_stages: int) -> dict[int, tuple[np.ndarray, ...]]:
    """The mesh cycle's position law per stage of the gear set (checked on reading)."""
    if not mesh_cycle:
        return {}
    out = {}
    for key, law in mesh_cycle.items():
        stage = int(key)
        if stage > n_stages:
            raise CalibrationError(f"mesh_cycle stage {stage}: the gear set has stages "
                                   f"1..{n_stages}")
        out[stage] = tuple(np.asarray(law[k], dtype=float)
                           for k in ("roll_angle_deg", "k", "exponent"))
    return out


def laws_for(gearset: GearSet, effective_masses: Sequence[float],
             calibration: str | Path | None = None, *, search: bool = True) -> LawSet:
    """The law tables a run uses: the given file, else `CALIBRATION_FILE`, else closed forms.

    Parameters
    ----------
    gearset : GearSet
    effective_masses : sequence of float
        Per-stage effective mass of one mesh [kg], for the closed forms.
    calibration : path, optional
        A calibration file; it must exist.
    search : bool
        Look for `CALIBRATION_FILE` in the working directory when no file is
        given.
    """
    if calibration is not None:
        return load_calibration(calibration, gearset, effective_masses)
    if search and Path(CALIBRATION_FILE).is_file():
        return load_calibration(CALIBRATION_FILE, gearset, effective_masses)
    logger.warning(
        "no calibration file (%s not given or found): using closed-form IMPACT parameters "
        "(Hertz stiffness, seed eqs. 13-17)", CALIBRATION_FILE,
    )
    return closed_form_laws(gearset, effective_masses)
