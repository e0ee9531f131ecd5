"""Meshes of the tooth pair: groups, gap, hubs, quality, case file, command.

The mesh is read back with fe_impact's own reader (the solver's view of it)
and checked against the gear geometry and the TCA, not against the builder's
internals.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict

import numpy as np
import pytest

from fe_impact.cli.mesh import register
from fe_impact.errors import FeImpactError, GeometryError, MeshError
from fe_impact.fe.case import ContactSpec, load_case
from fe_impact.fe.mesh import load_mesh
from fe_impact.gears import GearPair, default_gearset
from fe_impact.gears.pairanalysis import PairSpec
from fe_impact.meshing.toothpair import MIN_SICN, build_pair, pair_key
from fe_impact.physics import hertz

GAP = 5e-6
SPEED = 0.1


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


@pytest.fixture(scope="module")
def coarse(gearset, tmp_path_factory):
    """Default stage-1 pair at level coarse, P2 (the CI-sized mesh)."""
    out = tmp_path_factory.mktemp("pair_coarse")
    return build_pair(gearset, 1, 0.0, "coarse", 2, GAP, SPEED, out)


@pytest.fixture(scope="module")
def mesh(coarse):
    pair = coarse
    return load_mesh(pair.mesh_path, unit="mm")


def _local(points, origin, axes):
    return (points - origin) @ np.asarray(axes).T


def test_coarse_mesh_is_small(coarse):
    pair = coarse
    # the CI-sized mesh (its build time is docs/performance.md's, not a test's)
    assert 5_000 < pair.stats.n_dofs < 60_000
    assert pair.stats.n_dofs == 3 * pair.stats.n_nodes


def test_groups_and_elements(mesh, coarse):
    pair = coarse
    assert set(mesh.volumes) == {"pinion", "face_gear"}
    assert {"pinion_flank", "face_flank", "pinion_hub", "face_hub"} <= set(mesh.surfaces)
    assert mesh.order == 2 and mesh.cells.shape[1] == 10
    counts = pair.stats.n_elements
    assert len(mesh.volume("pinion")) == counts["pinion"]
    assert len(mesh.volume("face_gear")) == counts["face_gear"]
    assert mesh.n_points == pair.stats.n_nodes


def test_mesh_is_in_millimetres(coarse):
    """The file holds mm (the case says unit = "mm"): the contact point at r_2 = 84 mm."""
    import meshio

    pair = coarse
    pts = meshio.read(pair.mesh_path).points
    assert 70.0 < pts[:, 2].min() and pts[:, 2].max() < 100.0


def _fit_quadratic(points):
    """w = c0 + c1 s + c2 t + c3 s^2 + c4 s t + c5 t^2 by least squares; returns c."""
    s, t, w = points.T
    a = np.stack([np.ones_like(s), s, t, s * s, s * t, t * t], axis=1)
    return np.linalg.lstsq(a, w, rcond=None)[0]


def test_flanks_are_separated_by_the_gap_at_the_contact_point(mesh, coarse):
    """Fit both flanks' nodes near the contact point by quadratics in the contact frame
    (major, minor, normal from the TCA) and take the minimum of their difference.

    The nodes lie on the exact flanks, so the only error is the quadratic fit over
    the patch (|s| <= 0.8 mm, |t| <= 0.12 mm): the cubic terms of the pinion profile,
    about kappa^2 t^3 ~ 1e4 * 1e-12 = 1e-8 m, a few per mille of the 5 um gap; the
    gap itself is made by turning the pinion by h0 / l1, exact to O(h0^2 / R) ~ 1e-9 m.
    """
    pair = coarse
    c = pair.contact
    axes = (pair.ellipse.major, pair.ellipse.minor, c.normal)
    fits = {}
    for name in ("pinion_flank", "face_flank"):
        nodes = mesh.surface_points(name)
        loc = _local(mesh.points[nodes], c.point, axes)
        near = (np.abs(loc[:, 0]) < 0.8e-3) & (np.abs(loc[:, 1]) < 0.12e-3)
        assert near.sum() >= 25
        fits[name] = _fit_quadratic(loc[near])
    g = fits["pinion_flank"] - fits["face_flank"]
    hess = np.array([[2 * g[3], g[4]], [g[4], 2 * g[5]]])
    st = np.linalg.solve(hess, -g[1:3])
    gap = g[0] + g[1:3] @ st + 0.5 * st @ hess @ st
    assert gap == pytest.approx(GAP, rel=0.01)
    # the minimum is at the contact point (within a fraction of the element size)
    assert np.all(np.abs(st) < 0.05e-3)


def test_flank_nodes_lie_on_the_exact_flanks(mesh, coarse, gearset):
    """Every face-flank node, P2 mid-edge nodes included, on FaceGearTooth.flank at its
    own radius and height (above the involute band's lower end); 0.1 m coordinates:
    a few ulp."""
    pair = coarse
    face = GearPair.from_gearset(gearset, 1).face
    angle = pair.contact.face_angle
    c, s = np.cos(angle), np.sin(angle)
    x = mesh.points[mesh.surface_points("face_flank")]
    local = np.stack([c * x[:, 0] - s * x[:, 2], x[:, 1], s * x[:, 0] + c * x[:, 2]], axis=1)
    low = max(face.height_range(face.face_inner)[0], face.height_range(face.face_outer)[0])
    keep = local[:, 1] > low + 1e-5
    exact = face.flank(np.hypot(local[keep, 0], local[keep, 2]), local[keep, 1]).points
    assert np.abs(exact - local[keep]).max() < 1e-9  # mm file: rounding of 17 digits in mm


def test_hub_faces_lie_where_expected(mesh, coarse, gearset):
    """pinion_hub: the rim cylinder rho = r_root - 2 m about the pinion axis and the two
    radial planes at +-(2 n + 1) pi/N_p from the tooth centre (n neighbour teeth on each
    side, half a pitch beyond the outer ones); face_hub: the plane y = root - 2 m and the
    radial planes at +-(2 n + 1) pi/N_2 (rotated by phi_2).

    Only the flanks are moved onto exact surfaces; other faces are carried by a
    surface mesh through the stretch map (planes stay within a few micrometres,
    measured 4.5 um) and mid-edge nodes are straight, so on the rim arc they sit on
    the chord: sagitta h^2 / (8 r). Gmsh takes an edge as of unit size up to about
    1.4 times the size field, so h up to 1.5 times the far size 3.75 mm: 211 um."""
    pair = coarse
    g = GearPair.from_gearset(gearset, 1)
    p, f = g.pinion, g.face
    cuts = 2 * pair.analysis.spec.neighbour_teeth + 1
    assert cuts == 3  # the default: one neighbour tooth on each side
    planes = 10e-6
    rim = p.root_radius - 2 * p.module
    chord = (1.5 * 1.25 * 3e-3) ** 2 / (8 * rim) + planes
    # pinion frame: undo Rz(pi + pi/(2 N_p) + phi) about (0, r_p, z0)
    phi = pair.analysis.pinion_roll_placed
    x = mesh.points[mesh.surface_points("pinion_hub")] - [0.0, p.pitch_radius, g.z0]
    a = -(np.pi + np.pi / (2 * p.teeth) + phi)
    xp = np.stack([np.cos(a) * x[:, 0] - np.sin(a) * x[:, 1],
                   np.sin(a) * x[:, 0] + np.cos(a) * x[:, 1]], axis=1)
    rho, sigma = np.hypot(*xp.T), np.arctan2(xp[:, 0], xp[:, 1])
    on_rim = (rho > rim - chord) & (rho < rim + planes)
    on_cut = np.abs(rho * (np.abs(sigma) - cuts * np.pi / p.teeth)) < planes
    assert np.all(on_rim | on_cut) and on_rim.any() and on_cut.any()
    # face gear
    x = mesh.points[mesh.surface_points("face_hub")]
    on_bottom = np.abs(x[:, 1] - (f.root_height - 2 * f.module)) < planes
    on_planes = np.zeros(len(x), bool)
    for side in (-1, 1):
        ang = side * cuts * np.pi / f.teeth + pair.contact.face_angle
        on_planes |= np.abs(x[:, 0] * np.cos(ang) - x[:, 2] * np.sin(ang)) < planes
    assert np.all(on_bottom | on_planes) and on_bottom.any() and on_planes.any()


def test_element_quality(mesh, coarse):
    """Gmsh's minimum SICN above the builder's acceptance level, and, independently,
    every tetrahedron's corner volume positive (Gmsh orders them positively)."""
    pair = coarse
    assert pair.stats.min_sicn > MIN_SICN
    assert pair.stats.mean_sicn > 0.3
    p = mesh.points[mesh.cells[:, :4]]
    vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
    assert vol.min() > 0.0


def test_impact_case(coarse, gearset):
    """The impact case against the gear set, the TCA and Hertz; case.toml reads back to it."""
    pair = coarse
    case, tca = pair.case, pair.analysis
    assert load_case(pair.case_path) == case
    assert pair.case_path.read_text().startswith("# Dynamic single-tooth impact")
    assert case.mesh_file == pair.mesh_path.resolve() and case.unit == "mm"
    (mat,) = case.materials
    assert mat.volumes == ("pinion", "face_gear")
    assert mat.youngs_modulus == 212e9 and mat.poisson_ratio == 0.289
    assert mat.density == 7860.0 and mat.yield_strength == 835e6
    # automatic penalty and contact zone
    assert case.contacts == (ContactSpec("pinion_flank", "face_flank"),)
    pinion, face = case.rigid_bodies
    assert pinion.surface == "pinion_hub" and face.surface == "face_hub"
    assert pinion.motion == face.motion == "rotation"
    assert pinion.direction == (0.0, 0.0, 1.0) and face.direction == (0.0, 1.0, 0.0)
    assert pinion.point == (0.0, 0.0285, 0.0) and face.point == (0.0, 0.0, 0.0)
    assert pinion.inertia == 1.96e-4 and face.inertia == 7.15e-3
    # closing at the impact speed: (v_pinion - v_face) . n = -v_k, n into the pinion
    x, n = tca.contact.point, tca.contact.normal
    velocity = []
    for body in (pinion, face):
        arm = x - np.array(body.point)
        velocity.append(body.initial_velocity * np.cross(body.direction, arm) @ n)
    # the case holds the velocities as computed: the lever arms recomputed here
    # differ by rounding only
    assert velocity[0] - velocity[1] == pytest.approx(-SPEED, rel=1e-12)
    # momentum split: m1 v1 + m2 v2 = 0 with m_i = I_i / l_i^2, l_i recomputed here
    levers = [np.cross(b.direction, x - np.array(b.point)) @ n for b in (pinion, face)]
    masses = [b.inertia / lev**2 for b, lev in zip((pinion, face), levers, strict=True)]
    momentum = masses[0] * abs(velocity[0])
    assert masses[0] * velocity[0] + masses[1] * velocity[1] == pytest.approx(
        0.0, abs=1e-12 * momentum)
    m_eff = masses[0] * masses[1] / (masses[0] + masses[1])
    assert tca.masses.effective_mass == pytest.approx(m_eff, rel=1e-12)
    # duration: 2.5 Hertz contact times of the effective mass on the equivalent radius
    e_star = hertz.effective_modulus(212e9, 0.289)
    hit = hertz.impact(m_eff, SPEED, tca.equivalent_radius, e_star)
    analysis = case.analysis
    assert analysis.type == "dynamic" and analysis.integrator == "newmark"
    assert analysis.time_step is None  # automatic
    assert analysis.duration == pytest.approx(2.5 * hit.contact_time, rel=1e-9)
    # ParaView frames: FRAMES_PER_CONTACT (20) per Hertz contact time
    assert analysis.output_interval == pytest.approx(hit.contact_time / 20, rel=1e-9)


def test_tca_json_holds_the_analysis(coarse):
    """tca.json: its keys, and the values of the PairAnalysis it is written from."""
    pair = coarse
    tca, a = json.loads(pair.tca_path.read_text()), pair.analysis
    assert list(tca) == ["key", "gearset", "spec", "frame", "contact",
                         "pinion_roll_angle_placed_rad", "effective_modulus_Pa",
                         "equivalent_radius_m", "ellipses", "design_ellipse", "masses",
                         "impact", "mesh", "stretch_factor"]
    assert tca["key"] == pair.key and tca["spec"]["gap"] == GAP == a.gap
    assert tca["impact"] == {
        "speed_m_s": SPEED, "delta_max_m": a.impact.delta_max,
        "force_max_N": a.impact.force_max, "contact_time_s": a.impact.contact_time,
        "velocity_split": "momentum", "omega_pinion_rad_s": a.velocities[0],
        "omega_face_rad_s": a.velocities[1]}
    assert tca["masses"] == asdict(a.masses)
    assert tca["contact"]["point_m"] == a.contact.point.tolist()
    assert [e["force_N"] for e in tca["ellipses"]] == [37.0, 100.0, 1000.0]
    assert [e["approach_m"] for e in tca["ellipses"]] == [e.approach for e in a.ellipses]
    assert tca["design_ellipse"]["p0_Pa"] == a.design_ellipse.p0 == pair.ellipse.p0
    assert tca["pinion_roll_angle_placed_rad"] == a.pinion_roll_placed
    assert tca["mesh"]["n_dofs"] == pair.stats.n_dofs
    assert tca["stretch_factor"] == pair.stats.element_sizes["factor"]


def test_key_and_reuse(coarse, gearset):
    """Same inputs, same key; any change, another; reuse returns the files untouched."""
    pair = coarse
    spec = PairSpec(stage=1, level="coarse", order=2, gap=GAP, impact_speed=SPEED)
    assert pair_key(gearset, spec) == pair.key
    other = PairSpec(stage=1, level="coarse", order=2, gap=2 * GAP, impact_speed=SPEED)
    assert pair_key(gearset, other) != pair.key
    stamp = pair.mesh_path.stat().st_mtime_ns
    again = build_pair(gearset, 1, 0.0, "coarse", 2, GAP, SPEED, pair.mesh_path.parent,
                       reuse=True)
    assert again.key == pair.key and again.stats == pair.stats
    # the case and the analysis are derived again, equal to those of the build
    assert again.case == pair.case
    assert again.analysis.to_dict() == pair.analysis.to_dict()
    assert pair.mesh_path.stat().st_mtime_ns == stamp   # reused, not meshed again


@pytest.mark.parametrize(
    "kwargs, error, words",
    [
        ({"level": "medium"}, MeshError, "level"),
        ({"order": 3}, MeshError, "order"),
        ({"gap": -1e-6}, MeshError, "gap"),
        ({"impact_speed": 0.0}, MeshError, "impact speed"),
        ({"stage": 5}, GeometryError, "stage"),
        ({"roll_angle_deg": 20.0}, GeometryError, "off the working flanks"),
        ({"roll_angle_deg": 30.0}, GeometryError, "base circle"),
        ({"n_face_teeth": 4}, MeshError, "n_face_teeth"),
    ],
)
def test_invalid_options(gearset, tmp_path, kwargs, error, words):
    args = {"stage": 1, "roll_angle_deg": 0.0, "level": "coarse", "order": 2, "gap": GAP,
            "impact_speed": SPEED, **kwargs}
    with pytest.raises(error, match=words):
        build_pair(gearset, out_dir=tmp_path, **args)
    assert not list(tmp_path.iterdir())  # nothing written


def _parser():
    parser = argparse.ArgumentParser(prog="fe-impact")
    register(parser.add_subparsers())
    return parser


def test_command_writes_mesh_case_summary_and_picture(tmp_path, capsys):
    args = _parser().parse_args(["mesh", "--level", "coarse", "--order", "1", "--gap", "3",
                                 "--impact-speed", "0.2", "--out", str(tmp_path)])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    assert "Hertz ellipse" in printed and "DOFs" in printed and "wrote" in printed
    for name in ("pair.msh", "case.toml", "tca.json", "pair.png"):
        assert (tmp_path / name).stat().st_size > 0
    tca = json.loads((tmp_path / "tca.json").read_text())
    assert tca["spec"]["gap"] == pytest.approx(3e-6) and tca["spec"]["order"] == 1
    assert load_mesh(tmp_path / "pair.msh", unit="mm").order == 1
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind


@pytest.mark.parametrize(
    "argv, option",
    [(["--level", "medium"], "--level"), (["--order", "3"], "--order"),
     (["--gap", "-2"], "--gap"), (["--impact-speed", "0"], "--impact-speed"),
     (["--stage", "7"], "--stage"), (["--face-teeth", "5"], "--face-teeth"),
     (["--refinement", "0.2"], "--refinement"), (["--refinement", "nan"], "--refinement")],
)
def test_command_user_errors_name_the_option(tmp_path, argv, option):
    args = _parser().parse_args(["mesh", *argv, "--out", str(tmp_path)])
    with pytest.raises(FeImpactError, match=option):
        args.func(args)


def test_pinion_flank_snap_stays_on_the_involute_at_the_base_circle(gearset):
    """Snapping a flank node onto the crowned pinion flank keeps its radius and axial
    position. At radii above the base circle the Newton solve must return that radius
    to rounding (1e-12 relative); a node a hair inside the base circle (where the flank
    meets the root) has no point with roll angle >= 0 at its radius and must stay at
    the flank's start (radius r_b; 1 nm: rounding of the roll angle near the start,
    where the radius is flat in it), not on the mirrored branch, which moved such
    a node by up to millimetres and turned its elements inside out."""
    from fe_impact.meshing.pairgeometry import _pinion_flank_point

    pinion = GearPair.from_gearset(gearset, 1).pinion
    r_b = pinion.base_radius
    u = np.array([-5e-3, 0.0, 2.6e-3, 7e-3])
    for radius in (1.01 * r_b, 1.1 * r_b, 0.5 * (r_b + pinion.tip_radius)):
        p = _pinion_flank_point(pinion, u, np.full(u.shape, radius))
        assert np.allclose(np.hypot(p[:, 0], p[:, 1]), radius, rtol=1e-12, atol=0)
        assert np.allclose(p[:, 2], u, rtol=0, atol=1e-12)
    # the flank's start: roll angle t* = delta / r_b, radius r_b (no relief at u = 0)
    r_b_points = _pinion_flank_point(pinion, u, np.full(u.shape, r_b))
    assert np.allclose(np.hypot(r_b_points[:, 0], r_b_points[:, 1]), r_b, rtol=1e-12, atol=0)
    for radius in (r_b - 2e-6, r_b - 1e-4):
        p = _pinion_flank_point(pinion, u, np.full(u.shape, radius))
        assert np.all(np.linalg.norm(p - r_b_points, axis=1) < 1e-9)


@pytest.mark.slow   # three coarse meshes, ~18 s
def test_a_mesh_does_not_depend_on_what_the_process_built_before(gearset, tmp_path):
    """A process builds a stage's sector solids once and turns them into place for
    every later position; they are built at the pitch point with no gap, so a
    position's mesh is the same whether it is the first the process makes or comes
    after another (a sweep's workers take cases in any order, a resumed run makes
    one alone). Checked exactly: the same node coordinates, as read back."""
    import fe_impact.meshing.solids as solids

    saved = dict(solids._SOLIDS)
    try:
        solids._SOLIDS.clear()
        first = build_pair(gearset, 1, 9.5, "coarse", 2, GAP, SPEED, tmp_path / "a")
        solids._SOLIDS.clear()
        build_pair(gearset, 1, -6.0, "coarse", 2, GAP, SPEED, tmp_path / "b")
        again = build_pair(gearset, 1, 9.5, "coarse", 2, GAP, SPEED, tmp_path / "c")
    finally:
        solids._SOLIDS.clear()
        solids._SOLIDS.update(saved)
    a, c = load_mesh(first.mesh_path, unit="mm"), load_mesh(again.mesh_path, unit="mm")
    assert a.points.shape == c.points.shape
    assert np.array_equal(a.points, c.points)


def test_a_sector_is_turned_exactly_as_the_affine_map_says():
    """``_rotate`` (OCC's axis-and-angle placement) moves a solid as the 3 x 4
    matrix of ``_affine`` maps points: every vertex of a box turned about an
    oblique axis through an off-origin centre lands where the matrix sends it
    (OCC keeps vertices exact under a rotation: 1e-9 mm is rounding)."""
    from scipy.spatial.transform import Rotation

    from fe_impact.meshing.session import gmsh_session
    from fe_impact.meshing.solids import _affine, _apply, _rotate

    axis = np.array([1.0, -2.0, 0.5]) / np.sqrt(5.25)
    rotation = Rotation.from_rotvec(0.3 * axis).as_matrix()
    matrix = _affine(rotation, np.array([3.0, 40.0, -7.0]))
    with gmsh_session("rotate") as model:
        box = model.occ.addBox(1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
        model.occ.synchronize()
        before = np.array([model.getValue(0, t, []) for _, t in
                           model.getBoundary([(3, box)], recursive=True)])
        _rotate(model.occ, box, matrix)
        model.occ.synchronize()
        after = np.array([model.getValue(0, t, []) for _, t in
                          model.getBoundary([(3, box)], recursive=True)])
        _rotate(model.occ, box, _affine(np.eye(3), np.zeros(3)))   # the identity: no move
        model.occ.synchronize()
        again = np.array([model.getValue(0, t, []) for _, t in
                          model.getBoundary([(3, box)], recursive=True)])
    np.testing.assert_allclose(after, np.array([_apply(matrix, x) for x in before]),
                               rtol=0.0, atol=1e-9)
    np.testing.assert_array_equal(again, after)


def test_root_lands_are_one_piece_each(gearset):
    # A root land was two strips of 0.17 mm between the fillets (each tooth's half),
    # whose flat tetrahedra turned over when mapped back from the stretched space.
    # Joined, the section keeps every point and stays closed, in the same order.
    from fe_impact.meshing.pairgeometry import _joined_roots, _pinion_section

    pair = GearPair.from_gearset(gearset, 2)
    joined = _pinion_section(pair, 0.0, 0.0, 0.02, n_teeth=2, neighbours=1)
    names = [name for name, _ in joined]
    assert not [n for n in names if n.startswith(("fillet_", "root_left", "root_right"))]
    # four teeth: three lands between them, a half land and fillet at each cut
    assert sum(n.startswith("root_land") for n in names) == 3
    assert sum(n.startswith("root_end") for n in names) == 2
    for (_, a), (_, b) in zip(joined, joined[1:] + joined[:1], strict=True):
        assert np.allclose(a[-1], b[0], rtol=0, atol=1e-12)
    pieces = [("fillet_right", np.zeros((3, 2))), ("root_right", np.ones((2, 2))),
              ("root_left_1", 2 * np.ones((2, 2))), ("fillet_left_1", 3 * np.ones((3, 2))),
              ("flank_left_1", 4 * np.ones((2, 2)))]
    out = _joined_roots(pieces)
    assert [n for n, _ in out] == ["root_land", "flank_left_1"]
    assert len(out[0][1]) == 3 + 1 + 1 + 2       # the shared end points once


def test_a_flat_cap_on_the_face_gear_tip_land_is_flipped_not_remeshed(gearset, tmp_path,
                                                                        caplog):
    # Stage 1 at -5.4 deg of roll (the seventh of the nine coarse positions, made for
    # 2177 N): the mesher lays a thin element on the face gear's tip land, curved in
    # the stretched space; mapped back the land is flat again and the element turns
    # over. (The case was the eighth position, -9.2 deg, until the face gear's flank
    # was continued smoothly beyond the face's ends, 178ea36: before the flip that
    # mesh was made again at a stretch factor of 5, 35k DOFs instead of 32k; of the
    # nine stage-1 meshes at 178ea36 those at -1.7 and -5.4 deg have the cap.) If a
    # change of the geometry or the mesher no longer makes that element, pick
    # another case from the nine positions' meshes.
    import logging

    from fe_impact.calibration.meshcycle import PAIR_GAP, path_positions

    roll = min(path_positions(gearset, 1), key=lambda r: abs(r + 5.4))
    with caplog.at_level(logging.INFO, logger="fe_impact.meshing"):
        pair = build_pair(gearset, 1, roll, "coarse", 2, PAIR_GAP, 0.1, tmp_path,
                          design_force=2177.0)
    assert "flat tetrahedra capping a boundary surface removed" in caplog.text
    assert "meshing again" not in caplog.text
    assert pair.stats.min_sicn > MIN_SICN
    assert pair.stats.element_sizes["factor"] == 8.0
    mesh = load_mesh(pair.mesh_path, "mm")
    assert {"face_flank", "pinion_flank", "face_hub", "pinion_hub"} <= set(mesh.surfaces)
