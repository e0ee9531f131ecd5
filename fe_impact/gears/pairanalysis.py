"""Tooth contact analysis and Hertz estimates of one tooth pair, before meshing.

:func:`analyse_pair` takes a gear set and a :class:`PairSpec` (stage, pinion
roll angle, gap, impact speed, ...) and returns a :class:`PairAnalysis`: the
TCA contact of the stage's :class:`~fe_impact.gears.tca.GearPair` at the roll
angle, the equivalent radius and ``E*`` of its Hertz contact, the rotor
inertias reduced to the contact normal (:class:`ReducedMasses`), the Hertz
impact at the requested speed, the initial angular velocities that close the
gap at that speed, and the Hertz ellipses (at the design force, which sets the
element sizes of the mesh, and at :data:`REPORT_FORCES`).

Upstream of the mesh: :func:`fe_impact.meshing.toothpair.build_pair` meshes
the pair this analysis describes, and writes it to ``tca.json``
(:meth:`PairAnalysis.to_dict`). SI units, the mesh frame of
:mod:`fe_impact.gears.tca`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from fe_impact.defaults import LEVEL_NAMES, REFINEMENT_RANGE
from fe_impact.errors import GeometryError, MeshError
from fe_impact.gears.tca import (
    ContactEllipse,
    ContactPoint,
    GearPair,
    contact_ellipse,
    equivalent_radius,
)
from fe_impact.physics import hertz

__all__ = [
    "CONTACTS",
    "LEVEL_NAMES",
    "MAX_IMPACT_SPEED",
    "REPORT_FORCES",
    "VELOCITY_SPLITS",
    "PairAnalysis",
    "PairSpec",
    "ReducedMasses",
    "analyse_pair",
    "analyse_stage_pair",
    "corner_contact_point",
    "hertz_impact_estimate",
]

#: Loads [N] at which tca.json lists the Hertz ellipse.
REPORT_FORCES = (37.0, 100.0, 1000.0)
#: Where a pair is built to touch (:attr:`PairSpec.contact`).
CONTACTS = ("flank", "corner-approach", "corner-recess")
#: How the impact speed is shared by the rotors (:attr:`PairSpec.velocity_split`).
VELOCITY_SPLITS = ("momentum", "pinion", "face_gear")
#: Largest impact speed a tooth pair is built for, m/s (the seed's fastest
#: ratio-switch impact, at 1000 r/min, is about 4.2 m/s).
MAX_IMPACT_SPEED = 20.0


@dataclass(frozen=True)
class PairSpec:
    """What to mesh: stage, position, refinement and the impact to set up.

    Parameters
    ----------
    stage : int
        Face-gear stage, 1-based.
    roll_angle_deg : float
        Pinion roll angle from the pitch-point position [deg]
        (:class:`~fe_impact.gears.tca.GearPair`).
    level : {"coarse", "default", "fine"}
        Refinement (:data:`fe_impact.meshing.sizing.LEVELS`).
    refinement : float
        Uniform refinement of the level: every element size of the level and
        its gradation divided by this, so the size field is the level's,
        scaled (1: the level itself; allowed :data:`REFINEMENT_RANGE`). A
        family of meshes in the sense of Richardson's extrapolation
        (``validation/mesh_cycle.py``).
    order : {1, 2}
        Element order.
    gap : float
        Initial normal gap ``h0`` at the contact point [m], >= 0.
    impact_speed : float
        Closing normal speed ``v_k`` at the contact point [m/s], > 0.
    n_face_teeth : int
        Face-gear teeth in the sector, 1..3.
    rim_modules : float
        Rim depth below the root of both sectors, in modules.
    neighbour_teeth : int
        Unloaded teeth beside the loaded ones on each side of both sectors,
        0..2 (each sector is cut half a pitch beyond its outer teeth, and the
        cuts are held: with 0 the cuts half a pitch beside the loaded tooth
        stiffen its root; a neighbour tooth on each side frees it as the rest
        of the gear would).
    design_force : float or None
        Load [N] whose Hertz ellipse sets the element sizes; None takes the
        Hertz peak force of the impact (:func:`fe_impact.physics.hertz.impact` with
        the effective mass and the ellipse's equivalent radius).
    velocity_split : {"momentum", "pinion", "face_gear"}
        How ``v_k`` is shared by the rotors: ``"momentum"`` gives each the
        share that makes the normal momentum ``m_1 v_1 + m_2 v_2`` zero (the
        pair's centre of mass at rest: symmetric rebound, smallest rotations);
        otherwise all of it on one rotor.
    pinion_axial_position : float or None
        See :class:`~fe_impact.gears.tca.GearPair` (m; None: at ``L = r_2``).
    contact : {"flank", "corner-approach", "corner-recess"}
        Where the teeth touch: on the flanks (the tooth contact analysis at the
        roll angle), or the first touch of a rounded tip edge on the mating
        flank (:func:`~fe_impact.gears.corner.corner_contact`): the face gear's
        edge before the path of contact, the pinion's after it. A corner contact
        builds the touching tip edge rounded (the gear set's ``tip_edge_radius_mm``).
    """

    stage: int = 1
    roll_angle_deg: float = 0.0
    level: str = "default"
    order: int = 2
    gap: float = 5e-6
    impact_speed: float = 0.1
    n_face_teeth: int = 1
    rim_modules: float = 2.0
    neighbour_teeth: int = 1
    design_force: float | None = None
    velocity_split: str = "momentum"
    pinion_axial_position: float | None = None
    contact: str = "flank"
    refinement: float = 1.0

    def __post_init__(self) -> None:
        if self.contact not in CONTACTS:
            raise GeometryError(f"contact = {self.contact!r}; pick one of {list(CONTACTS)}")
        if self.level not in LEVEL_NAMES:
            raise MeshError(f"level = {self.level!r}; pick one of {list(LEVEL_NAMES)}")
        lo, hi = REFINEMENT_RANGE
        if isinstance(self.refinement, bool) or not (
                isinstance(self.refinement, int | float) and lo <= self.refinement <= hi):
            raise MeshError(f"refinement = {self.refinement!r}; allowed {lo:g} .. {hi:g} "
                            "(element sizes divided by it)")
        if self.order not in (1, 2) or isinstance(self.order, bool):
            raise MeshError(f"order = {self.order!r}; pick 1 (linear) or 2 (quadratic)")
        if not (math.isfinite(self.gap) and 0.0 <= self.gap <= 1e-3):
            raise MeshError(f"gap = {self.gap * 1e6:g} um; allowed 0 .. 1000 um")
        if not (math.isfinite(self.impact_speed) and 0.0 < self.impact_speed <= MAX_IMPACT_SPEED):
            raise MeshError(f"impact speed = {self.impact_speed!r} m/s; allowed "
                            f"(0, {MAX_IMPACT_SPEED:g}] m/s")
        if self.n_face_teeth not in (1, 2, 3):
            raise MeshError(f"n_face_teeth = {self.n_face_teeth!r}; allowed 1, 2 or 3")
        if self.neighbour_teeth not in (0, 1, 2) or isinstance(self.neighbour_teeth, bool):
            raise MeshError(f"neighbour_teeth = {self.neighbour_teeth!r}; allowed 0, 1 or 2")
        if not (math.isfinite(self.rim_modules) and 0.5 <= self.rim_modules <= 10.0):
            raise MeshError(f"rim_modules = {self.rim_modules!r}; allowed 0.5 .. 10 modules")
        if self.design_force is not None and not (
            math.isfinite(self.design_force) and self.design_force > 0.0
        ):
            raise MeshError(f"design force = {self.design_force!r} N; must be > 0")
        if self.velocity_split not in VELOCITY_SPLITS:
            raise MeshError(
                f"velocity_split = {self.velocity_split!r}; pick one of {list(VELOCITY_SPLITS)}"
            )
        if not (math.isfinite(self.roll_angle_deg) and abs(self.roll_angle_deg) <= 60.0):
            raise GeometryError(
                f"roll angle = {self.roll_angle_deg!r} deg; allowed -60 .. 60 deg"
            )


@dataclass(frozen=True)
class ReducedMasses:
    """Rotor inertias reduced to the contact normal (:func:`~fe_impact.gears.tca.effective_mass`).

    Attributes
    ----------
    pinion_mass, face_mass : float
        ``I_i / l_i^2`` [kg].
    pinion_lever, face_lever : float
        Signed lever arms ``l_i = (e_i x (x_c - p_i)) . n`` [m].
    effective_mass : float
        ``1 / (1/m_1 + 1/m_2)`` [kg].
    """

    pinion_mass: float
    pinion_lever: float
    face_mass: float
    face_lever: float
    effective_mass: float


@dataclass(frozen=True)
class PairAnalysis:
    """Tooth contact analysis and Hertz estimates of one tooth pair (SI units, mesh frame).

    Attributes
    ----------
    spec : PairSpec
        What the pair is built for (gap, impact speed, velocity split, ...).
    contact : ContactPoint
        The TCA contact at the requested roll angle (before opening the gap).
    pinion_roll_placed : float
        Pinion roll angle of the mesh [rad]: the contact's, turned back by
        ``gap / l_1`` to open the gap.
    effective_modulus : float
        ``E*`` of the gear material [Pa].
    equivalent_radius : float
        Radius of the sphere contact with the ellipse's load-approach law [m]
        (:func:`~fe_impact.gears.tca.equivalent_radius`).
    masses : ReducedMasses
    impact : HertzImpact
        Hertz impact of ``masses.effective_mass`` on ``equivalent_radius`` at
        ``spec.impact_speed`` (Johnson 1985, section 11.4).
    velocities : tuple of float
        Initial angular velocities [rad/s] of the pinion (about +z) and the
        face gear (about +y) closing at the impact speed (:func:`_velocities`).
    design_ellipse : ContactEllipse
        Hertz ellipse at the design force (it sets the element sizes).
    ellipses : tuple of ContactEllipse
        Hertz ellipses at :data:`REPORT_FORCES`.
    """

    spec: PairSpec
    contact: ContactPoint
    pinion_roll_placed: float
    effective_modulus: float
    equivalent_radius: float
    masses: ReducedMasses
    impact: hertz.HertzImpact
    velocities: tuple[float, float]
    design_ellipse: ContactEllipse
    ellipses: tuple[ContactEllipse, ...]

    @property
    def gap(self) -> float:
        """Initial normal gap at the contact point [m]."""
        return self.spec.gap

    @property
    def impact_speed(self) -> float:
        """Closing normal speed at the contact point [m/s]."""
        return self.spec.impact_speed

    def to_dict(self) -> dict:
        """JSON-friendly record (SI units): the TCA part of ``tca.json``."""
        hit = self.impact
        return {
            "spec": asdict(self.spec),
            "frame": "mesh frame: y = face-gear axis, origin on it in the pitch plane; pinion "
                     "axis x = 0, y = r_p along z; normal points out of the face gear",
            "contact": self.contact.to_dict(),
            "pinion_roll_angle_placed_rad": self.pinion_roll_placed,
            "effective_modulus_Pa": self.effective_modulus,
            "equivalent_radius_m": self.equivalent_radius,
            "ellipses": [e.to_dict() for e in self.ellipses],
            "design_ellipse": self.design_ellipse.to_dict(),
            "masses": asdict(self.masses),
            "impact": {
                "speed_m_s": self.spec.impact_speed,
                "delta_max_m": hit.delta_max,
                "force_max_N": hit.force_max,
                "contact_time_s": hit.contact_time,
                "velocity_split": self.spec.velocity_split,
                "omega_pinion_rad_s": self.velocities[0],
                "omega_face_rad_s": self.velocities[1],
            },
        }


def _velocities(spec: PairSpec, masses: ReducedMasses) -> tuple[float, float]:
    """Angular velocities (pinion, face gear) [rad/s] about +z and +y closing at ``v_k``.

    The normal velocity of rotor i at the contact is ``omega_i l_i`` (signed
    lever arm); the normal points into the pinion, so closing means
    ``omega_1 l_1 - omega_2 l_2 = -v_k``.
    """
    v, m1, m2 = spec.impact_speed, masses.pinion_mass, masses.face_mass
    l1, l2 = masses.pinion_lever, masses.face_lever
    share = {"momentum": m2 / (m1 + m2), "pinion": 1.0, "face_gear": 0.0}[spec.velocity_split]
    return -share * v / l1, (1.0 - share) * v / l2


def _stage_contact(gearset, spec: PairSpec) -> tuple[GearPair, ContactPoint]:
    """The stage's gear pair and its TCA contact at ``spec``'s roll angle, on the flanks."""
    if not 1 <= spec.stage <= len(gearset.stages):
        raise GeometryError(
            f"stage = {spec.stage}; this gear set has stages 1..{len(gearset.stages)}"
        )
    pair = GearPair.from_gearset(gearset, spec.stage, spec.pinion_axial_position)
    if spec.contact != "flank":
        return pair, corner_contact_point(gearset, pair, spec)
    contact = pair.contact(np.radians(spec.roll_angle_deg))
    if not contact.on_flank:
        raise GeometryError(
            f"roll angle = {spec.roll_angle_deg:g} deg puts the contact off the working flanks "
            f"(face radius {contact.face_parameters[0] * 1e3:.3f} mm, height "
            f"{contact.face_parameters[1] * 1e3:.3f} mm); pick an angle nearer 0"
        )
    return pair, contact


def corner_contact_point(gearset, pair: GearPair, spec: PairSpec) -> ContactPoint:
    """The first touch of ``spec``'s rounded tip edge, as the contact the tooth pair is
    built and placed for: both members where the edge touches (the pinion turned by
    the closing turn on the approach side, the face gear on the recess side), the
    normal out of the face gear, each member's curvatures (the rounding's on the
    edge's member) and their relative curvature."""
    from fe_impact.gears.corner import corner_contact, touching_edge

    side = spec.contact.removeprefix("corner-")
    radius, key, make = touching_edge(gearset, side)
    if radius <= 0.0:
        raise GeometryError(f"contact = {spec.contact!r} needs a rounded tip edge: "
                            f"{key}.tip_edge_radius_mm = 0")
    roll = math.radians(spec.roll_angle_deg)
    touch = corner_contact(pair, make(pair, radius), side, roll)
    phi2 = pair.nominal_face_angle(roll)
    if side == "approach":      # the pinion turned onto the face gear's edge
        roll_closed, face_angle = roll + touch.turn, phi2
        normal = -touch.normal
        pinion_parameters, face_parameters = touch.foot, (touch.section, pair.face.tip_height)
        pinion_curvature, face_curvature = touch.flank, touch.edge
    else:                       # the face gear turned onto the pinion's edge
        roll_closed, face_angle = roll, phi2 + touch.turn
        normal = touch.normal
        pinion_parameters = (touch.section, pair.pinion.theta_tip)
        face_parameters = touch.foot
        pinion_curvature, face_curvature = touch.edge, touch.flank
    return ContactPoint(
        roll_angle=roll_closed, face_angle=face_angle,
        transmission_error=face_angle - pair.nominal_face_angle(roll_closed),
        point=touch.point, normal=normal, pinion_parameters=pinion_parameters,
        face_parameters=face_parameters, pinion_curvature=pinion_curvature,
        face_curvature=face_curvature, relative=touch.relative, on_flank=False, residual=0.0)


def analyse_stage_pair(gearset, spec: PairSpec) -> tuple[GearPair, PairAnalysis]:
    """The stage's gear pair and the TCA and Hertz estimates at ``spec``'s contact.

    :func:`analyse_pair` without dropping the :class:`~fe_impact.gears.tca.GearPair`
    (the mesh builder places the teeth with it).
    """
    pair, contact = _stage_contact(gearset, spec)
    mat = gearset.material
    e_star = hertz.effective_modulus(mat.youngs_modulus, mat.poisson_ratio)
    masses = ReducedMasses(**pair.effective_masses(contact, gearset.pinion.inertia,
                                                   gearset.stages[spec.stage - 1].inertia))
    radius = equivalent_radius(contact.relative, e_star)
    impact = hertz.impact(masses.effective_mass, spec.impact_speed, radius, e_star)
    force = spec.design_force if spec.design_force is not None else impact.force_max
    return pair, PairAnalysis(
        spec=spec, contact=contact,
        pinion_roll_placed=contact.roll_angle + spec.gap / masses.pinion_lever,
        effective_modulus=e_star, equivalent_radius=radius, masses=masses, impact=impact,
        velocities=_velocities(spec, masses),
        design_ellipse=contact_ellipse(contact.relative, force, e_star),
        ellipses=tuple(contact_ellipse(contact.relative, f, e_star) for f in REPORT_FORCES),
    )


def analyse_pair(gearset, spec: PairSpec) -> PairAnalysis:
    """Tooth contact analysis and Hertz estimates of a tooth pair, without meshing."""
    return analyse_stage_pair(gearset, spec)[1]


def hertz_impact_estimate(gearset, stage: int, roll_angle_deg: float, impact_speed: float,
                          contact: str = "flank"):
    """Hertz impact of a stage's tooth pair at the TCA contact, without meshing.

    Returns the :func:`fe_impact.physics.hertz.impact` result (``delta_max``,
    ``force_max``, ``contact_time``) for the effective mass and the equivalent
    radius of the contact at ``roll_angle_deg`` (``contact``: see :class:`PairSpec`).
    """
    spec = PairSpec(stage=stage, roll_angle_deg=roll_angle_deg, impact_speed=impact_speed,
                    contact=contact)
    return analyse_pair(gearset, spec).impact
