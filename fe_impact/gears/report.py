"""What a gear engineer checks before any finite-element work, per face-gear stage.

:func:`stage_geometry` gathers, for each stage of a gear set, in SI units:

- the usable face width: inner limits by undercut and by the conjugate tip,
  outer limit by pointing (:func:`~fe_impact.gears.facegear.face_gear_limits`),
  the chosen radii and their margins, the top land at the outer radius and
  the radius where the top land is :data:`TOP_LAND_MIN` (the seed file's rule
  for the outer radii);
- the path of contact in pinion roll angle: the roll angles where the TCA
  contact (:class:`~fe_impact.gears.tca.GearPair`) leaves the working flanks
  (:attr:`~fe_impact.gears.tca.ContactPoint.on_flank`, the test that makes
  :func:`~fe_impact.gears.pairanalysis.analyse_pair` refuse a roll angle),
  which limit ends it at each side, and the contact ratio: the path's length
  in roll angle over the angular pitch ``2 pi / N_p``;
- the Hertz contact at the pitch point (roll angle 0) under a nominal load
  (:func:`~fe_impact.gears.pairanalysis.analyse_stage_pair`): principal and
  relative curvatures, equivalent radius, ``E*``, ellipse semi-axes, peak
  pressure and approach;
- the pinion's tooth-root bending there, ISO 6336-3 style (the 30 deg tangent
  section on its generated fillet, ``Y_F``, ``Y_S`` and ``sigma_F0`` under the
  nominal load, against ``2 sigma_Flim``; :mod:`fe_impact.gears.root_stress`);
- the rotor inertias reduced to the contact normal there
  (:class:`~fe_impact.gears.pairanalysis.ReducedMasses`);
- the tip edges: the rounding radii, the largest the face gear's top land
  takes and where, what the pinion's roundings leave of its tip land, and
  the line of action as the torsional model sees it
  (:func:`~fe_impact.gears.kinematics.mesh_geometry`): where the flanks end
  with sharp and with rounded edges, and the contact ratio of each;
- the first touch of a pair entering mesh (the face gear's rounded tip edge
  on the pinion's involute) and leaving it (the pinion's rounded tip edge on
  the face gear's flank), three-dimensional
  (:func:`~fe_impact.gears.corner.corner_contact`), at the roll angle where
  the torsional model's planar corner gap is :data:`CORNER_REPORT_GAP`:
  the gap over the whole face and in the pinion's mid-face plane, where
  along the edge it touches, and its Hertz contact under the nominal load.

Nominal load: a torque on the output (all rings sit on it), shared by the
``n_pinions`` meshes of the engaged ring, gives each the normal force
``F = T / (n_pinions |l_2|)`` with ``l_2`` the face gear's lever arm about
its axis at the contact (``r_2 cos(alpha0)`` at the pitch point; the
torsional model's ``base_levers``, :mod:`fe_impact.switching.model`). The
command's default torque is the largest load of the seed presets
(:func:`fe_impact.switching.presets.seed_load_torque`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from fe_impact.errors import GeometryError
from fe_impact.gears.corner import REFERENCE_GAP
from fe_impact.gears.facegear import FaceGearTooth
from fe_impact.gears.gearset import GearSet
from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
from fe_impact.gears.root_stress import iso_root_bending
from fe_impact.gears.tca import MAX_ROLL_STEP, ContactPoint, GearPair, contact_ellipse

__all__ = [
    "ROLL_TOLERANCE",
    "TOP_LAND_MIN",
    "contact_path_ends",
    "pitch_point",
    "radius_at_top_land",
    "stage_geometry",
    "top_land",
]

#: Top-land width [m] the seed file's outer radii are chosen at (seed.toml: "outer
#: = radius where the top land is 0.2 mm ... rounded down to 0.5 mm").
TOP_LAND_MIN = 0.2e-3
#: Planar corner gap [m] at which the report compares the three-dimensional first
#: touch with the torsional model's tables: the corner's reference gap.
CORNER_REPORT_GAP = REFERENCE_GAP
#: Width [rad] of the bracket the ends of the path of contact are bisected to
#: (3e-12 m along the line of action of a 30 mm pinion).
ROLL_TOLERANCE = 1e-10
#: Farthest roll angle [rad] searched for the end of the working flanks (the
#: roll angles a tooth pair is built for, :class:`~fe_impact.gears.pairanalysis.PairSpec`).
MAX_ROLL = math.radians(60.0)


# -- face width ------------------------------------------------------------------------
def top_land(tooth: FaceGearTooth, radius: float) -> float:
    """Top-land width [m] of the face-gear tooth at ``radius`` (arc at the tip plane).

    ``2 L psi`` with ``psi`` the half angle of the top land
    (:meth:`~fe_impact.gears.facegear.FaceGearTooth.top_land_half_angle`);
    negative beyond the pointing limit.
    """
    return float(2.0 * radius * tooth.top_land_half_angle(radius))


def radius_at_top_land(tooth: FaceGearTooth, width: float, outer: float) -> float | None:
    """Radius [m] between ``r_2`` and the pointing limit ``outer`` where the top land is
    ``width``; None if it is narrower than that already at the pitch radius (a small
    module)."""
    r_2 = tooth.pitch_radius
    if top_land(tooth, r_2) < width:
        return None
    return float(brentq(lambda r: top_land(tooth, r) - width, r_2, outer, xtol=1e-12))


def _face_width(gearset: GearSet, index: int) -> dict:
    stage, limits = gearset.stages[index], gearset.stage_limits(index)
    tooth = gearset.face_gear_tooth(index)
    inner_limit = limits.inner(gearset.inner_limit)
    outward = [s.inner_radius - stage.outer_radius for s in gearset.stages
               if s.inner_radius >= stage.outer_radius]
    return {
        "pitch_radius_m": limits.pitch_radius,
        "inner_undercut_limit_m": limits.inner_undercut,
        "inner_conjugate_limit_m": limits.inner_conjugate,
        "outer_pointing_limit_m": limits.outer_pointing,
        "inner_undercut_u_m": limits.inner_undercut_u,
        "inner_conjugate_u_m": limits.inner_conjugate_u,
        "fractions_of_pitch_radius": limits.fractions(),
        "inner_limit_rule": gearset.inner_limit,
        "inner_limit_governing": limits.governing(gearset.inner_limit),
        "inner_limit_reason": limits.inner_reason(gearset.inner_limit),
        "inner_radius_m": stage.inner_radius,
        "outer_radius_m": stage.outer_radius,
        "face_width_m": stage.face_width,
        "inner_margin_m": stage.inner_radius - inner_limit,
        "outer_margin_m": limits.outer_pointing - stage.outer_radius,
        "top_land_at_outer_radius_m": top_land(tooth, stage.outer_radius),
        "top_land_min_m": TOP_LAND_MIN,
        "radius_at_top_land_min_m": radius_at_top_land(tooth, TOP_LAND_MIN,
                                                       limits.outer_pointing),
        "clearance_to_next_ring_m": min(outward) if outward else None,
    }


# -- path of contact ---------------------------------------------------------------------
def _unknowns(contact: ContactPoint) -> np.ndarray:
    """TCA unknowns ``(u, theta, L, h, TE)`` of a solved contact (a Newton start)."""
    return np.array([*contact.pinion_parameters, *contact.face_parameters,
                     contact.transmission_error])


def _contact_or_none(pair: GearPair, roll: float, near: ContactPoint) -> ContactPoint | None:
    """The contact at ``roll`` started from ``near``; None where the geometry has none
    (below the pinion base circle, or Newton lost: both lie off the working flanks)."""
    try:
        return pair.contact(roll, guess=_unknowns(near))
    except GeometryError:
        return None


def _flank_margins(pair: GearPair, contact: ContactPoint) -> dict[str, float]:
    """Distance [m] of the contact to each limit of the working flanks (>= 0 inside).

    The same limits as :meth:`~fe_impact.gears.tca.GearPair._on_flank`, as lengths:
    pinion radii for the involute's roll parameter, axial and radial positions
    and heights for the rest.
    """
    p, f = pair.pinion, pair.face
    u, theta = contact.pinion_parameters
    radius, height = contact.face_parameters
    r = p.base_radius * math.hypot(1.0, theta)
    low, high = f.height_range(radius)
    return {
        "pinion tip": p.base_radius * math.hypot(1.0, p.theta_tip) - r,
        "pinion form circle": r - p.form_radius,
        "pinion face end": 0.5 * p.face_width - abs(u),
        "face inner end": radius - f.face_inner,
        "face outer end": f.face_outer - radius,
        "face-gear tip": high - height,
        "face-gear fillet": height - low,
    }


def _flank_end(pair: GearPair, start: ContactPoint,
               direction: int) -> tuple[ContactPoint, dict[str, float]]:
    """Last on-flank contact from ``start`` turning the pinion in ``direction`` (+1/-1),
    within :data:`ROLL_TOLERANCE`, and its distances to the limits of the flanks (the
    smallest names the limit that ends them there)."""
    inside, outside = start, None
    while outside is None:   # steps of MAX_ROLL_STEP keep Newton in its basin
        roll = inside.roll_angle + direction * MAX_ROLL_STEP
        if abs(roll) > MAX_ROLL:
            raise GeometryError(
                f"the contact stays on the working flanks beyond a roll angle of "
                f"{direction * math.degrees(MAX_ROLL):g} deg; check the gear set"
            )
        contact = _contact_or_none(pair, roll, inside)
        if contact is not None and contact.on_flank:
            inside = contact
        else:
            outside = roll
    while abs(outside - inside.roll_angle) > ROLL_TOLERANCE:
        roll = 0.5 * (inside.roll_angle + outside)
        contact = _contact_or_none(pair, roll, inside)
        if contact is not None and contact.on_flank:
            inside = contact
        else:
            outside = roll
    return inside, _flank_margins(pair, inside)


def contact_path_ends(pair: GearPair, pitch: ContactPoint | None = None) -> dict:
    """Ends of the path of contact of ``pair`` in pinion roll angle.

    Parameters
    ----------
    pair : GearPair
    pitch : ContactPoint, optional
        The contact at roll angle 0 (solved here if not given); it must lie on
        the working flanks.

    Returns
    -------
    dict
        ``first_roll_rad``/``last_roll_rad`` and ``first_limit``/``last_limit``:
        the ends in the order a driving pinion meets them (it turns so that its
        flank pushes the face gear's: opposite to the sign of its lever arm
        about the contact normal, :func:`~fe_impact.gears.tca.effective_mass`),
        and what ends the working flanks there; ``first_margins_m`` and
        ``last_margins_m``: the distance [m] of that end to every limit of the
        flanks (0 for the one that ends them); ``path_length_rad``;
        ``angular_pitch_rad`` =
        ``2 pi / N_p``; ``contact_ratio`` = path length / angular pitch.

    Raises
    ------
    GeometryError
        If the pitch-point contact is off the flanks or the flanks never end.
    """
    pitch = pair.contact(0.0) if pitch is None else pitch
    if not pitch.on_flank:
        raise GeometryError(
            f"stage with {pair.face.teeth} teeth: the contact at the pitch point is off the "
            "working flanks (face width or pinion face too narrow?)"
        )
    ends = {side: _flank_end(pair, pitch, side) for side in (1, -1)}
    # the first point is on the side the driving pinion turns away from: sign(l_1)
    lever = pair.effective_masses(pitch, 1.0, 1.0)["pinion_lever"]
    first, last = (1, -1) if lever > 0.0 else (-1, 1)
    pitch_angle = 2.0 * math.pi / pair.pinion.teeth
    length = ends[1][0].roll_angle - ends[-1][0].roll_angle
    (c_first, m_first), (c_last, m_last) = ends[first], ends[last]
    return {
        "first_roll_rad": c_first.roll_angle,
        "first_limit": min(m_first, key=m_first.get),
        "first_margins_m": m_first,
        "last_roll_rad": c_last.roll_angle,
        "last_limit": min(m_last, key=m_last.get),
        "last_margins_m": m_last,
        "path_length_rad": length,
        "angular_pitch_rad": pitch_angle,
        "contact_ratio": length / pitch_angle,
    }


# -- load and Hertz ----------------------------------------------------------------------
#: The edges of the working flanks, as the tooth contact analysis bounds them
#: (:meth:`~fe_impact.gears.tca.GearPair._on_flank`), each a function of a point in the
#: mesh frame that is >= 0 inside: the face gear's two face ends and its tip plane, the
#: pinion's two face ends (the inner one towards the face-gear axis), tip and form circle.
ELLIPSE_EDGES = ("face-gear inner end", "face-gear outer end", "face-gear tip",
                 "pinion inner face end", "pinion outer face end", "pinion tip",
                 "pinion form circle")


def _edge_margins(pair: GearPair, contact: ContactPoint, point: np.ndarray) -> np.ndarray:
    """Signed distances [m] of a mesh-frame ``point`` inside each of :data:`ELLIPSE_EDGES`
    (radii and heights of the face gear, axial positions and radii of the pinion)."""
    p, f = pair.pinion, pair.face
    q_f = pair.face_rotation(contact.face_angle).T @ point
    q_p = pair.pinion_rotation(contact.roll_angle).T @ (
        point - np.array([0.0, p.pitch_radius, pair.z0]))
    radius, height = math.hypot(q_f[0], q_f[2]), q_f[1]
    axial, pinion_radius = q_p[2], math.hypot(q_p[0], q_p[1])
    return np.array([radius - f.face_inner, f.face_outer - radius, f.tip_height - height,
                     axial + 0.5 * p.face_width, 0.5 * p.face_width - axial,
                     p.tip_radius - pinion_radius, pinion_radius - p.form_radius])


def ellipse_edges(pair: GearPair, contact: ContactPoint, a: float, b: float) -> dict[str, float]:
    """How far [m] the contact ellipse (semi-axes ``a`` along the relative curvature's
    major direction, ``b`` along its minor) runs past each edge of the working flanks
    (negative: how far inside it stays).

    Each edge's margin ``g`` is linearised in the tangent plane (its gradient by central
    differences over 1 um); the ellipse reaches ``sqrt((a g.e_a)^2 + (b g.e_b)^2)`` towards
    it. The flanks' curvature bends them off the plane by ``a^2 kappa / 2``, under a
    micrometre for ``a`` of a few millimetres against the ~0.1-0.5 1/m of the major
    direction. The Hertz ellipse assumes whole flanks: where it overhangs an edge the
    pressure there is higher than ``p0`` (edge loading).
    """
    step = 1e-6
    centre = np.asarray(contact.point, float)
    margin = _edge_margins(pair, contact, centre)
    reach = np.zeros_like(margin)
    for axis, length in ((contact.relative.major, a), (contact.relative.minor, b)):
        direction = np.asarray(axis, float)
        slope = (_edge_margins(pair, contact, centre + step * direction)
                 - _edge_margins(pair, contact, centre - step * direction)) / (2 * step)
        reach += (length * slope) ** 2
    return {name: float(r - m) for name, r, m in zip(ELLIPSE_EDGES, np.sqrt(reach), margin,
                                                     strict=True)}


def pitch_point(gearset: GearSet, number: int, torque: float) -> tuple[GearPair, dict]:
    """The stage's pair and its pitch-point rows of :func:`stage_geometry` (``pitch_point``,
    ``masses``, and ``_contact``: the contact there) under ``torque`` on the output."""
    pair = GearPair.from_gearset(gearset, number)
    contact = pair.contact(0.0)
    if not contact.on_flank:
        stage = gearset.stages[number - 1]
        raise GeometryError(
            f"stage {number} ({stage.teeth} teeth): the contact at the pitch point (face "
            f"radius {contact.face_parameters[0] * 1e3:.3f} mm) is off the working flanks; "
            f"the face spans {stage.inner_radius * 1e3:.3f} .. {stage.outer_radius * 1e3:.3f} "
            "mm and must contain the pitch radius"
        )
    pair, analysis = analyse_stage_pair(gearset, PairSpec(stage=number, roll_angle_deg=0.0))
    contact, masses = analysis.contact, analysis.masses
    force = torque / (gearset.n_pinions * abs(masses.face_lever))
    ellipse = contact_ellipse(contact.relative, force, analysis.effective_modulus)
    limit = gearset.material.contact_stress_limit
    edges = ellipse_edges(pair, contact, ellipse.a, ellipse.b)
    worst = max(edges, key=edges.get)
    hertz = {
        "contact_point_m": contact.point.tolist(),
        "pinion_curvatures_1_m": contact.pinion_curvature.kappa.tolist(),
        "face_curvatures_1_m": contact.face_curvature.kappa.tolist(),
        "relative_curvatures_1_m": [contact.relative.lambda_min, contact.relative.lambda_max],
        "relative_radii_m": list(contact.relative.radii),
        "equivalent_radius_m": analysis.equivalent_radius,
        "effective_modulus_Pa": analysis.effective_modulus,
        "load_torque_Nm": torque,
        "normal_force_N": force,
        "a_m": ellipse.a,
        "b_m": ellipse.b,
        "max_pressure_Pa": ellipse.p0,
        "approach_m": ellipse.approach,
        "contact_stress_limit_Pa": limit,
        "contact_stress_ratio": ellipse.p0 / limit,
        "ellipse_overhang_m": edges,
        "ellipse_nearest_edge": worst,
        "ellipse_past_edge_m": edges[worst],
    }
    reduced = {
        "pinion_inertia_kg_m2": gearset.pinion.inertia,
        "face_inertia_kg_m2": gearset.stages[number - 1].inertia,
        "pinion_mass_kg": masses.pinion_mass,
        "pinion_lever_m": masses.pinion_lever,
        "face_mass_kg": masses.face_mass,
        "face_lever_m": masses.face_lever,
        "effective_mass_kg": masses.effective_mass,
    }
    bending = iso_root_bending(pair, contact, force, gearset.material.bending_stress_limit)
    return pair, {"pitch_point": hertz, "masses": reduced, "root_bending": bending,
                  "_contact": contact}


def stage_geometry(gearset: GearSet, torque: float | list[float]) -> list[dict]:
    """Pre-FE checks of every stage of ``gearset`` (module docstring), SI units.

    Parameters
    ----------
    gearset : GearSet
    torque : float or sequence of float
        Load torque on the output [N m], > 0 (the command's default:
        :func:`fe_impact.switching.presets.seed_load_torque`); a sequence gives
        one per stage (a schedule's largest load on each).

    Returns
    -------
    list of dict
        One per stage, in order: ``stage``, ``teeth``, ``shaper_teeth`` and the
        sections ``face_width``, ``path_of_contact``, ``pitch_point``,
        ``masses`` (keys carry their units: ``_m``, ``_rad``, ``_Pa``, ``_N``,
        ``_kg``, ``_Nm``, ``_1_m``).
    """
    torques = ([torque] * len(gearset.stages) if np.ndim(torque) == 0 else list(torque))
    if len(torques) != len(gearset.stages):
        raise GeometryError(f"load torques: {len(torques)} given for "
                            f"{len(gearset.stages)} stages; give one per stage")
    for value in torques:
        if value is None or not (math.isfinite(value) and value > 0.0):
            raise GeometryError(f"load torque = {value!r} N m; must be a number > 0")
    from dataclasses import replace

    from fe_impact.gears.kinematics import mesh_geometry

    # the torsional model's line of action, with the gear set's tip edges and sharp:
    # the same for every stage
    sharp = replace(gearset, pinion=replace(gearset.pinion, tip_edge_radius=0.0),
                    face_tip_edge_radius=0.0)
    line, sharp_line = mesh_geometry(gearset), mesh_geometry(sharp)
    rows = []
    for index, stage in enumerate(gearset.stages):
        pair, pitch = pitch_point(gearset, index + 1, torques[index])
        rows.append({
            "stage": index + 1,
            "teeth": stage.teeth,
            "shaper_teeth": stage.shaper_teeth,
            "face_width": _face_width(gearset, index),
            "path_of_contact": contact_path_ends(pair, pitch.pop("_contact")),
            **pitch,
            "tip_edges": _tip_edges(gearset, index, line, sharp_line),
            "corners": _corners(gearset, pair, pitch["pitch_point"], line),
        })
    return rows


def _corners(gearset: GearSet, pair: GearPair, pitch: dict, line) -> dict:
    """First touches beyond both ends of the path (module docstring), at the roll
    angles where the line of action ``line`` (planar corners) gives the report's gap."""
    from fe_impact.gears.corner import (
        corner_contact,
        face_edge_rounding,
        midplane_rounding,
        pinion_edge_rounding,
    )

    force, e_star = pitch["normal_force_N"], pitch["effective_modulus_Pa"]
    rows = {}
    for side, table, radius, edge in (
            ("approach", line.approach, gearset.face_tip_edge_radius, face_edge_rounding),
            ("recess", line.recess, gearset.pinion.tip_edge_radius, pinion_edge_rounding)):
        if radius <= 0.0:
            rows[side] = None          # a sharp edge: no ball, no Hertz contact
            continue
        delta = table.delta_at(CORNER_REPORT_GAP)
        roll = float(line.corner_roll(side, delta))
        touch = corner_contact(pair, edge(pair, radius), side, roll)
        plane = corner_contact(pair, midplane_rounding(pair, radius, side, roll), side, roll)
        ellipse = touch.ellipse(force, e_star)
        rows[side] = {
            "roll_rad": roll,
            "line_beyond_end_m": delta,
            "planar_gap_m": CORNER_REPORT_GAP,
            "midplane_gap_m": plane.gap,
            "gap_m": touch.gap,
            "section_m": touch.section,
            "on_rounding": touch.on_rounding,
            "at_edge_end": touch.at_edge_end,
            "relative_curvatures_1_m": [touch.relative.lambda_min, touch.relative.lambda_max],
            "normal_force_N": force,
            "a_m": ellipse.a,
            "b_m": ellipse.b,
            "max_pressure_Pa": ellipse.p0,
            # beyond this force the Hertz ellipse runs off the rounding's arc (onto the
            # flank beside it, or the tip land): the closed form no longer describes it
            "arc_margin_rad": touch.arc_margin,
            "rounding_force_N": touch.rounding_force(radius, e_star),
        }
    return rows


def _tip_edges(gearset: GearSet, index: int, line, sharp_line) -> dict:
    """The tip-edge roundings of stage ``index`` and of the pinion, and the line of
    action they leave (``line``; ``sharp_line`` with sharp edges; module docstring)."""
    pinion = gearset.pinion
    limit, where = gearset.face_tip_edge_limit(index)
    half_land = pinion.tip_edge_rounding()[1]
    r_a = pinion.pitch_radius + pinion.addendum_coeff * pinion.module
    return {
        "face_radius_m": gearset.face_tip_edge_radius,
        "face_limit_m": limit,
        "face_limit_at_radius_m": where,
        "pinion_radius_m": pinion.tip_edge_radius,
        "pinion_tip_land_left_m": 2.0 * half_land * r_a,
        "pinion_tip_land_sharp_m": pinion.tip_land(),
        "line_start_sharp_m": sharp_line.s_start,
        "line_start_m": line.s_start,
        "line_end_sharp_m": sharp_line.s_end,
        "line_end_m": line.s_end,
        "contact_ratio_sharp": sharp_line.contact_ratio,
        "contact_ratio": line.contact_ratio,
    }
