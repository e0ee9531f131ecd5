"""Static contact against Hertz on the coarse sphere-on-block specimen."""

from __future__ import annotations

import numpy as np
import pytest

from fe_impact.case import load_case
from fe_impact.static import StaticSolver
from validation import hertz_static


@pytest.fixture(scope="module")
def coarse_run(coarse_hertz_case):
    solver = StaticSolver(load_case(coarse_hertz_case))
    ps = hertz_static.axis_point(solver, "sphere", hertz_static.DEPTH)
    pb = hertz_static.axis_point(solver, "block", -hertz_static.DEPTH)
    result = solver.run()
    rows = [hertz_static.compare(s, solver, ps, pb) for s in result.steps]
    return solver, result, rows


def test_force_matches_hertz_locally(coarse_run):
    # Coarse mesh (h = 0.2 mm, about one element per contact radius at the first
    # step): measured <= 1.9%; the 2% target is for the finest level,
    # so 2.5% here still fails on any real regression of the contact stiffness.
    _, _, rows = coarse_run
    assert max(abs(r["force_error"]) for r in rows) < 0.025


def test_pressure_and_radius_at_full_load(coarse_run):
    # At 25 um the contact radius spans 2.5 coarse elements: measured pressure
    # error 0.9% and radius error 5.3% (area-based, biased low by half an element).
    _, _, rows = coarse_run
    assert abs(rows[-1]["pressure_error"]) < 0.05
    assert -0.08 < rows[-1]["radius_error"] < 0.0


def test_equilibrium_reaction_equals_contact_force(coarse_run):
    # The reaction on the pushed face balances the contact force. contact_force sums
    # the forces along the deformed master normal, which tilts by up to
    # delta/a ~ 0.05 rad at the contact edge: the z-resultant is smaller by
    # 1 - cos(tilt), at most 1.3e-3 at the edge and ~1e-4 on average.
    _, result, _ = coarse_run
    for s in result.steps:
        rel = abs(s.reaction_force[0] + s.contact_force[0]) / s.contact_force[0]
        assert rel < 1e-3


def test_auto_penalty_keeps_penetration_below_one_percent(coarse_run):
    _, _, rows = coarse_run
    assert max(r["penetration_ratio"] for r in rows) < 0.01


def test_force_grows_like_hertz_power(coarse_run):
    # Between 10 and 25 um the far field is a small linear part (~2% of D), so
    # the force-displacement exponent is close to Hertz's 1.5.
    _, result, _ = coarse_run
    d = np.array([-s.value for s in result.steps[1:]])
    f = np.array([s.contact_force[0] for s in result.steps[1:]])
    exponent = np.polyfit(np.log(d), np.log(f), 1)[0]
    assert 1.40 < exponent < 1.55


def test_p1_mesh_runs_and_agrees(coarse_hertz_case_p1, coarse_run):
    # Linear tetrahedra are stiffer (faceted sphere, locking-free but coarse):
    # within 15% of the P2 force at full load on the same coarse sizes.
    result = StaticSolver(load_case(coarse_hertz_case_p1)).run()
    p2 = coarse_run[1].steps[-1].contact_force[0]
    assert abs(result.steps[-1].contact_force[0] / p2 - 1) < 0.15


def test_no_contact_without_load(coarse_hertz_case, tmp_path):
    text = coarse_hertz_case.read_text().replace(
        "values = [-5e-06, -1e-05, -1.5e-05, -2e-05, -2.5e-05]", "values = [1e-6]")
    case = tmp_path / "lift.toml"
    case.write_text(text.replace('file = "sphere_block.msh"',
                                 f'file = "{coarse_hertz_case.parent / "sphere_block.msh"}"'))
    step = StaticSolver(load_case(case)).run().steps[0]
    assert step.contact_force[0] == 0.0
    assert step.contact_area[0] == 0.0
