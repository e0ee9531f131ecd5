"""Friction condensed on the contact patch's tangent coordinates only.

A zone with friction is condensed on its nodes' normal coordinates and on the
tangent ones of a patch: the nodes the solver predicts the contact to reach
(:func:`fe_impact.contact.linearised.predicted_patch`,
:func:`~fe_impact.contact.linearised.flight_patch`), grown (a new factorisation)
when a row with a force reaches a node left out
(:data:`fe_impact.contact.condensed.FULL_TANGENTIAL_COORDINATES`). A row with no
force carries no tangential force, so the solution is the one condensed on all
three coordinates of every node: these tests condense the small zones of the
friction studies on all three, on the predicted patch, and on a patch grown from
nothing, and compare.
"""

from __future__ import annotations

import numpy as np
import pytest

import fe_impact.contact.condensed as condensed
import fe_impact.contact.linearised as linearised
import fe_impact.solvers.dynamic as dynamic
import fe_impact.solvers.static as static


def _whole_zone(monkeypatch):
    monkeypatch.setattr(condensed, "FULL_TANGENTIAL_COORDINATES", 10 ** 9)


def _no_prediction(monkeypatch):
    def none(*args, **kwargs):
        return np.zeros(0, dtype=np.int64)

    monkeypatch.setattr(dynamic, "predicted_patch", none)
    monkeypatch.setattr(dynamic, "flight_patch", none)
    monkeypatch.setattr(static, "predicted_patch", none)


def _counted_growths(monkeypatch, cls, name):
    grown = []
    grow = getattr(cls, name)

    def counted(self, *args):
        out = grow(self, *args)
        if out is not False:
            grown.append(1)
        return out

    monkeypatch.setattr(cls, name, counted)
    return grown


def test_newmark_oblique_impact_on_the_patch_equals_the_whole_zone(tmp_path, monkeypatch):
    # The coarse Newmark oblique impact at 62 deg (gross slip, the study of
    # validation/friction_oblique.py). Outside the rows in contact only the normal
    # rows differ (the normal part of their nodes' motion, as without friction),
    # and those rows carry no force; 1e-8 relative: round-off over the step's
    # solves (measured on the coarse tooth impact 3.5e-12), far below the
    # penalty's own regularisation (1e-3), and a row missed at the patch's edge
    # would move the rebound by its share of the force (1e-3 or more).
    from validation import friction_oblique

    def run(name):
        return friction_oblique.run(quick=True, out=tmp_path / name, integrator="newmark",
                                    angles=(62.0,))["angles"][0]

    predicted = run("predicted")
    with monkeypatch.context() as m:
        _whole_zone(m)
        whole = run("whole")
    _no_prediction(monkeypatch)
    grown = _counted_growths(monkeypatch, condensed.CondensedContact, "_grow_tangential")
    patch = run("grown")
    assert grown, "the patch's tangent coordinates never grew"
    for key in ("tangential_restitution", "tan_rebound", "friction_dissipation_J"):
        assert predicted[key] == pytest.approx(whole[key], rel=1e-8), key
        assert patch[key] == pytest.approx(whole[key], rel=1e-8), key


def test_static_cattaneo_on_the_patch_equals_the_whole_zone(tmp_path, monkeypatch):
    # The coarse Cattaneo-Mindlin loading (validation/friction_cattaneo.py, six
    # tangential steps). The projection iteration stops at the analysis tolerance
    # (1e-6 of the contact displacement), and a growth restarts it from another
    # path: 1e-5 relative on the forces and the microslip.
    from validation import friction_cattaneo as fc

    predicted = fc.run_level(tmp_path, "predicted", 0.2e-3, steps=6)
    with monkeypatch.context() as m:
        _whole_zone(m)
        whole = fc.run_level(tmp_path, "whole", 0.2e-3, steps=6)
    _no_prediction(monkeypatch)
    grown = _counted_growths(monkeypatch, static.StaticSolver, "_grow_tangential")
    patch = fc.run_level(tmp_path, "patch", 0.2e-3, steps=6)
    assert grown, "the patch's tangent coordinates never grew"
    assert predicted["n_contact_dofs"] < whole["n_contact_dofs"]
    assert patch["n_contact_dofs"] < whole["n_contact_dofs"]
    for run in (predicted, patch):
        for a, b in zip(whole["steps"], run["steps"], strict=True):
            for key in ("P", "Q", "microslip_fe_m"):
                assert b[key] == pytest.approx(a[key], rel=1e-5, abs=1e-5 * abs(a["slide_m"])
                                               if key == "microslip_fe_m" else 0.0), key


