"""Tip-edge contact of a pair entering and leaving mesh (`fe_impact.gears.corner`).

The corner gap is checked against a second computation that shares nothing
with the module's projections and root finding (`validation/corner_gaps.py`'s
brute force): the rounded edge sampled as a surface (each section's arc
between its flank and land normals), and the gap as the least rotation, over
the samples, that brings the mating flank onto a sample (the pinion's: r_b
times the polar angle to its involute, plus the crowning; the face gear's:
r_b2 times the polar angle about its axis to its flank at the sample's radius
and height). The rounding's own curvature
is checked on a torus, where it is known in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fe_impact.errors import GeometryError
from fe_impact.gears import default_gearset
from fe_impact.gears.corner import (
    CornerContact,
    EdgeRounding,
    _edge_curvatures,
    corner_contact,
    face_edge_rounding,
    pinion_edge_rounding,
)
from fe_impact.gears.tca import GearPair
from fe_impact.switching.geometry import mesh_geometry
from validation.corner_gaps import arc_samples, brute_gap

GEARSET = default_gearset()
PAIR = GearPair.from_gearset(GEARSET, 1)


def _roll(side: str, delta: float) -> float:
    """Pinion roll angle ``delta`` [m] of line of action beyond the planar model's
    end of flank contact (roll angles grow towards the face-gear tip end)."""
    return float(mesh_geometry(GEARSET).corner_roll(side, delta))


@pytest.mark.parametrize("delta", [2e-4, 1e-3])
def test_approach_gap_is_the_least_pinion_turn_onto_the_rounded_face_edge(delta):
    # Both sample the rounding; the module refines its least between sections by a
    # parabola, the brute force takes the least sample, which lies above the true least
    # by up to k (h/2)^2 between sections (k < 20 1/m, the clearance's curvature along
    # the edge; h = 11 um for 1201 sections over 13.5 mm: 6e-10 m) plus rho dpsi^2 / 8
    # on the arc (400 points over ~110 deg of rho = 0.1 mm: 2e-10 m). So
    # 0 <= brute - module <= 1e-9 m; round-off of the Newton solutions ~1e-12 m.
    roll = _roll("approach", delta)
    edge = face_edge_rounding(PAIR, GEARSET.face_tip_edge_radius, n=1201)
    contact = corner_contact(PAIR, edge, "approach", roll)
    assert isinstance(contact, CornerContact) and contact.side == "approach"
    brute = brute_gap(PAIR, "approach", arc_samples(edge, 400), roll)
    assert -1e-11 <= brute - contact.gap <= 1e-9
    assert contact.gap > 0.0 and contact.on_rounding and not contact.at_edge_end


@pytest.mark.parametrize("delta", [2e-4, 1e-3])
def test_recess_gap_is_the_least_face_gear_turn_onto_the_rounded_pinion_edge(delta):
    # as above, on the 13.5 mm of pinion face over the ring: k < 10 1/m (3e-10 m) and
    # 400 points on each arc of rho = 0.3 mm (6e-10 m): 0 <= brute - module <= 1e-9 m
    roll = _roll("recess", delta)
    edge = pinion_edge_rounding(PAIR, GEARSET.pinion.tip_edge_radius, n=1201)
    contact = corner_contact(PAIR, edge, "recess", roll)
    brute = brute_gap(PAIR, "recess", arc_samples(edge, 400), roll)
    assert -1e-11 <= brute - contact.gap <= 1e-9
    assert contact.gap > 0.0 and contact.on_rounding and not contact.at_edge_end


def test_the_first_touch_gives_a_hertz_contact_across_the_edge():
    # The rounding is the sharper body: across the edge its curvature is 1/rho; the
    # relative curvature across (the larger eigenvalue) is 1/rho plus the flank's
    # normal curvature in that direction, and the ellipse is long along the edge.
    contact = corner_contact(PAIR, face_edge_rounding(PAIR, 1e-4), "approach",
                             _roll("approach", 5e-4))
    assert contact.edge.kappa[1] == pytest.approx(1e4, rel=1e-12)
    across = contact.edge.directions[1]
    expected = 1e4 + contact.flank.normal_curvature(across)
    assert contact.relative.lambda_max == pytest.approx(expected, rel=1e-3)
    ellipse = contact.ellipse(500.0, 115e9)
    assert ellipse.a > 5 * ellipse.b


def test_rounding_curvature_along_a_circular_edge_is_the_torus_formula():
    # A ball of radius rho swept along a circle of radius R is a torus; at a point whose
    # normal makes the angle phi with the outward radius, the curvature along the
    # parallel is cos(phi) / (R + rho cos(phi)) (do Carmo 1976, 3-3, example). Three
    # centres 1 mrad apart: the chord formula's error is ~(1e-3)^2 / 24 relative.
    big, rho = 0.05, 1e-3
    angles = np.array([-1e-3, 0.0, 1e-3])
    centres = big * np.stack([np.cos(angles), np.sin(angles), np.zeros(3)], axis=-1)
    edge = EdgeRounding(rho, angles, centres, np.zeros((3, 3)), np.zeros((3, 3)))
    for phi in (0.0, 0.7, 2.0):
        outward = np.array([math.cos(phi), 0.0, math.sin(phi)])
        curv = _edge_curvatures(edge, 1, np.eye(3), outward)
        along = math.cos(phi) / (big + rho * math.cos(phi))
        assert sorted(curv.kappa) == pytest.approx(sorted([along, 1.0 / rho]), rel=1e-6)


def test_roll_angles_inside_the_path_and_unknown_sides_are_refused():
    edge = face_edge_rounding(PAIR, 1e-4, n=21)
    end = math.degrees(_roll("approach", 0.0))
    far = end + 180.0 / PAIR.pinion.teeth           # half an angular pitch past the end
    allowed = rf"allowed roll angles \({end:.4f}, {far:.4f}\] deg"
    with pytest.raises(GeometryError, match=rf"roll angle 0.0000 deg has no approach corner "
                                            rf"contact.*{allowed}"):
        corner_contact(PAIR, edge, "approach", 0.0)
    # far past the end (it used to fail in the mesh builder's loft, 15 s later)
    with pytest.raises(GeometryError, match=rf"roll angle 30.0000 deg .*{allowed}"):
        corner_contact(PAIR, edge, "approach", math.radians(30.0))
    with pytest.raises(GeometryError, match=r"corner side = 'tip'.*approach.*recess"):
        corner_contact(PAIR, edge, "tip", 0.3)


def test_a_corner_contact_places_the_pair_at_the_edges_first_touch():
    # The tooth pair built for a corner contact touches where corner_contact says: the
    # point lies on both members (the flank of one, the rounding of the other), with the
    # normal out of the face gear, at zero gap once each member is where it says.
    import math

    from fe_impact.gears import default_gearset
    from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
    from fe_impact.switching.geometry import mesh_geometry

    gearset = default_gearset()
    line = mesh_geometry(gearset)
    for side in ("approach", "recess"):
        roll = float(line.corner_roll(side, getattr(line, side).delta_at(10e-6)))
        spec = PairSpec(stage=1, roll_angle_deg=math.degrees(roll), contact=f"corner-{side}",
                        level="coarse", gap=1e-6, impact_speed=0.02)
        pair, analysis = analyse_stage_pair(gearset, spec)
        c = analysis.contact
        assert not c.on_flank
        # the same first touch as the corner module's
        edge = (face_edge_rounding if side == "approach" else pinion_edge_rounding)(
            pair, gearset.face_tip_edge_radius if side == "approach"
            else gearset.pinion.tip_edge_radius)
        touch = corner_contact(pair, edge, side, roll)
        np.testing.assert_allclose(c.point, touch.point, atol=1e-12)
        # normal out of the face gear: the face gear's tip is at +y of its flank's
        # contact, the pinion lies on the side the normal points to
        assert abs(np.linalg.norm(c.normal) - 1.0) < 1e-12
        assert c.normal @ np.array([1.0, 0.0, 0.0]) > 0.5
        # the gap is opened by turning the pinion back by gap / lever
        assert analysis.pinion_roll_placed - c.roll_angle == pytest.approx(
            spec.gap / analysis.masses.pinion_lever, rel=1e-12)
    with pytest.raises(GeometryError, match="no approach corner contact"):
        analyse_stage_pair(gearset, PairSpec(stage=1, roll_angle_deg=0.0,
                                             contact="corner-approach"))


def test_the_meshed_rounding_section_lies_on_the_exact_rounding():
    # The face gear's section in a plane z = c: every point at distance rho from the
    # balls' centre curve (sampled every 0.5 um: the distance error of the sampling is
    # (0.25 um)^2 / (2 rho) < 1e-9 m), its ends on the tip plane and on the flank.
    from scipy.spatial import cKDTree

    from fe_impact.gears import default_gearset
    from fe_impact.meshing.pairgeometry import (
        _face_flank_at_plane,
        _face_rounding_section,
        _FaceFlank,
    )

    gearset = default_gearset()
    pair = GearPair.from_gearset(gearset, 1)
    rho = gearset.face_tip_edge_radius
    for c in (0.083, 0.088, 0.094):   # over the face, 82.5 .. 96 mm
        arc = _face_rounding_section(pair, rho, c, 0.0)
        lengths = np.arange(c - 0.2e-3, c + 0.2e-3, 0.5e-6)
        centres = pair.face_to_mesh(face_edge_rounding(pair, rho, lengths=lengths).centres,
                                    0.0)
        distance, _ = cKDTree(centres).query(arc)
        np.testing.assert_allclose(distance, rho, atol=1e-9)
        assert np.allclose(arc[:, 2], c, atol=1e-15)
        assert arc[0, 1] == pytest.approx(pair.face.tip_height, abs=1e-12)
        flank = _face_flank_at_plane(_FaceFlank(pair.face), c, arc[-1:, 1], 0.0, 1, 0.0)[0]
        np.testing.assert_allclose(flank, arc[-1], atol=1e-12)


def test_the_arc_margin_is_the_angle_to_the_roundings_nearer_end():
    # Independent of the module's own angle: sample the rounding's arc in the touching
    # section (validation.corner_gaps' samples, whose first and last points are the
    # tangencies with the flank and the tip land) and measure, along the arc, how far
    # the sample nearest the touch lies from each end. 2000 samples over ~110 deg:
    # 0.06 deg apart, so agreement to 0.1 deg. And the Hertz ellipse at
    # rounding_force is exactly as wide across the edge as the arc left: b =
    # rho * margin (b ~ F^(1/3) is Hertz's own scaling, so to round-off).
    rho = GEARSET.face_tip_edge_radius
    edge = face_edge_rounding(PAIR, rho, n=241)
    touch = corner_contact(PAIR, edge, "approach", _roll("approach", 5e-4))
    i = int(np.argmin(np.abs(edge.parameter - touch.section)))
    arc = arc_samples(edge, 2000).reshape(len(edge.parameter), 2000, 3)[i]
    arc = PAIR.face_to_mesh(arc, PAIR.nominal_face_angle(touch.roll_angle))  # held there
    k = int(np.argmin(np.linalg.norm(arc - touch.point, axis=-1)))
    steps = np.linalg.norm(np.diff(arc, axis=0), axis=-1)
    to_ends = (steps[:k].sum() / rho, steps[k:].sum() / rho)
    assert touch.arc_margin == pytest.approx(min(to_ends), abs=math.radians(0.1))
    assert 0.0 < touch.arc_margin < math.radians(10.0)     # near the flank's tangency
    e_star = 1.1566e11
    force = touch.rounding_force(rho, e_star)
    assert touch.ellipse(force, e_star).b == pytest.approx(rho * touch.arc_margin, rel=1e-9)


def test_loft_stations_keep_half_a_fine_step_from_the_fine_window():
    # Stage 3's recess corner: the coarse stations (4.5 mm apart) put one 45 um from
    # the fine window (0.5 mm steps within 2.5 mm of the touch). Every gap must be at
    # least half a fine step, the touch must be a station, and the window's steps
    # stay fine.
    from fe_impact.meshing.pairgeometry import FINE_HALF, FINE_STEP, _stations_through

    lo, hi, at = 113.5655e-3, 138.5e-3, 118.6555e-3
    cs = _stations_through(lo, hi, at, 4.5e-3, (FINE_HALF, FINE_STEP))
    assert np.min(np.diff(cs)) >= 0.5 * FINE_STEP
    assert np.min(np.abs(cs - at)) == 0.0 and cs[0] == lo and cs[-1] == hi
    window = cs[np.abs(cs - at) <= FINE_HALF]
    assert np.max(np.diff(window)) <= FINE_STEP * (1 + 1e-9)


@pytest.mark.parametrize("stage", [1, 2])
def test_the_meshed_face_flank_runs_on_along_its_tangent_beyond_the_face_ends(stage):
    # The lofts' section planes cross the face's ends, so the flank they interpolate
    # must be smooth there: beyond an end its polar angle leaves along its tangent
    # in the radius, its slope running out to zero over END_BLEND (held constant,
    # its kink put the loft up to 13 um off the flank next to the end and turned a
    # corner mesh's elements over). Checked at heights on the generated flank and
    # on its continuation below h_ext: the value is continuous (to rounding); the
    # slopes just beyond and just inside the end, each a Richardson-extrapolated
    # one-sided difference (exact for the blend's quadratic, O(h^2) inside), are
    # equal; beyond the blend the angle stays put. The continuation's own slope
    # is a one-sided difference over 1 um: its relative error is about
    # |a''/a'| x 0.5 um, and |a''/a'| is at most 450 /m at the inner end (the
    # slope changes by 1% over 20 um there), 2.3e-4: 1e-3.
    from fe_impact.meshing.pairgeometry import END_BLEND, _FaceFlank

    face = GearPair.from_gearset(GEARSET, stage).face
    flank = _FaceFlank(face)
    h = 1e-6
    for height in (flank.h_ext + 1e-3, flank.h_ext - 0.5e-3):
        for end, out in ((face.face_inner, -1.0), (face.face_outer, 1.0)):
            def angle(radius, height=height):
                return float(flank.angle(np.array([radius]), np.array([height]))[0])

            def slope(direction, at=end, angle=angle):
                one_sided = [(angle(at + direction * k * h) - angle(at)) / (direction * k * h)
                             for k in (1, 2)]
                return 2.0 * one_sided[0] - one_sided[1]

            inside, beyond = slope(-out), slope(out)
            assert abs(inside) > 0.1   # rad/m: the flank does turn with the radius
            assert beyond == pytest.approx(inside, rel=1e-3)
            jump = angle(end + out * 1e-9) - angle(end) - inside * out * 1e-9
            # rad: 0.1 nm at 0.1 m; the flank's own root finding settles the angle to
            # about 1e-13 (a step of the held angle was 8.6e-10 here)
            assert abs(jump) < 1e-12
            far = [angle(end + out * (END_BLEND + d)) for d in (0.0, 1e-3)]
            assert far[1] == far[0]
            assert far[0] - angle(end) == pytest.approx(out * inside * END_BLEND / 2, rel=1e-3)


@pytest.mark.slow   # one coarse corner mesh, ~20 s
def test_a_recess_corner_refined_up_to_the_face_end_meshes(tmp_path):
    # Stage 2's recess corner at 180 mm/s (the seed presets' fastest there) touches
    # 1.1 mm from the face gear's inner end with a design ellipse 1.07 mm long: its
    # micron-sized elements reach the end. With the flank held constant beyond the
    # end, every retry down to the isotropic mesh left an element turned over
    # (quality -0.35 at stretch 1) when the flank nodes were moved onto the flank.
    from fe_impact.calibration.sweep import (
        GAP_FRACTION,
        MAX_GAP,
        ImpactCase,
        Settings,
        case_contact,
    )
    from fe_impact.gears.pairanalysis import hertz_impact_estimate
    from fe_impact.meshing.toothpair import MIN_SICN, build_pair

    case = ImpactCase(2, GEARSET.stages[1].teeth, "corner-recess", 0.18)
    contact, roll = case_contact(case, Settings(level="coarse"), GEARSET)
    hit = hertz_impact_estimate(GEARSET, 2, roll, case.impact_speed, contact)
    pair = build_pair(GEARSET, 2, roll, "coarse", 2, min(MAX_GAP, GAP_FRACTION * hit.delta_max),
                      case.impact_speed, tmp_path, contact=contact)
    assert pair.stats.min_sicn > MIN_SICN


@pytest.mark.slow
def test_the_stage_3_recess_face_gear_sector_lofts():
    # OCC's smooth loft failed through the first section of this sector (beyond the
    # ring's inner cut) while the face-gear flank was held constant beyond the face's
    # ends; its smooth continuation lofts all of them. One volume, with its flank and
    # hub faces found.
    import gmsh

    from fe_impact.gears.pairanalysis import PairSpec, analyse_stage_pair
    from fe_impact.meshing.pairgeometry import _add_face_gear
    from fe_impact.switching.calibration import corner_reference_roll

    roll = math.degrees(corner_reference_roll(GEARSET, "recess"))
    pair, analysis = analyse_stage_pair(GEARSET, PairSpec(
        stage=3, roll_angle_deg=roll, level="coarse", contact="corner-recess"))
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("sector")
        volume, groups = _add_face_gear(gmsh.model, pair, analysis)
        assert len(gmsh.model.getEntities(3)) == 1 and volume > 0
        assert len(groups["face_flank"]) == 1 and len(groups["face_hub"]) >= 1
    finally:
        gmsh.finalize()


def test_the_recess_corner_of_a_face_cut_to_its_undercut_limit():
    # inner_limit = "undercut" admits stage 1's face from 81.6 mm: the projection of
    # the pinion's rounding onto the face gear then has feet in the root fillet, where
    # no flank point exists. They used to stop it ("face-gear flank point not found
    # at L = 82.0151 mm, h = -1.9131 mm"); they are off the flank, and the first
    # touch is the one the conjugate-limit face gives (the touch is far from the
    # inner end: the same gap within 1%).
    import dataclasses

    trimmed = dataclasses.replace(
        GEARSET, inner_limit="undercut",
        stages=(dataclasses.replace(GEARSET.stages[0], inner_radius=81.6e-3),
                *GEARSET.stages[1:]))
    roll = _roll("recess", 0.5e-3)
    touches = []
    for gs in (GEARSET, trimmed):
        pair = GearPair.from_gearset(gs, 1)
        edge = pinion_edge_rounding(pair, gs.pinion.tip_edge_radius, n=201)
        touches.append(corner_contact(pair, edge, "recess", roll))
    assert touches[1].gap == pytest.approx(touches[0].gap, rel=1e-2)


def test_a_node_just_beyond_a_face_end_below_the_generated_flank_is_continued():
    # geometry/two-stage.toml, stage 1: the inner end (139 mm) lies 0.05 mm outside
    # the undercut limit, so 0.02 mm beyond it the lowest generated height is 23 um
    # above h_ext. A mesh node there (the 1000 r/min impact's mesh had one) has no
    # exact flank point; it is continued from the end at its own radius and height:
    # 0.02 mm from the end's flank point at the same height (the flank turns by
    # ~1 rad/m, a few nanometres over that).
    from pathlib import Path

    from fe_impact.gears.gearset import load_gearset
    from fe_impact.meshing.pairgeometry import _FaceFlank

    root = Path(__file__).resolve().parents[1]
    face = GearPair.from_gearset(load_gearset(root / "geometry" / "two-stage.toml"), 1).face
    flank = _FaceFlank(face)
    radius = face.face_inner - 2e-5
    height = 0.5 * (flank.h_ext + face.height_range(radius)[0])
    assert flank.h_ext < height < face.height_range(radius)[0]
    p = flank.point(np.array([radius]), np.array([height]))[0]
    end = face.flank(face.face_inner, height).points
    assert math.hypot(p[0], p[2]) == pytest.approx(radius, rel=1e-12)
    assert p[1] == height
    assert np.linalg.norm(p - end) == pytest.approx(2e-5, rel=0.01)
