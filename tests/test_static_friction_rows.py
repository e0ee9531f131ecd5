"""The frictional static solve in the space of the contact rows.

A zone of more than ``FRICTION_ROW_SPACE_COORDINATES`` coordinates is solved on the
compliances of its normal and tangential rows, each kept with the Jacobian of the
projection it entered at, by a defect correction. Where the projection turns the rows
far from those Jacobians (the contact near a flank's end), the correction drifted
away instead of settling; the rows in contact are then formed again in the current
projection. Checked against the exact compliance (a dense solve) and against the
condensed formulation of the same problem.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fe_impact.solvers.static as static

GEOMETRY = Path(__file__).resolve().parents[1] / "geometry"


def test_refreshed_rows_hold_the_exact_compliance(monkeypatch):
    """After :meth:`_RowSpace.refresh`, the kept ``C`` is ``B K^-1 B^T`` of the Jacobian
    rows now held (some replaced, one met first there), to round-off: against a dense
    inverse. Solved two rows at a time, so that the blocks between chunks are formed."""
    monkeypatch.setattr(static, "ROW_BLOCK", 2)
    rng = np.random.default_rng(3)
    n = 40
    A = rng.standard_normal((n, n))
    K = sp.csr_matrix(A @ A.T + n * np.eye(n))
    Kinv = np.linalg.inv(K.toarray())
    space = static._RowSpace(K, lambda b: Kinv @ b)
    B = sp.csr_matrix(rng.standard_normal((12, n)) * (rng.random((12, n)) < 0.3))
    keys = np.arange(12) * 3
    space.prime(keys, B)
    moved = np.array([7, 2, 11, 5, 0])
    B_new = sp.csr_matrix(B[moved].toarray() + 0.2 * rng.standard_normal((5, n)))
    b_first = sp.csr_matrix(rng.standard_normal((1, n)))     # a row not met before
    space.refresh(np.append(keys[moved], 99), sp.vstack([B_new, b_first]))
    held = np.vstack([B.toarray(), b_first.toarray()])
    held[moved] = B_new.toarray()
    keys = np.append(keys, 99)
    pos = space.positions(keys, sp.csr_matrix(held))
    exact = held @ Kinv @ held.T
    # the dense inverse and the kept blocks are both exact to a few ulps of a
    # condition number of about 10 (n added to the diagonal of A A^T)
    np.testing.assert_allclose(space.C[np.ix_(pos, pos)], exact, rtol=1e-12, atol=1e-12)


@pytest.mark.slow
def test_an_end_position_of_the_25deg_drive_settles_with_friction(tmp_path, monkeypatch):
    """The 25 deg drive's coarse mesh-cycle position nearest the path's start (10.584
    deg roll, 3,752 contact coordinates: the rows' space) did not converge in 30
    projections with friction and was solved frictionless. It now settles, and its
    load-approach is the condensed formulation's (the zone's coordinates held
    directly, as below the row-space size) to the projection tolerance."""
    from fe_impact.calibration import meshcycle as mc
    from fe_impact.gears.gearset import load_gearset
    from fe_impact.meshing.toothpair import build_pair

    gearset = load_gearset(GEOMETRY / "nasa-25deg.toml")
    case = max(mc.plan_positions(gearset, [1], level="coarse"),
               key=lambda c: c.roll_angle_deg)
    pair = build_pair(gearset, case.stage, case.roll_angle_deg, "coarse", 2, mc.PAIR_GAP,
                      0.1, tmp_path / "pair", design_force=max(case.forces),
                      contact=case.contact)
    solver, rows = mc.solve_static_pair(gearset, pair, case.forces, case.friction)
    assert solver.rows is not None       # the rows' space, as in the calibration
    monkeypatch.setattr(static, "FRICTION_ROW_SPACE_COORDINATES", 10 ** 6)
    solver, full = mc.solve_static_pair(gearset, pair, case.forces, case.friction)
    assert solver.rows is None
    for a, b in zip(rows.steps, full.steps, strict=True):
        # each solve stops when its displacement's error bound is below 1e-6 of the
        # contact displacement ([analysis] tolerance): 1e-5 allows both errors
        assert a.rigid_values[0] == pytest.approx(b.rigid_values[0], rel=1e-5)
        assert a.contact_force[0] == pytest.approx(b.contact_force[0], rel=1e-5)
