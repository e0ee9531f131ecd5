"""The rolling mesh: kinematics, energy, the contact law and bad input (rigid rotors, fast).

The elastic sectors' version of these checks is ``validation/rolling.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fe_impact.errors import CaseError
from fe_impact.gears import default_gearset
from fe_impact.rolling.model import (
    ContactGeometry,
    Roller,
    RollSettings,
    rigid_body,
    solve_contact,
)
from fe_impact.rolling.run import integrate
from fe_impact.rolling.sectors import tooth_range


@pytest.fixture(scope="module")
def gearset():
    return default_gearset()


def _roller(gearset, settings, stiffen=1.0, n=31, teeth=5):
    # planar tip-corner gaps: quicker to tabulate than the solid ones, and none of
    # these checks depends on which (the command uses the solid ones)
    geo = ContactGeometry.build(gearset, 1, stiffen=stiffen, n=n, corners="planar")
    pair = geo.pair
    p = rigid_body("pinion", gearset.pinion.inertia, *pair.pinion_axis)
    f = rigid_body("face_gear", gearset.stages[0].inertia, *pair.face_axis)
    return Roller(geo, p, f, tooth_range(teeth), 0.0, pair.nominal_face_angle(0.0), settings)


def test_solve_contact_single_pair_is_hertz():
    # one pair with no compliance of its own (D -> 0): the force is Hertz's
    # P = K (-g)^1.5 of the free overlap, the closed form of the law
    kh, g = 2.0e10, -3.0e-6
    lam = solve_contact(np.array([g]), np.array([[1e-18]]), np.array([kh]))
    assert lam[0] == pytest.approx(kh * (-g) ** 1.5, rel=1e-6)


def test_solve_contact_complementarity():
    # two coupled pairs, one pushed open by the other: each gap h = g + D lam +
    # (lam/K)^(2/3) is >= 0, zero where lam > 0 (to round-off of the metres)
    D = np.array([[2e-9, -1.5e-9], [-1.5e-9, 2e-9]])
    g = np.array([-4e-6, 1e-6])
    kh = np.array([1e10, 1e10])
    lam = solve_contact(g, D, kh)
    h = g + D @ lam + (lam / kh) ** (2 / 3)
    assert np.all(lam >= 0.0)
    assert np.all(h >= -1e-15)
    assert np.all(np.abs(lam * h) <= 1e-15 * lam.max())


def test_kinematics_accelerating_unloaded_te_zero(gearset):
    # (a) no load, stiffened material (E x 1e6), the pinion accelerated to
    # 1000 r/min over 1.5 cycles: the face gear is pushed only by the flanks
    # (up to ~1.6 kN), through one- and two-pair zones; with unmodified
    # flanks (conjugate) the TE must stay zero while they push; the issue's
    # tolerance 0.01 um (the Hertz approach at 1e6 x E is ~1e-3 um). Once the
    # push ends the face gear flies free across the backlash: not checked.
    s = RollSettings(speed=1000 * 2 * math.pi / 60, cycles=2.0, steps_per_cycle=200,
                     speed_ramp_cycles=1.5)
    r = _roller(gearset, s, stiffen=1e6)
    res = integrate(r)
    pushed = res.pair_force_n[:, :, 0].sum(axis=1) > 1.0     # the drive flanks push
    assert res.pair_force_n.max() > 1000.0
    assert pushed.sum() >= 250                       # 1.25 cycles of 200 steps
    assert (res.pair_force_n[pushed, :, 0] > 0).sum(axis=1).max() == 2   # a two-pair zone
    assert np.abs(res.te_m[pushed]).max() < 0.01e-6


def test_contact_points_coincide_in_both_frames(gearset):
    # the contact point found in the pinion's turning frame and in the face
    # gear's, each turned by its own rotor angle, must be the same place of
    # the mesh frame, on the drive and the coast flanks (the meshed teeth have
    # no backlash, the gaps carry it). Tolerance 0.2 um: the TCA's and the
    # table's linear interpolation over 121 positions (0.7 mm apart; the
    # point's path is curved over the face), measured 0.09 um at most
    s = RollSettings(speed=100.0, cycles=1.0, steps_per_cycle=50)
    r = _roller(gearset, s, n=121)
    checked = set()
    for step in range(0, 50, 7):
        th = r.pinion_motion(step * r.dt)[0]
        for fl, k, pos in r.positions(th):
            if not r.geo.mesh.s_start < pos < r.geo.mesh.s_end:
                continue        # a tip edge: the table holds the path's end point
            xp, xf, *_ = r._ref_points(fl, k, pos, th)
            gap = np.linalg.norm(r.world(xp, th, "pinion")
                                 - r.world(xf, r.ratio * th, "face_gear"))
            assert gap < 0.2e-6, (fl, k, pos)
            checked.add(fl)
    assert checked == {0, 1}


def test_energy_balance_loaded(gearset):
    # (c) no damping: kinetic + Hertz energy - drive and load work stays at its
    # start, within the 0.1% of the work done
    s = RollSettings(speed=1000 * 2 * math.pi / 60, torque=50.0, cycles=2.0,
                     steps_per_cycle=200, ramp_cycles=1.0)
    res = integrate(_roller(gearset, s))
    assert res.energy["drive_work"][-1] > 1.0
    assert res.energy_error() < 1e-3


def test_cycles_beyond_sector(gearset):
    with pytest.raises(CaseError, match="cycles = 9"):
        _roller(gearset, RollSettings(speed=100.0, cycles=9.0))


@pytest.mark.parametrize("teeth", [4, 5, 6, 7])
def test_window_holds_the_geometric_count_of_cycles(gearset, teeth):
    # independent truth: a pair can touch over a reach of (hi - lo) along the line of
    # action (the path of contact and the tip edges' approach and recess); N teeth span
    # N base pitches of it, so the pinion turns through N - reach / p_b base pitches while
    # every pair in reach is in the sectors, less the window's margins (0.01 pitch each
    # end). Tolerance: the window is searched on a grid of 16/3200 = 0.005 pitch, one step
    # lost at each end at most, so 0.01 (+ round-off).
    roller = _roller(gearset, RollSettings(speed=100.0, cycles=0.1), teeth=teeth)
    lo, hi = roller.geo.reach()
    count = teeth - (hi - lo) / roller.p_b - 0.02
    assert roller.capacity == pytest.approx(count, abs=0.0101)
    # the window is where the sectors mesh: at its middle a drive pair is in reach
    middle = 0.5 * sum(roller.held_window())
    assert any(fl == 0 for fl, *_ in roller.positions(middle))


def test_cycles_beyond_sector_says_what_fits(gearset):
    # the refusal's count is the geometric one of the test above (6 teeth: 6 - 2.23
    # - 0.02 = 3.75 on the planar corners), and it names the option that gives more
    # (none at the most teeth)
    roller = _roller(gearset, RollSettings(speed=100.0, cycles=0.1), teeth=6)
    with pytest.raises(CaseError, match="cycles = 5: the sectors \\(6 teeth each\\) hold "
                       f"{roller.capacity:.2f} mesh cycles.*more --teeth \\(up to 7\\)"):
        _roller(gearset, RollSettings(speed=100.0, cycles=5.0), teeth=6)
    with pytest.raises(CaseError, match="hold 4.7.* fewer cycles$"):
        _roller(gearset, RollSettings(speed=100.0, cycles=5.0), teeth=7)
    with pytest.raises(CaseError, match="start_cycles -4 is before the window"):
        _roller(gearset, RollSettings(speed=100.0, cycles=1.0, start_cycles=-4.0), teeth=7)


@pytest.mark.parametrize("teeth, first, last", [(4, -1, 2), (5, -1, 3), (6, -2, 3),
                                                (7, -2, 4)])
def test_tooth_range_counts_the_teeth(teeth, first, last):
    assert list(tooth_range(teeth)) == list(range(first, last + 1))
    assert len(tooth_range(teeth)) == teeth


@pytest.mark.parametrize("teeth", [3, 8, 0, True, 5.5])
def test_bad_teeth_refused(teeth):
    from fe_impact.rolling.sectors import check_teeth

    with pytest.raises(CaseError, match=f"--teeth {teeth}: .* 4 to 7 .*4..7"):
        check_teeth(teeth)


@pytest.mark.parametrize("argv, option", [
    (["--speed", "1000", "--teeth", "3"], "--teeth 3"),
    (["--speed", "1000", "--teeth", "40"], "--teeth 40"),
    (["--speed", "1000", "--teeth", "7", "--cycles", "5", "--rigid"], "--cycles 5"),
    (["--stage", "4", "--speed", "1000"], "--stage 4"),
    (["--speed", "0"], "--speed 0"),
    (["--speed", "1000", "--torque", "5000"], "--torque 5000"),
    (["--speed", "1000", "--cycles", "5", "--rigid"], "--cycles 5"),
    (["--speed", "1000", "--steps-per-cycle", "50"], "--speed 1000"),
    (["--speed", "1000", "--level", "nope"], "--level nope"),
])
def test_cli_bad_input_one_line(tmp_path, capsys, argv, option):
    from fe_impact.cli.main import main

    out = tmp_path / "out"
    assert main(["roll", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and option in err[0]
    assert not out.exists()


def test_cli_rigid_writes_outputs(tmp_path):
    from fe_impact.cli.main import main

    out = tmp_path / "out"
    assert main(["roll", "--speed", "1000", "--torque", "50", "--cycles", "0.5", "--rigid",
                 "--out", str(out)]) == 0
    for name in ("roll.json", "te.csv", "pairs.csv", "events.csv", "te.png", "forces.png"):
        assert (out / name).exists(), name
    te = np.loadtxt(out / "te.csv", delimiter=",", skiprows=1)
    assert te.shape[0] == round(0.5 * 240) + 1


def test_solve_contact_pair_joining_with_vanishing_force():
    # a pair whose free overlap is a hair (1e-15 m) beside a loaded one pushed
    # through the shared rotor: the forces must still meet complementarity to
    # round-off of the metres (1e-15 m; the gaps are micrometres)
    D = np.array([[3e-9, 2.9e-9], [2.9e-9, 3e-9]])
    g = np.array([-5e-6, -1e-15])
    kh = np.array([2e10, 2e10])
    lam = solve_contact(g, D, kh)
    h = g + D @ lam + (lam / kh) ** (2 / 3)
    assert np.all(lam >= 0.0)
    assert np.all(h >= -1e-16)
    assert np.all(np.abs(h[lam > 0]) <= 1e-15)


# -- the local law read at depth and the probe inside a sector ------------------------------------
@pytest.fixture(scope="module")
def layer_setup(gearset):
    from fe_impact.rolling.model import LayerLaw

    geo = ContactGeometry.build(gearset, 1, n=5, corners="planar")
    i = 2                                       # the path's middle
    a1, b1, p01 = geo.major_unit[i], geo.minor_unit[i], geo.pressure_unit[i]
    tables = LayerLaw.tabulate((b1 / a1, b1 / a1), geo.poisson_ratio)   # one shape: ~3 s

    def law(depth):
        return LayerLaw([2.0 * p01 * b1 / geo.youngs_modulus], [depth / a1], [b1 / a1], tables)

    return geo, i, law


def test_layer_law_deep_is_hertz(layer_setup):
    # read infinitely deep, the layer is the whole half-space: the two bodies'
    # compression is the Hertz approach delta of the ellipse (its closed form in
    # elliptic integrals, P = K_H delta^1.5, an independent route from the
    # Boussinesq quadrature tabulated). At 10 m the displacement left below,
    # P (1 + nu)(3 - 2 nu) / (2 pi E z) per body, is < 1e-4 of delta at 1 kN;
    # the table's interpolation ~1e-4: tolerance 1e-3.
    from fe_impact.rolling.model import HertzLaw

    geo, i, law = layer_setup
    lam = np.array([1.0, 100.0, 1000.0])
    deep = law(10.0)
    hertz = HertzLaw(np.full(3, geo.hertz_k[i]))
    np.testing.assert_allclose(deep.take([0, 0, 0]).approach(lam), hertz.approach(lam),
                               rtol=1e-3)


def test_layer_law_matches_quadrature_and_is_monotone(layer_setup, gearset):
    # the tabulated law against the closed-form quadrature of the layer 0..d
    # (Johnson 1985 s. 3.2, hertz.ellipse_layer_compression) at the depths the
    # model uses (1.8 and 3.6 mm) and 100 N / 1 kN: the table's monotone cubic
    # in ln(d/a) over 36 points, tolerance 1e-3. It must rise with the force,
    # and its energy int lam d(delta) must match a trapezoid sum of it (1e-4).
    from fe_impact.physics import hertz

    geo, i, law = layer_setup
    mat = gearset.material
    for depth in (1.8e-3, 3.6e-3):
        lw = law(depth)
        for force in (100.0, 1000.0):
            t = force ** (1 / 3)
            exact = 2.0 * hertz.ellipse_layer_compression(
                depth, geo.major_unit[i] * t, geo.minor_unit[i] * t,
                geo.pressure_unit[i] * t, mat.youngs_modulus, mat.poisson_ratio)
            assert lw.approach(np.array([force]))[0] == pytest.approx(exact, rel=1e-3)
        forces = np.geomspace(1e-3, 1e4, 4000)
        many = lw.take(np.zeros(len(forces), int))
        delta = many.approach(forces)
        assert np.all(np.diff(delta) > 0.0)
        assert np.all(many.slope(forces) > 0.0)
        work = np.concatenate([[0.0], np.cumsum(0.5 * (forces[1:] + forces[:-1])
                                                * np.diff(delta))])
        work += forces[0] * delta[0] * 0.4          # below 1e-3 N: Hertz-like, 0.4 P delta
        assert lw.energy(forces[-1:])[0] == pytest.approx(work[-1], rel=1e-4)


def test_solve_contact_layer_law_complementarity(layer_setup):
    # two coupled pairs with the layer law and a slightly unsymmetric D (read at
    # depth, loaded on the surface): gaps >= 0, zero where a pair carries
    geo, i, law = layer_setup
    lw = law(3.6e-3).take([0, 0, 0])
    D = np.array([[2e-9, -1.4e-9, 0.1e-9], [-1.5e-9, 2e-9, 0.0], [0.1e-9, 0.0, 1e-9]])
    g = np.array([-4e-6, 1e-6, -2e-6])
    lam = solve_contact(g, D, lw)
    h = g + D @ lam + lw.approach(lam)
    assert lam[0] > 0.0 and lam[2] > 0.0 and lam[1] == 0.0
    assert np.all(h >= -1e-15)
    assert np.all(np.abs(h[lam > 0]) <= 1e-15)


def _p2_cube():
    """A unit cube in six P2 tetrahedra (edge-midpoint nodes in TET10_EDGES order)."""
    from fe_impact.contact.nearfield_fe import TET10_EDGES

    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    tets = [(0, 1, 3, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 6, 4, 7), (0, 4, 5, 7), (0, 5, 1, 7)]
    points, index, cells = list(corners), {}, []
    for tet in tets:
        row = list(tet)
        for a, b in TET10_EDGES:
            key = tuple(sorted((tet[a], tet[b])))
            if key not in index:
                index[key] = len(points)
                points.append(0.5 * (corners[key[0]] + corners[key[1]]))
            row.append(index[key])
        cells.append(row)
    return np.array(points), np.array(cells)


def test_body_probe_reads_interpolated_field():
    # the probe's P2 shape functions reproduce any quadratic field exactly (the
    # interpolant of a quadratic is itself): a field vanishing on the hub face
    # x = 0 (whose nodes carry no DOF) is read at interior points to round-off;
    # a point outside the sector says so (smallest barycentric coordinate < 0)
    from fe_impact.rolling.model import Body

    points, cells = _p2_cube()
    hub = points[:, 0] == 0.0
    node_dofs = -np.ones((len(points), 3), int)
    node_dofs[~hub] = np.arange(3 * (~hub).sum()).reshape(-1, 3)
    body = Body("cube", None, None, np.zeros(3), np.array([0.0, 0.0, 1.0]), points=points,
                cells=cells, node_dofs=node_dofs)

    def field(x):
        return x[..., 0:1] * np.stack([1 + x[..., 1], 2 * x[..., 2] - x[..., 0],
                                       0.5 + x[..., 0] * 0 + x[..., 1]], axis=-1)

    q = np.zeros(3 * (~hub).sum())
    q[node_dofs[~hub]] = field(points[~hub])
    rng = np.random.default_rng(7)
    for x in rng.uniform(0.02, 0.98, (20, 3)):
        dofs, w, inside = body.probe(x)
        assert inside >= -1e-12
        np.testing.assert_allclose(w @ q[dofs], field(x), atol=1e-13)
    assert body.probe(np.array([1.5, 0.5, 0.5]))[2] < -0.1


def test_faces_on_cut_finds_the_plane_through_the_axis():
    # a known solid: the wedge between the planes through the y axis at -30 and +10 deg
    # (points (z tan(a), y, z)), cut from a box; the face at -30 deg is one planar face,
    # the +10 deg one another, and no face lies in the plane at -20 deg
    import math

    from fe_impact.errors import MeshError
    from fe_impact.meshing.session import gmsh_session
    from fe_impact.rolling.sectors import _faces_on_cut

    with gmsh_session("wedge") as model:
        occ = model.occ
        pts = [occ.addPoint(0, 0, 0), occ.addPoint(50 * math.tan(math.radians(-30)), 0, 50),
               occ.addPoint(50 * math.tan(math.radians(10)), 0, 50)]
        lines = [occ.addLine(pts[i], pts[(i + 1) % 3]) for i in range(3)]
        face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
        volume = occ.extrude([(2, face)], 0, 10, 0)[1][1]
        occ.synchronize()
        left = _faces_on_cut(model, volume, math.radians(-30))
        right = _faces_on_cut(model, volume, math.radians(10))
        assert len(left) == 1 and len(right) == 1 and left != right
        for tag in left:
            x, _, z = model.occ.getCenterOfMass(2, tag)
            assert math.degrees(math.atan2(x, z)) == pytest.approx(-30.0, abs=1e-9)
        with pytest.raises(MeshError, match="no face in its cut plane at -20 deg"):
            _faces_on_cut(model, volume, math.radians(-20))
