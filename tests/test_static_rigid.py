"""Static cases with rigid hubs: prescribed motion or load, and the reaction along it.

The sphere-on-block specimen's flat equator face is tied to a rigid body
translating along z. Independent truths: the sphere's equilibrium (the
body's reaction balances the contact force on a flat master, whose normals
are exactly z) and the inverse problem (loading the body with the reactions
of prescribed motions gives those motions back).
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from fe_impact.errors import CaseError, ContactError
from fe_impact.fe.case import RigidBodySpec, load_case
from fe_impact.fe.casefile import write_case
from fe_impact.fe.mesh import load_mesh
from fe_impact.solvers.static import StaticSolver
from validation.hertz_static import DISPLACEMENTS

Z = (0.0, 0.0, 1.0)


@pytest.fixture(scope="module")
def specimen(coarse_hertz_case):
    case = load_case(coarse_hertz_case)
    return replace(case, displacements=()), load_mesh(case.mesh_file, case.unit)


def _body(**motion) -> RigidBodySpec:
    return RigidBodySpec("sphere_equator", "translation", Z, **motion)


@pytest.fixture(scope="module")
def by_motion(specimen):
    case, mesh = specimen
    moved = replace(case, rigid_bodies=(_body(values=tuple(DISPLACEMENTS)),))
    return StaticSolver(moved, mesh).run()


def test_reaction_balances_contact_force(by_motion):
    # The sphere is held only by the body (the symmetry planes carry no z
    # force) and pushed by the contact. contact_force sums the forces along
    # the deformed master normal, which tilts by up to delta/a ~ 0.05 rad at
    # the contact edge: the z-resultant is smaller by 1 - cos(tilt), at most
    # 1.3e-3 at the edge and ~1e-4 on average (as for [[displacements]] in
    # tests/test_static_contact.py).
    for step, d in zip(by_motion.steps, DISPLACEMENTS, strict=True):
        assert step.rigid_values == [d]
        f = step.contact_force[0]
        assert f > 0
        assert abs(step.rigid_reactions[0] + f) <= 1e-3 * f


def test_load_control_recovers_the_motion(specimen, by_motion):
    # Loading the body with the reactions of the prescribed motions must give
    # the motions back. The load is met to 1e-9 (the reaction to 1e-8). The
    # two runs grow different contact zones, whose normal frames are fixed at
    # condensation: a frame tilted by t from the contact normal loses
    # 1 - cos t of the force, t up to delta/a ~ 0.05 at the patch edge, so
    # motion and force agree to ~1e-3 at worst (measured 2e-5).
    case, mesh = specimen
    loads = tuple(s.rigid_reactions[0] for s in by_motion.steps)
    loaded = StaticSolver(replace(case, rigid_bodies=(_body(loads=loads),)), mesh).run()
    for got, want in zip(loaded.steps, by_motion.steps, strict=True):
        assert got.rigid_values[0] == pytest.approx(want.rigid_values[0], rel=1e-3)
        assert got.contact_force[0] == pytest.approx(want.contact_force[0], rel=1e-3)
        assert got.rigid_reactions[0] == pytest.approx(want.rigid_reactions[0], rel=1e-8)


def test_the_estimated_error_holds_the_tolerance(specimen, by_motion):
    # The projection iteration stops when its contraction bounds the error
    # left (TRUSTED_RATE), not when the last change does. Independent truth:
    # the same load steps iterated to 1e-12. The tolerance is on the zone's
    # displacement relative to the contact displacement, so the body's
    # motion (the contact displacement plus the sphere's bulk compliance)
    # must agree to 1e-6 of it; a factor 2 covers the two quantities not
    # being the same norm.
    case, mesh = specimen
    loads = tuple(s.rigid_reactions[0] for s in by_motion.steps)
    runs = {}
    for tol in (1e-6, 1e-12):
        analysis = replace(case.analysis, tolerance=tol, max_iterations=60)
        runs[tol] = StaticSolver(replace(case, analysis=analysis,
                                         rigid_bodies=(_body(loads=loads),)), mesh).run()
    for got, full in zip(runs[1e-6].steps, runs[1e-12].steps, strict=True):
        assert got.iterations < full.iterations
        assert abs(got.rigid_values[0] - full.rigid_values[0]) <= \
            2e-6 * abs(full.rigid_values[0])


def test_case_file_round_trip(tmp_path, specimen):
    case, _ = specimen
    for body in (_body(values=(1e-6, 2e-6)), _body(loads=(-10.0, -20.0))):
        path = write_case(replace(case, rigid_bodies=(body,), path=tmp_path / "c.toml"),
                          tmp_path / "c.toml")
        assert load_case(path).rigid_bodies == (body,)


def test_a_load_pulling_away_is_refused(specimen):
    case, mesh = specimen
    with pytest.raises(ContactError, match="does not move toward the contact"):
        StaticSolver(replace(case, rigid_bodies=(_body(loads=(10.0,)),)), mesh).run()


V = f"values = [{1e-6!r}]"    # as write_case writes it
BAD = [
    (V, V + "\nloads = [1.0]", r"exactly one of values .* and loads"),
    (V, "", r"exactly one of values .* and loads .*got neither"),
    (V, "values = [1e-6, 2e-6]", r"different numbers of values"),
    ('motion = "translation"', 'motion = "rotation"', None),
    (V, V + "\ninertia = 1.0", r"inertia need \[analysis\] type = \"dynamic\""),
]


@pytest.mark.parametrize("old,new,pattern", BAD)
def test_bad_static_rigid_bodies(tmp_path, specimen, old, new, pattern):
    case, _ = specimen
    text = (write_case(replace(case, rigid_bodies=(_body(values=(1e-6,)),),
                               displacements=(), path=tmp_path / "ok.toml"),
                       tmp_path / "ok.toml").read_text())
    text = text.replace("[analysis]", '[[displacements]]\nsurface = "block_bottom"\n'
                        'component = "x"\nvalues = [0.0]\n\n[analysis]')
    assert old in text
    bad = tmp_path / "bad.toml"
    if pattern is None:   # a rotation of 1e-6 rad is fine; 0.2 rad is not small
        bad.write_text(text.replace(old, new).replace(V, "values = [0.2]"))
        pattern = r"values = \[0.2\]: must be in \[-0.1, 0.1\] rad"
    else:
        bad.write_text(text.replace(old, new))
    with pytest.raises(CaseError, match=pattern):
        load_case(bad)


def test_two_load_controlled_bodies_are_refused(tmp_path, specimen):
    case, _ = specimen
    two = replace(case, path=tmp_path / "two.toml", rigid_bodies=(
        _body(loads=(1.0,)), replace(_body(loads=(1.0,)), surface="block_bottom")))
    with pytest.raises(CaseError, match="at most one body can be load-controlled"):
        write_case(two, tmp_path / "two.toml")


def test_solve_command_reports_the_body(tmp_path, specimen):
    # The CLI on a load-controlled case: summary.json names the body and gives
    # its coordinate and the load it carries (the case's load, to 1e-8).
    import json

    from fe_impact.cli.main import main

    case, _ = specimen
    path = write_case(replace(case, rigid_bodies=(_body(loads=(-20.0,)),),
                              path=tmp_path / "c.toml"), tmp_path / "c.toml")
    assert main(["solve", str(path), "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    (body,) = summary["steps"][0]["rigid_bodies"]
    assert body["surface"] == "sphere_equator" and body["motion"] == "translation"
    assert body["reaction"] == pytest.approx(-20.0, rel=1e-8)
    assert body["value"] < 0


def test_tooth_pair_converges_at_three_times_the_largest_impact(tmp_path):
    # Stage 1, coarse, pitch point: the pinion pressed on the face gear by
    # torque up to 2.5 kN, three times the largest impact force of the default
    # calibration (820 N). The projections converge in a few iterations; the
    # torque is carried by the contact alone, so torque / lever = contact force
    # to the tilt of the normal over the patch (5e-3); and the approach holds
    # the teeth's bending besides the contact, so it exceeds Hertz's.
    from fe_impact.gears import default_gearset
    from fe_impact.gears.tca import contact_ellipse
    from fe_impact.meshing.paircase import static_pair_case
    from fe_impact.meshing.toothpair import build_pair

    gs = default_gearset()
    forces = (200.0, 2500.0)
    spec = dict(stage=1, roll_angle_deg=0.0, level="coarse", gap=1e-6, impact_speed=0.1,
                design_force=max(forces))
    pm = build_pair(gs, out_dir=tmp_path, **spec)
    case = static_pair_case(gs, pm, forces)
    result = StaticSolver(case, load_mesh(pm.mesh_path, "mm")).run()
    lever = pm.analysis.masses.pinion_lever
    for step, f in zip(result.steps, forces, strict=True):
        assert step.iterations <= 10
        assert step.contact_force[0] == pytest.approx(f, rel=5e-3)
        approach = -step.rigid_values[0] * lever - pm.analysis.gap
        hertz = contact_ellipse(pm.analysis.contact.relative, f, pm.analysis.effective_modulus)
        assert approach > hertz.approach


def test_a_stalled_iteration_says_what_helps():
    # A change stalling at 2e-8 m on a 1e-4 m face with a 2e-5 m contact
    # displacement: the active set flips at the patch edge; a tolerance of
    # about 2 x 2e-8 / 2e-5 = 2e-3 ends it (the stall the coarse stage-1 pair
    # showed at 3 kN before the normal-coordinate contact).
    from fe_impact.solvers.static import _diagnosis

    msg = _diagnosis([1e-6, 1e-7, 2e-8, 1.9e-8, 2e-8, 1.8e-8], 2e-5, 1e-4)
    assert "loosen [analysis] tolerance to about 2e-03" in msg
    assert "max_iterations" in _diagnosis([1e-5, 5e-6, 2e-6, 1e-6], 2e-5, 1e-4)


def test_two_alternating_states_are_recognised():
    # The iteration of a tip edge's corner contact at 850 N: the state two
    # projections back returns (its displacement within the bound, the same
    # rows in contact) while the last one lies 1.4e-8 m away, with one row in
    # contact in one state only. Recognised as alternating, whether the rows in
    # contact differ between the two states or not; not while it still converges,
    # nor when the row sets of the returning state differ.
    import numpy as np
    import scipy.sparse as sp

    from fe_impact.solvers.static import _alternates

    zone = sp.identity(3, format="csr")
    za, zb = np.array([1e-6, 2e-6, 0.0]), np.array([1e-6, 2e-6 + 1.4e-8, 0.0])
    la, lb = np.array([1.0, 2.0, 0.0]), np.array([1.0, 2.0, 0.5])
    bound = 1e-12
    cycle = [(za, la, 0.0), (zb, lb, 0.0)]
    assert _alternates(cycle, za + 1e-13, la, zone, bound)           # rows alternate
    assert _alternates([(za, la, 0.0), (zb, la, 0.0)], za, la, zone, bound)   # same rows
    assert not _alternates(cycle, za + 1e-11, la, zone, bound)       # not back yet
    assert not _alternates(cycle, za, lb, zone, bound)               # other rows in contact
    assert not _alternates(cycle[1:], za, la, zone, bound)           # one state only
    assert not _alternates([(za, la, 0.0), (za, la, 0.0)], za, la, zone, bound)  # converged


def test_row_space_solves_the_same_problem(specimen, by_motion, monkeypatch):
    # A large zone is solved in the space of its gap rows (kept compliances of
    # the projection each row was first met at, corrected by the exact
    # response to the last forces each projection); the coordinate-space
    # solve of the same load steps to 1e-12 is the independent truth.
    # - To 1e-12 as well: the zones grow along different iteration paths and
    #   the normal frames fixed at each growth differ by about that much, so
    #   1e-8 is four orders above what the iteration leaves.
    # - To the default 1e-6: the error the iteration leaves must hold that
    #   tolerance as in the coordinate space (the bound of
    #   test_the_estimated_error_holds_the_tolerance); a correction with the
    #   last projection's Jacobian instead of the current one converges
    #   slower and stopped 1.35e-5 early.
    import fe_impact.solvers.static as static

    case, mesh = specimen
    loads = tuple(s.rigid_reactions[0] for s in by_motion.steps)
    runs = {}
    for name, limit, tol in (("coordinates", 10**9, 1e-12), ("rows", 0, 1e-12),
                             ("rows, 1e-6", 0, 1e-6)):
        monkeypatch.setattr(static, "ROW_SPACE_COORDINATES", limit)
        analysis = replace(case.analysis, tolerance=tol, max_iterations=60)
        solver = StaticSolver(replace(case, analysis=analysis,
                                      rigid_bodies=(_body(loads=loads),)), mesh)
        runs[name] = solver.run()
        assert (solver.rows is not None) == (limit == 0)
    for got, rough, want in zip(runs["rows"].steps, runs["rows, 1e-6"].steps,
                                runs["coordinates"].steps, strict=True):
        assert got.rigid_values[0] == pytest.approx(want.rigid_values[0], rel=1e-8)
        assert got.contact_force[0] == pytest.approx(want.contact_force[0], rel=1e-8)
        assert got.contact_area[0] == pytest.approx(want.contact_area[0], rel=1e-8)
        assert abs(rough.rigid_values[0] - want.rigid_values[0]) <= \
            2e-6 * abs(want.rigid_values[0])


def test_row_space_compliance_of_the_bordered_stiffness(specimen, by_motion, monkeypatch):
    # The rows' compliances B K^-1 B^T come from the Schur complement of
    # [[K, B^T], [B, 0]] on its row block; the independent truth is the same
    # product by solves. Both are direct: they agree to round-off (5e-15 on a
    # 206k-DOF corner), so 1e-10 leaves room for the conditioning of K only.
    import numpy as np

    import fe_impact.solvers.static as static

    case, mesh = specimen
    monkeypatch.setattr(static, "ROW_SPACE_COORDINATES", 0)
    moved = replace(case, rigid_bodies=(_body(values=(by_motion.steps[-1].rigid_values[0],)),))
    solver = StaticSolver(moved, mesh)
    space = solver.rows
    assert space is not None and len(space.index) > 3
    B = space.B0
    exact = B @ solver.solver.solve(B.T.toarray())
    assert np.abs(space.C - exact).max() <= 1e-10 * np.abs(exact).max()