def test_predicted_patch_takes_the_rows_within_the_share_of_the_reach():
    # One pair, rows with gaps 0..9 um and a search distance of 10 um: the rows
    # within 0.65 of the reach beyond the smallest gap (0..6 um) are predicted, and
    # their nodes are what tangential_nodes gives for those rows.
    import scipy.sparse as sp

    class _Contact:
        pass

    class _State:
        gap = np.arange(10) * 1e-6

    r = 10
    c = _Contact()
    c.states = [_State()]
    c.g_ref = _State.gap.copy()
    c.active_rows = np.ones(r, dtype=bool)
    # row k reaches node k alone (its three components)
    cols = 3 * np.arange(r)
    c.Bt_full = sp.csr_matrix((np.ones(2 * r), (np.arange(2 * r), np.tile(cols, 2))),
                              shape=(2 * r, 3 * r))
    nodes = linearised.predicted_patch(None, c, [10e-6], fraction=0.65)
    assert list(nodes) == [0, 1, 2, 3, 4, 5, 6]
    assert len(linearised.predicted_patch(None, c, [None])) == 0


def test_static_friction_in_the_rows_space_equals_the_condensed_zone(tmp_path, monkeypatch):
    # A zone above FRICTION_ROW_SPACE_COORDINATES is solved in the space of its normal and
    # tangential rows (their compliances kept by row, the gaps and slips corrected
    # by the exact response to the last forces each projection) instead of on its
    # condensed coordinates; forced here on small zones. The coarse Cattaneo-Mindlin
    # loading, and a load-controlled rigid body pressing the sphere with friction
    # (the load root on the rows' problem). The projection iteration stops at the
    # analysis tolerance (1e-6 of the contact displacement) from two paths: 1e-5
    # relative on the Cattaneo loading, as above; the loaded case is converged to
    # 1e-10 of its contact displacement and held to 1e-7 (measured 1e-10; at the
    # default tolerance its rigid coordinate differed by 1.0e-5).
    from dataclasses import replace
    from pathlib import Path

    from fe_impact.fe.case import RigidBodySpec
    from fe_impact.fe.mesh import load_mesh
    from validation import friction_cattaneo as fc
    from validation.impact_cases import sphere_block_case

    meshes = Path(__file__).resolve().parents[1] / "meshes"
    case = sphere_block_case(meshes / "hertz_coarse_p1.msh")
    case = replace(case, contacts=(replace(case.contacts[0], mu_static=0.3, mu_dynamic=0.3),),
                   rigid_bodies=(RigidBodySpec("sphere_equator", "translation", (0.0, 0.0, 1.0),
                                               loads=(-40.0, -90.0)),),
                   analysis=replace(case.analysis, tolerance=1e-10, max_iterations=100))
    mesh = load_mesh(case.mesh_file)

    def both():
        name = f"rows{static.FRICTION_ROW_SPACE_COORDINATES}"
        level = fc.run_level(tmp_path, name, 0.2e-3, steps=3)
        solver = static.StaticSolver(case, mesh, stress=False)
        return level, solver.run(), solver.rows is not None

    coordinates = both()
    monkeypatch.setattr(static, "FRICTION_ROW_SPACE_COORDINATES", 0)
    rows = both()
    assert not coordinates[2] and rows[2]
    for a, b in zip(coordinates[0]["steps"], rows[0]["steps"], strict=True):
        for key in ("P", "Q", "microslip_fe_m"):
            assert b[key] == pytest.approx(a[key], rel=1e-5, abs=1e-5 * abs(a["slide_m"])
                                           if key == "microslip_fe_m" else 0.0), key
    for a, b in zip(coordinates[1].steps, rows[1].steps, strict=True):
        assert np.linalg.norm(a.friction_force[0]) > 1e-3 * a.contact_force[0]
        assert b.rigid_values[0] == pytest.approx(a.rigid_values[0], rel=1e-7)
        assert b.contact_force[0] == pytest.approx(a.contact_force[0], rel=1e-7)
        assert b.friction_force[0] == pytest.approx(a.friction_force[0], rel=1e-7,
                                                    abs=1e-7 * a.contact_force[0])


def test_static_friction_refuses_a_rows_space_too_large_to_keep(monkeypatch):
    # The rows' space keeps a dense compliance of three rows per gap row: above
    # FRICTION_ROW_SPACE_ROWS the solver refuses in one ContactError naming the
    # count and the limit (the calibration then solves the position frictionless).
    from dataclasses import replace
    from pathlib import Path

    from fe_impact.errors import ContactError
    from fe_impact.fe.case import RigidBodySpec
    from fe_impact.fe.mesh import load_mesh
    from validation.impact_cases import sphere_block_case

    meshes = Path(__file__).resolve().parents[1] / "meshes"
    case = sphere_block_case(meshes / "hertz_coarse_p1.msh")
    case = replace(case, contacts=(replace(case.contacts[0], mu_static=0.3, mu_dynamic=0.3),),
                   rigid_bodies=(RigidBodySpec("sphere_equator", "translation", (0.0, 0.0, 1.0),
                                               values=(-4e-6,)),))
    monkeypatch.setattr(static, "FRICTION_ROW_SPACE_COORDINATES", 0)
    monkeypatch.setattr(static, "FRICTION_ROW_SPACE_ROWS", 3)
    with pytest.raises(ContactError, match=r"gap rows, \d+ with their tangential rows, above "
                                           r"the 3 whose compliances friction can keep"):
        static.StaticSolver(case, load_mesh(case.mesh_file), stress=False)
